// CLI tests of `gaussmesh sample`: outputs, report fields, orientations, option errors, and the
// out-of-core path (--memory): same bytes as in core, stdin to stdout, bad input and interruption
// leave no temporary file.
#include <algorithm>
#include <filesystem>
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

std::string q(const std::string& text) { return "'" + text + "'"; }

std::size_t files_in(const std::string& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::recursive_directory_iterator(dir)) ++n;
  return n;
}

// `sample IN flags` in core, then out of core from the file (with a report, into `report`) and
// from a pipe: the same samples PLY every time, and no temporary file left.
void expect_in_core_bytes(const std::string& name, const std::string& flags, nlohmann::json& report) {
  ScratchDir dir, tmp;
  const std::string bin = q(gaussmesh_binary());
  const std::string in = q(fixture(name));
  const std::string tag = name + flags;
  ASSERT_EQ(run_command(bin + " sample " + in + " -o " + q(dir.file("a.ply")) + flags).exit_code, 0) << tag;
  const CommandResult ooc = run_command(bin + " sample " + in + " -o " + q(dir.file("b.ply")) + flags +
                                        " --memory 16M --threads 2 --tmp " + q(tmp.path().string()) +
                                        " --report " + q(dir.file("r.json")));
  ASSERT_EQ(ooc.exit_code, 0) << tag << ": " << ooc.err;
  const CommandResult piped = run_command("cat " + in + " | " + bin + " sample - -o -" + flags + " --memory 16M --tmp " +
                                          q(tmp.path().string()) + " > " + q(dir.file("c.ply")));
  ASSERT_EQ(piped.exit_code, 0) << tag << ": " << piped.err;
  const std::string a = read_file(dir.file("a.ply"));
  EXPECT_GT(a.size(), 100u) << tag;
  EXPECT_EQ(a, read_file(dir.file("b.ply"))) << tag;
  EXPECT_EQ(a, read_file(dir.file("c.ply"))) << tag;
  EXPECT_EQ(files_in(tmp.path().string()), 0u) << "temporary files left by " << tag;
  report = nlohmann::json::parse(read_file(dir.file("r.json")));
}

TEST(SampleCli, OutOfCoreGivesTheInCoreBytesFromFilesAndPipes) {
  for (const char* name : {"real/cow.off", "real/fandisk.off", "real/bunny-lowres.ply"}) {
    nlohmann::json report;
    expect_in_core_bytes(name, " --orientations 2 --smooth 1", report);
    ASSERT_FALSE(report.is_null()) << name;
    EXPECT_EQ(report["out_of_core"], true);
    EXPECT_GE(report["chunks"].get<std::size_t>(), 1u);
    EXPECT_GT(report["bytes_spilled"].get<std::size_t>(), 0u);
    double passes = 0;
    for (const char* key : {"ingest", "partition", "sample", "cleanup", "write"}) {
      ASSERT_TRUE(report["seconds"].contains(key)) << key;
      EXPECT_GE(report["seconds"][key].get<double>(), 0.0) << key;
      passes += report["seconds"][key].get<double>();
    }
    EXPECT_LE(passes, report["seconds"]["total"].get<double>() + 1e-6) << name;
  }
}

// The paper sample test out of core: the same samples PLY as in core, from a file and a pipe.
TEST(SampleCli, OutOfCorePaperTestGivesTheInCoreBytesFromFilesAndPipes) {
  for (const char* name : {"real/cow.off", "real/fandisk.off", "real/homer.off", "real/knot1.off",
                           "real/mech-holes-shark.off", "real/mushroom.off", "real/bunny-lowres.ply"}) {
    for (const char* smooth : {"0", "2 --orientations 2"}) {
      nlohmann::json report;
      expect_in_core_bytes(name, std::string(" --sample-test paper --smooth ") + smooth, report);
      ASSERT_FALSE(report.is_null()) << name << " smooth " << smooth;
      EXPECT_EQ(report["sample_test"], "paper");
    }
  }
}

TEST(SampleCli, OutOfCoreBadInputAndOptions) {
  ScratchDir dir, tmp;
  const std::string bin = q(gaussmesh_binary());
  const std::string mem = " --memory 16M --tmp " + q(tmp.path().string());
  for (const char* bad : {"bad/OutOfMemory.off", "bad/empty.ply", "bad/invalid.off", "bad/malformed2.obj"}) {
    const CommandResult r = run_command(bin + " sample " + q(fixture(bad)) + " -o " + q(dir.file("s.ply")) + mem);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("s.ply"))) << bad;
    EXPECT_EQ(files_in(tmp.path().string()), 0u) << bad;
  }
  for (const std::string bad : {"--memory 0", "--memory 12Q", "--memory 1M", "--memory 16M --patches p.ply"}) {
    const CommandResult r = run_command(bin + " sample " + q(fixture("real/cow.off")) + " -o " + q(dir.file("s.ply")) +
                                        " --tmp " + q(tmp.path().string()) + " " + bad);
    EXPECT_EQ(r.exit_code, 1) << bad << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("s.ply"))) << bad;
  }
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
}

TEST(SampleCli, InterruptedOutOfCoreRunLeavesNoTemporaryFiles) {
  ScratchDir dir, tmp;
  // The input stalls after the header and a few vertices: the run is inside the ingest pass with its spill
  // files open when SIGINT arrives.
  const std::string cow = q(fixture("real/cow.off"));
  auto run = run_command("((head -c 20000 " + cow + "; sleep 4) | " + q(gaussmesh_binary()) + " sample - -o " +
                         q(dir.file("s.ply")) + " --memory 16M --tmp " + q(tmp.path().string()) +
                         " & pid=$!; sleep 1; ls " + q(tmp.path().string()) + " | wc -l; kill -INT $pid; wait $pid; echo status=$?)");
  EXPECT_NE(run.out.find("status=130"), std::string::npos) << run.out << run.err;
  EXPECT_EQ(run.out.substr(0, 1), "1") << "the run's temporary directory should exist before the signal: " << run.out;
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
  EXPECT_EQ(files_in(dir.path().string()), 0u);
}

}  // namespace
}  // namespace gaussmesh::testing
