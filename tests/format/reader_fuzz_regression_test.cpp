// Every input the reader fuzz targets found a bug with (fixtures/fuzz/fuzz_*_reader/, one folder
// per target) goes through the same reader and the same contract check as in the fuzz target
// (fuzz/checking_sink.h, fuzz/record_check.h): each must end in a clean, located error or a mesh
// that keeps the reader contract. Before its fix each one crashed, hung, leaked or broke it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "fuzz/checking_sink.h"
#include "fuzz/record_check.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

namespace fs = std::filesystem;
using format::MeshFormat;

// The files of fixtures/fuzz/TARGET, in name order (empty when there is no such folder).
std::vector<std::string> findings(const std::string& target) {
  std::vector<std::string> files;
  fs::path dir = fs::path(fixture("fuzz")) / target;
  if (!fs::is_directory(dir)) return files;
  for (const auto& entry : fs::directory_iterator(dir)) files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

void expect_clean(const std::string& target, MeshFormat format) {
  for (const std::string& path : findings(target)) {
    SCOPED_TRACE(path);
    fuzz::ReadCheck check = fuzz::read_and_check(read_file(path), format);
    EXPECT_EQ(check.broken, "");
    if (!check.status.is_ok()) {
      EXPECT_FALSE(check.status.where().empty()) << check.status.to_string();
    }
  }
}

TEST(ReaderFuzzRegression, EveryFolderNamesATarget) {
  const std::vector<std::string> known = {"fuzz_ply_reader", "fuzz_off_reader", "fuzz_obj_reader", "fuzz_stl_reader",
                                          "fuzz_draco_reader", "fuzz_record_reader", "fuzz_simplify"};
  if (!fs::is_directory(fixture("fuzz"))) return;
  for (const auto& entry : fs::directory_iterator(fixture("fuzz"))) {
    EXPECT_NE(std::find(known.begin(), known.end(), entry.path().filename().string()), known.end()) << entry.path();
  }
}

TEST(ReaderFuzzRegression, Ply) { expect_clean("fuzz_ply_reader", MeshFormat::kPly); }
TEST(ReaderFuzzRegression, Off) { expect_clean("fuzz_off_reader", MeshFormat::kOff); }
TEST(ReaderFuzzRegression, Obj) { expect_clean("fuzz_obj_reader", MeshFormat::kObj); }
TEST(ReaderFuzzRegression, Stl) { expect_clean("fuzz_stl_reader", MeshFormat::kStl); }
TEST(ReaderFuzzRegression, Draco) { expect_clean("fuzz_draco_reader", MeshFormat::kDraco); }

TEST(ReaderFuzzRegression, RecordFile) {
  for (const std::string& path : findings("fuzz_record_reader")) {
    SCOPED_TRACE(path);
    EXPECT_EQ(fuzz::check_record_file(path, read_file(path).substr(0, 20)), "");
  }
}

}  // namespace
}  // namespace gaussmesh::testing
