// Tests for welding in `gaussmesh simplify` (--weld, --no-weld; docs/partition.md, "Scattered
// input and soups") as a user runs it: a fixture written as a triangle soup with its faces
// shuffled, in PLY and in STL, simplifies to the same bytes as the fixture given --weld, in core
// and out of core, with and without a target, and the report counts the welded vertices; --no-weld leaves a PLY soup as
// it is; the two flags together are a usage error.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "stream/core/mesh.h"
#include "tests/support/scattered_copy.h"
#include "tests/support/simplify_run.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }
std::string binary() { return q(gaussmesh_binary()); }

// A wavy sheet of 581k faces (292k vertices) as binary PLY.
void write_sheet(const std::string& path) { ASSERT_TRUE(write_binary_ply(path, make_wavy_sheet(540))); }

TEST(SimplifyWeldCli, ASoupInPlyOrStlGivesTheWeldedFixturesBytesInCoreAndOutOfCore) {
  ScratchDir dir;
  // (Not the cow: two of its vertices share a position, and welding them pinches its surface
  // at a vertex, a non-manifold input: see CowWeldedIsNonManifold.)
  for (const char* name : {"fandisk.off", "mech-holes-shark.off", "bunny-lowres.ply"}) {
    const std::string in = fixture(std::string("real/") + name);
    const std::string soup = dir.file("soup.ply"), stl = dir.file("soup.stl");
    // Faces shuffled: the renumbering orders them whatever their input order.
    ASSERT_TRUE(write_soup_copy(in, soup, 5, false));
    ASSERT_TRUE(write_soup_copy(in, stl, 9, true));
    for (const std::string target : {"", "--ratio 0.1"}) {
      SCOPED_TRACE(std::string(name) + " " + target);
      const SimplifyOutcome welded = run_simplify(dir, in, "--weld " + target);
      ASSERT_EQ(welded.exit_code, 0) << welded.err;
      EXPECT_TRUE(welded.report["reordered"].get<bool>());
      const long faces = welded.report["input_faces"].get<long>();
      for (const std::string& input : {soup, stl}) {
        // With a target, a budget that holds the whole input's collapse: under a smaller one the
        // finish runs chunk by chunk and is not the in-core run's (docs/finish.md).
        const std::string budget = target.empty() ? "16M" : "256M";
        for (const std::string& engine : {std::string("--engine in-core"), "--engine out-of-core --memory " + budget}) {
          SCOPED_TRACE(input + " " + engine);
          const SimplifyOutcome run = run_simplify(dir, input, engine + " " + target);
          ASSERT_EQ(run.exit_code, 0) << run.err;
          EXPECT_EQ(run.report["input_faces"].get<long>(), faces);
          EXPECT_EQ(run.report["input_vertices"].get<long>(), 3 * faces);
          EXPECT_EQ(run.report["welded_vertices"].get<long>(), 3 * faces - welded.report["input_vertices"].get<long>() +
                                                                   welded.report["welded_vertices"].get<long>());
          EXPECT_TRUE(run.bytes == welded.bytes);
        }
      }
    }
  }
}

TEST(SimplifyWeldCli, CowWeldedIsNonManifold) {
  // Welding by position joins the cow's two vertices at one point: the welded surface touches
  // itself there. In core the run then splits that vertex again, a vertex per fan of faces, and
  // collapses the input as without --weld; out of core a non-manifold vertex is refused (exit 3),
  // as for any such input (docs/cli.md, "Non-manifold input").
  ScratchDir dir;
  const std::string in = fixture("real/cow.off");
  const SimplifyOutcome in_core = run_simplify(dir, in, "--weld --engine in-core --ratio 0.1");
  ASSERT_EQ(in_core.exit_code, 0) << in_core.err;
  EXPECT_EQ(in_core.report["welded_vertices"].get<long>(), 1);
  EXPECT_EQ(in_core.report["split_vertices"].get<long>(), 1);
  EXPECT_EQ(in_core.report["approximation"].get<std::string>(), "input");
  const SimplifyOutcome plain = run_simplify(dir, in, "--engine in-core --ratio 0.1");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(plain.report["welded_vertices"].get<long>(), 0);
  EXPECT_EQ(plain.report["approximation"].get<std::string>(), "input");
  EXPECT_TRUE(in_core.bytes == plain.bytes);  // split where it was welded: the cow as it came
  const SimplifyOutcome out_of_core = run_simplify(dir, in, "--weld --engine out-of-core --ratio 0.1");
  EXPECT_EQ(out_of_core.exit_code, 3);
  EXPECT_NE(out_of_core.err.find("manifold"), std::string::npos) << out_of_core.err;
}

TEST(SimplifyWeldCli, ASoupStreamsUnderAHardAddressSpaceLimit) {
  // 581k faces as a soup (1.7M vertices) under --memory 16M, in a process whose address space
  // is capped at 160 MiB (ulimit -v): welded on the way, it finishes with the unlimited run's
  // bytes. Left unwelded it cannot, and says so in one line (exit 5) rather than being killed.
  ScratchDir dir;
  write_sheet(dir.file("sheet.ply"));
  const std::string soup = dir.file("soup.ply");
  ASSERT_TRUE(write_soup_copy(dir.file("sheet.ply"), soup, 3, false));
  const std::string flags = "--engine out-of-core --memory 16M --threads 2";
  const SimplifyOutcome free_run = run_simplify(dir, soup, flags);
  ASSERT_EQ(free_run.exit_code, 0) << free_run.err;
  const std::string capped = "ulimit -v 163840; ";
  const std::string out = dir.file("capped.ply");
  auto run = run_command(capped + binary() + " simplify " + q(soup) + " -o " + q(out) + " --format ply " + flags);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(read_file(out) == free_run.bytes);
  std::filesystem::remove(out);
  run = run_command(capped + binary() + " simplify " + q(soup) + " -o " + q(out) + " --format ply --no-weld " + flags);
  EXPECT_EQ(run.exit_code, 5) << run.err;
  // The command's guard on --memory (MemoryLimitCli.AnExplicitBudgetIsGuarded) usually stops it
  // first; an allocation past the cap between two of its looks is "out of memory".
  EXPECT_TRUE(run.err.find("raise --memory") != std::string::npos || run.err.find("out of memory") != std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  // Under 48 MiB not even the threads start: exit 5 and one line too, whichever fails first.
  run = run_command("ulimit -v 49152; " + binary() + " simplify " + q(soup) + " -o " + q(out) + " --format ply " + flags);
  EXPECT_EQ(run.exit_code, 5) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(SimplifyWeldCli, AFileSizeLimitInTheRenumberingIsOneLineAndLeavesNothing) {
  // ulimit -f below what the renumbering's bucket files need: the write fails (EFBIG, not a
  // SIGXFSZ kill), one line names the file, exit 4, and the temporary directory is gone.
  ScratchDir dir;
  write_sheet(dir.file("sheet.ply"));
  const std::string soup = dir.file("soup.ply"), tmp = dir.file("tmp"), out = dir.file("out.ply");
  ASSERT_TRUE(write_soup_copy(dir.file("sheet.ply"), soup, 3, false));
  std::filesystem::create_directory(tmp);
  const auto run = run_command("ulimit -f 12000; " + binary() + " simplify " + q(soup) + " -o " + q(out) +
                               " --memory 16M --engine out-of-core --tmp " + q(tmp));
  EXPECT_EQ(run.exit_code, 4) << run.err;
  EXPECT_NE(run.err.find("reorder-"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("File too large"), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_TRUE(std::filesystem::is_empty(tmp));
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(SimplifyWeldCli, NoWeldKeepsASoupAndBothFlagsAreAUsageError) {
  ScratchDir dir;
  const std::string soup = dir.file("soup.ply");
  ASSERT_TRUE(write_soup_copy(fixture("real/cow.off"), soup, 5, false));
  const SimplifyOutcome kept = run_simplify(dir, soup, "--no-weld --engine in-core");
  // A soup unwelded has no shared edge: every face is a component of its own, kept as it is.
  ASSERT_EQ(kept.exit_code, 0) << kept.err;
  EXPECT_EQ(kept.report["welded_vertices"].get<long>(), 0);
  EXPECT_FALSE(kept.report["reordered"].get<bool>());
  EXPECT_EQ(kept.report["output_faces"].get<long>(), kept.report["input_faces"].get<long>());
  const SimplifyOutcome welded = run_simplify(dir, soup, "--engine in-core");
  ASSERT_EQ(welded.exit_code, 0) << welded.err;
  EXPECT_GT(welded.report["welded_vertices"].get<long>(), 0);
  std::filesystem::remove(dir.file("out.ply"));
  const SimplifyOutcome both = run_simplify(dir, soup, "--weld --no-weld");
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_NE(both.err.find("--weld"), std::string::npos) << both.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.ply")));
}

}  // namespace
}  // namespace gaussmesh::testing
