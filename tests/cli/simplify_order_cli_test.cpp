// Tests that `gaussmesh simplify` gives the same bytes for every numbering of the same mesh
// (docs/partition.md, "Scattered input and soups"): each fixture and a copy with its vertex ids
// and faces shuffled, and a generated sheet large enough to be renumbered when shuffled against
// its ordered file (which is not), in core and out of core, without and with a face target.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "stream/core/mesh.h"
#include "tests/support/scattered_copy.h"
#include "tests/support/simplify_run.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

// Without a target (the Gauss approximation), with a ratio in core, and with one out of core
// under a budget that collapses the whole input at once. (Under a smaller one the finish runs
// chunk by chunk on the input's own ids: docs/finish.md.)
const std::vector<std::string> kRuns = {"--engine in-core", "--engine out-of-core --memory 16M",
                                        "--engine in-core --ratio 0.1", "--engine out-of-core --memory 1G --ratio 0.01"};

void expect_same_bytes(const ScratchDir& dir, const std::string& ordered, const std::string& shuffled) {
  for (const std::string& flags : kRuns) {
    SCOPED_TRACE(flags);
    const SimplifyOutcome a = run_simplify(dir, ordered, flags);
    const SimplifyOutcome b = run_simplify(dir, shuffled, flags);
    ASSERT_EQ(a.exit_code, 0) << a.err;
    ASSERT_EQ(b.exit_code, 0) << b.err;
    EXPECT_GT(a.report["output_faces"].get<long>(), 0);
    EXPECT_EQ(a.report["output_faces"], b.report["output_faces"]);
    EXPECT_TRUE(a.bytes == b.bytes) << "the shuffled copy's output differs";
  }
}

TEST(SimplifyOrderCli, AShuffledFixtureGivesTheFixturesBytes) {
  ScratchDir dir;
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                           "bunny-lowres.ply"}) {
    SCOPED_TRACE(name);
    const std::string in = fixture(std::string("real/") + name), shuffled = dir.file("shuffled.ply");
    ASSERT_TRUE(write_scattered_copy(in, shuffled, 11));
    expect_same_bytes(dir, in, shuffled);
  }
}

TEST(SimplifyOrderCli, AShuffledSheetIsRenumberedAndGivesTheOrderedFilesBytes) {
  // 581k faces: enough for the order probe to call the shuffled copy scattered, so it is
  // renumbered in spatial order while the ordered file keeps its own numbering.
  ScratchDir dir;
  const stream::Mesh sheet = make_wavy_sheet(540);
  const std::string ordered = dir.file("sheet.ply"), shuffled = dir.file("shuffled.ply");
  ASSERT_TRUE(write_binary_ply(ordered, sheet));
  ASSERT_TRUE(write_binary_ply(shuffled, scattered_mesh(sheet, 3)));
  const SimplifyOutcome a = run_simplify(dir, ordered, "--engine in-core");
  const SimplifyOutcome b = run_simplify(dir, shuffled, "--engine in-core");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_FALSE(a.report["reordered"].get<bool>());
  EXPECT_TRUE(b.report["reordered"].get<bool>());
  expect_same_bytes(dir, ordered, shuffled);
}

}  // namespace
}  // namespace gaussmesh::testing
