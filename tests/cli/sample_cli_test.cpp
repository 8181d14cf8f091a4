// CLI tests of `gaussmesh sample`: outputs, report fields, orientations, option errors.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

TEST(SampleCli, WritesSamplesPatchesAndAReportOnAFixture) {
  ScratchDir dir;
  const std::string cmd = gaussmesh_binary() + " sample " + fixture("real/cow.off") + " -o " + dir.file("s.ply") +
                          " --patches " + dir.file("p.ply") + " --report " + dir.file("r.json") + " --orientations 3";
  const CommandResult r = run_command(cmd);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(read_file(dir.file("r.json")));
  for (const char* key : {"input_vertices", "input_faces", "gauss_vertices", "gauss_triangles", "patches", "candidates",
                          "samples", "peak_rss_bytes", "seconds"})
    EXPECT_TRUE(report.contains(key)) << key;
  EXPECT_EQ(report["gauss_vertices"], 162);  // icosa, default f = 4
  EXPECT_EQ(report["orientations"].size(), 3u);
  // The kept orientation has the fewest samples.
  std::size_t fewest = SIZE_MAX;
  for (const auto& o : report["orientations"]) fewest = std::min<std::size_t>(fewest, o["samples"]);
  EXPECT_EQ(report["samples"], fewest);
  const std::string samples = read_file(dir.file("s.ply"));
  EXPECT_NE(samples.find("element vertex " + std::to_string(report["samples"].get<std::size_t>())), std::string::npos);
  EXPECT_NE(samples.find("property uint input_vertex"), std::string::npos);
  const std::string patches = read_file(dir.file("p.ply"));
  EXPECT_NE(patches.find("element face 5804"), std::string::npos);
}

TEST(SampleCli, LevelPaperTestAndStdin) {
  ScratchDir dir;
  const CommandResult r = run_command("cat " + fixture("real/fandisk.off") + " | " + gaussmesh_binary() +
                                      " sample - -o " + dir.file("s.ply") + " --level 1 --sample-test paper --report -");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["gauss_vertices"], 42);
  EXPECT_EQ(report["sample_test"], "paper");
}

TEST(SampleCli, BadOptionsAreUsageErrors) {
  ScratchDir dir;
  for (const std::string bad : {"--base cube", "--frequency 2 --level 1", "--sample-test fuzzy", "--rotation 1,2",
                                "--orientations 0", "--frequency 0"}) {
    const CommandResult r =
        run_command(gaussmesh_binary() + " sample " + fixture("real/cow.off") + " -o " + dir.file("s.ply") + " " + bad);
    EXPECT_EQ(r.exit_code, 1) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("gaussmesh:"), std::string::npos) << bad;
  }
  const CommandResult missing = run_command(gaussmesh_binary() + " sample " + dir.file("nope.off") + " -o " + dir.file("s.ply"));
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
}

}  // namespace
}  // namespace gaussmesh::testing
