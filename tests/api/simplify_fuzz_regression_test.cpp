// Every input fuzz_simplify found a bug with (fixtures/fuzz/fuzz_simplify/) goes through the same
// two in-core simplify runs and output checks as in the fuzz target (fuzz/simplify_check.h, which
// gives the byte layout): each must end in an error value or a valid mesh. Before its fix each
// one crashed, hung or gave an output that broke an invariant.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "fuzz/simplify_check.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

namespace fs = std::filesystem;

TEST(SimplifyFuzzRegression, EveryFindingGivesAnErrorOrAValidMesh) {
  fs::path dir = fs::path(fixture("fuzz")) / "fuzz_simplify";
  if (!fs::is_directory(dir)) GTEST_SKIP() << "no findings in " << dir;
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(dir)) files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    EXPECT_EQ(fuzz::check_simplify(read_file(path)), "");
  }
}

}  // namespace
}  // namespace gaussmesh::testing
