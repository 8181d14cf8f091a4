// Tests for `gaussmesh simplify` as a user runs it: every real fixture to Draco, decoded by
// Google's own draco_decoder to the counts the report gives; stdin -> stdout gives the same
// bytes as file -> file; bad input, bad options, unwritable outputs and interruptions leave
// no output and no temporary file behind.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <regex>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "format/mesh_writer.h"
#include "gaussmesh/gaussmesh.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }

std::string binary() { return q(gaussmesh_binary()); }

// A torus of about twice `vertices` faces written to `path`: Draco for a .drc path, else binary
// PLY; `mesh` gets it.
std::string torus_file(const std::string& path, std::size_t vertices, Mesh& mesh) {
  ShapeOptions shape;
  shape.vertices = vertices;
  mesh = make_torus(1.0, 0.35, shape);
  auto file = format::OutputFile::create(path, true);
  EXPECT_TRUE(file.is_ok());
  const bool draco = path.ends_with(".drc");
  EXPECT_TRUE((draco ? format::write_draco(**file, mesh.view(), {}) : format::write_ply(**file, mesh.view(), {})).is_ok());
  EXPECT_TRUE((*file)->commit().is_ok());
  return path;
}

size_t files_in(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

// Counts from a PLY header ("element vertex N", "element face N").
std::pair<long, long> ply_counts(const std::string& path) {
  std::string text = read_file(path);
  std::smatch m;
  long vertices = -1, faces = -1;
  if (std::regex_search(text, m, std::regex("element vertex (\\d+)"))) vertices = std::stol(m[1]);
  if (std::regex_search(text, m, std::regex("element face (\\d+)"))) faces = std::stol(m[1]);
  return {vertices, faces};
}

class SimplifyFixture : public ::testing::TestWithParam<std::string> {};

TEST_P(SimplifyFixture, DracoOutputDecodesWithGooglesDecoderToTheReportedCounts) {
  ScratchDir dir;
  std::string out = dir.file("out.drc"), report = dir.file("r.json"), decoded = dir.file("decoded.ply");
  auto run = run_command(binary() + " simplify " + q(fixture("real/" + GetParam())) + " -o " + q(out) +
                         " --report " + q(report));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto json = nlohmann::json::parse(read_file(report));
  for (const char* field : {"input_vertices", "input_faces", "gauss_vertices", "gauss_triangles", "patches",
                            "candidates", "samples", "output_vertices", "output_faces", "chunks", "peak_rss_bytes",
                            "seconds"}) {
    EXPECT_TRUE(json.contains(field)) << field;
  }
  EXPECT_LT(json["output_faces"].get<long>(), json["input_faces"].get<long>());
  auto decode = run_command("draco_decoder -i " + q(out) + " -o " + q(decoded));
  ASSERT_EQ(decode.exit_code, 0) << decode.out << decode.err;
  auto [vertices, faces] = ply_counts(decoded);
  EXPECT_EQ(faces, json["output_faces"].get<long>());
  EXPECT_EQ(vertices, json["output_vertices"].get<long>());
  EXPECT_EQ(json["output_bytes"].get<long>(), static_cast<long>(std::filesystem::file_size(out)));
  EXPECT_EQ(files_in(dir.path().string()), 3u) << "only out.drc, r.json and decoded.ply";
}

INSTANTIATE_TEST_SUITE_P(Real, SimplifyFixture,
                         ::testing::Values("cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off",
                                           "mushroom.off", "bunny-lowres.ply"),
                         [](const auto& info) {
                           std::string name = info.param.substr(0, info.param.find('.'));
                           for (auto& c : name) c = c == '-' ? '_' : c;
                           return name;
                         });

TEST(SimplifyCli, StdinToStdoutGivesTheSameBytesAsFileToFile) {
  ScratchDir dir;
  std::string input = fixture("real/fandisk.off");
  auto a = run_command(binary() + " simplify " + q(input) + " -o " + q(dir.file("a.drc")) + " -q");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  auto b = run_command("cat " + q(input) + " | " + binary() + " simplify - -o - -q > " + q(dir.file("b.drc")));
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(read_file(dir.file("a.drc")), read_file(dir.file("b.drc")));
  EXPECT_FALSE(read_file(dir.file("a.drc")).empty());
}

TEST(SimplifyCli, FormatsFollowTheExtensionOrTheFlag) {
  ScratchDir dir;
  std::string input = q(fixture("real/cow.off"));
  ASSERT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("x.ply")) + " -q").exit_code, 0);
  ASSERT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("x.obj")) + " -q").exit_code, 0);
  ASSERT_EQ(run_command(binary() + " simplify " + input + " --format ply-ascii -o " + q(dir.file("x.out")) + " -q").exit_code, 0);
  EXPECT_EQ(read_file(dir.file("x.ply")).rfind("ply\nformat binary_little_endian 1.0", 0), 0u);
  EXPECT_NE(read_file(dir.file("x.obj")).find("\nf "), std::string::npos);
  EXPECT_EQ(read_file(dir.file("x.out")).rfind("ply\nformat ascii 1.0", 0), 0u);
  // The PLY output reads back with the counts info reports.
  auto info = run_command(binary() + " info " + q(dir.file("x.ply")));
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("closed manifold        yes"), std::string::npos) << info.out;
}

TEST(SimplifyCli, GlbAndGltfFollowTheExtensionOrTheFlag) {
  ScratchDir dir;
  std::string input = q(fixture("real/cow.off"));
  ASSERT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("x.glb")) + " -q").exit_code, 0);
  ASSERT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("x.gltf")) + " -q").exit_code, 0);
  ASSERT_EQ(run_command(binary() + " simplify " + input + " --format glb -o " + q(dir.file("x.out")) + " -q").exit_code, 0);
  auto piped = run_command(binary() + " simplify " + input + " --format glb -o - -q > " + q(dir.file("piped.glb")));
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(read_file(dir.file("x.glb")).rfind("glTF", 0), 0u);
  EXPECT_EQ(read_file(dir.file("x.out")), read_file(dir.file("x.glb")));
  EXPECT_EQ(read_file(dir.file("piped.glb")), read_file(dir.file("x.glb")));
  // Out of core, from a pipe, the same bytes: the container adds nothing that depends on the run.
  auto streamed = run_command("cat " + input + " | " + binary() + " simplify - --format glb -o - -q --engine out-of-core --memory 16M > " +
                              q(dir.file("streamed.glb")));
  ASSERT_EQ(streamed.exit_code, 0) << streamed.err;
  EXPECT_EQ(read_file(dir.file("streamed.glb")), read_file(dir.file("x.glb")));
  EXPECT_NE(read_file(dir.file("x.gltf")).find("\"KHR_draco_mesh_compression\""), std::string::npos);
  EXPECT_EQ(run_command(binary() + " simplify " + input + " --format gltf2 -o " + q(dir.file("y")) + " -q").exit_code, 1);
}

// An output that is a device (or a pipe) is written in place: a rename onto it would replace it.
TEST(SimplifyCli, OutputToDevNullLeavesItADevice) {
  auto run = run_command(binary() + " simplify " + q(fixture("real/cow.off")) + " -o /dev/null -q");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  struct stat node {};
  ASSERT_EQ(::stat("/dev/null", &node), 0);
  EXPECT_TRUE(S_ISCHR(node.st_mode));
}

// Decision (docs/cli.md): a face that names a vertex twice (or three times) has no surface; it
// is left out, so the cow with such faces added gives the cow's bytes, in core (which counts
// them in skipped_input_faces) and out of core.
TEST(SimplifyCli, FacesWithARepeatedCornerAreLeftOut) {
  ScratchDir dir, tmp;
  std::string text = read_file(fixture("real/cow.off"));
  std::smatch counts;
  ASSERT_TRUE(std::regex_search(text, counts, std::regex("OFF\\s+(\\d+)\\s+(\\d+)")));
  const long faces = std::stol(counts[2]);
  std::string extra;
  for (int i = 0; i < 40; ++i) extra += "3 " + std::to_string(i * 7) + " " + std::to_string(i * 7) + " " + std::to_string(i * 7 + 1) + "\n";
  extra += "3 5 5 5\n";
  text.replace(counts.position(2), counts.length(2), std::to_string(faces + 41));
  if (text.back() != '\n') text += '\n';
  write_file(dir.file("with-repeats.off"), text + extra);
  for (const std::string& engine : {std::string(" --engine in-core"), " --memory 16M --tmp " + q(tmp.path().string())}) {
    auto clean = run_command(binary() + " simplify " + q(fixture("real/cow.off")) + " -o " + q(dir.file("clean.drc")) + engine + " -q");
    auto repeats = run_command(binary() + " simplify " + q(dir.file("with-repeats.off")) + " -o " + q(dir.file("repeats.drc")) +
                               engine + " -q --report " + q(dir.file("r.json")));
    ASSERT_EQ(clean.exit_code, 0) << clean.err;
    ASSERT_EQ(repeats.exit_code, 0) << repeats.err;
    EXPECT_EQ(read_file(dir.file("repeats.drc")), read_file(dir.file("clean.drc"))) << engine;
    auto json = nlohmann::json::parse(read_file(dir.file("r.json")));
    EXPECT_EQ(json["input_faces"], faces + 41) << engine;
    if (engine == " --engine in-core") {
      EXPECT_EQ(json["skipped_input_faces"], 41);
    }
  }
}

TEST(SimplifyCli, BadInputLeavesNothingBehind) {
  ScratchDir dir;
  for (const char* bad : {"bad/OutOfMemory.off", "bad/empty.ply", "bad/invalid.off", "bad/malformed2.obj", "bad/nan-vertex.ply", "bad/inf-vertex.ply"}) {
    auto run = run_command(binary() + " simplify " + q(fixture(bad)) + " -o " + q(dir.file("out.drc")));
    EXPECT_EQ(run.exit_code, 2) << bad << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_NE(run.err.find(bad), std::string::npos) << run.err;
    EXPECT_EQ(files_in(dir.path().string()), 0u) << bad;
  }
}

TEST(SimplifyCli, UsageErrorsExitOne) {
  ScratchDir dir;
  std::string input = q(fixture("real/cow.off"));
  EXPECT_EQ(run_command(binary() + " simplify " + input).exit_code, 1);  // no -o
  EXPECT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("o.drc")) + " --mesher nope").exit_code, 1);
  EXPECT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("o.drc")) + " --qp 0").exit_code, 1);
  EXPECT_EQ(run_command(binary() + " simplify " + input + " -o " + q(dir.file("o.drc")) + " --format xyz").exit_code, 1);
  EXPECT_EQ(files_in(dir.path().string()), 0u);
}

TEST(SimplifyCli, UnwritableOutputIsExitFourAndKeepsTheOldFile) {
  ScratchDir dir;
  std::string input = q(fixture("real/cow.off"));
  auto run = run_command(binary() + " simplify " + input + " -o " + q(dir.file("missing/dir/out.drc")));
  EXPECT_EQ(run.exit_code, 4) << run.err;
  // A failed run never clobbers an existing output: the old file stays as it was.
  write_file(dir.file("keep.drc"), "previous result");
  auto bad = run_command(binary() + " simplify " + q(fixture("bad/invalid.off")) + " -o " + q(dir.file("keep.drc")));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(read_file(dir.file("keep.drc")), "previous result");
  EXPECT_EQ(files_in(dir.path().string()), 1u);
}

TEST(SimplifyCli, InterruptedRunLeavesNoFiles) {
  ScratchDir dir;
  // The input never ends; SIGINT arrives while gaussmesh waits on stdin.
  auto run = run_command("(sleep 30 | " + binary() + " simplify - -o " + q(dir.file("out.drc")) +
                         " & pid=$!; sleep 1; kill -INT $pid; wait $pid; echo status=$?)");
  EXPECT_NE(run.out.find("status=130"), std::string::npos) << run.out << run.err;
  EXPECT_EQ(files_in(dir.path().string()), 0u);
}

TEST(SimplifyCli, SignalsDuringTheChunkPassesLeaveNoTemporaryFiles) {
  // SIGTERM at several moments of an out-of-core run on two threads. In the chunk passes each
  // chunk spills record files, so while the handler empties the temporary directory the other
  // thread goes on creating files there, and a listing made before a file exists misses it.
  // Every run must leave none.
  ScratchDir dir, tmp;
  Mesh torus;
  const std::string in = torus_file(dir.file("torus.ply"), 250000, torus);
  const std::string command = binary() + " simplify " + q(in) + " -o " + q(dir.file("out.drc")) +
                              " --memory 16M --threads 2 -q --tmp " + q(tmp.path().string());
  // A whole run, to spread the signals over its length.
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(run_command(command).exit_code, 0);
  const double whole = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(files_in(tmp.path().string()), 0u);
  for (double at : {0.35, 0.5, 0.6, 0.7, 0.8, 0.9}) {
    char delay[32];
    std::snprintf(delay, sizeof delay, "%.3f", at * whole);
    const auto run = run_command("(" + command + " & pid=$!; sleep " + delay + "; kill -TERM $pid; wait $pid; echo status=$?)");
    // The signal may come after the run has finished (status 0): it has removed its files too.
    EXPECT_TRUE(run.out.find("status=143") != std::string::npos || run.out.find("status=0") != std::string::npos)
        << run.out << run.err;
    EXPECT_EQ(files_in(tmp.path().string()), 0u) << "signal after " << delay << " s of " << whole;
    std::filesystem::remove(dir.file("out.drc"));
  }
}

TEST(SimplifyCli, AFullTemporaryDiskAtAnyStepIsExitFourAndLeavesNothing) {
  // An out-of-core run with --tmp on a tmpfs too small for it, at sizes from where the
  // partition's first spill fails up to the first size that holds the whole run: every failing
  // run exits 4 with one line naming the file it could not write, leaves no temporary file and
  // no output. The fine steps below the top reach the stitch's own files (positions, loops, ids).
  if (::geteuid() != 0) GTEST_SKIP() << "not root: cannot mount a small tmpfs";
  ScratchDir dir;
  const std::string mount_point = dir.file("small");
  std::filesystem::create_directory(mount_point);
  const std::string out = dir.file("out.drc");
  std::set<std::string> failed_files;
  // kb -> succeeded; checks every failure on the way.
  auto run_at = [&](int kb) {
    const std::string options = "size=" + std::to_string(kb) + "k";
    if (::mount("tmpfs", mount_point.c_str(), "tmpfs", 0, options.c_str()) != 0) return -1;
    const auto run = run_command(binary() + " simplify " + q(fixture("real/homer.off")) + " -o " + q(out) +
                                 " --memory 16M -q --tmp " + q(mount_point));
    const std::size_t left = files_in(mount_point);
    ::umount(mount_point.c_str());
    EXPECT_EQ(left, 0u) << kb << " KiB: " << run.err;
    if (run.exit_code == 0) {
      EXPECT_TRUE(std::filesystem::exists(out)) << kb << " KiB";
      std::filesystem::remove(out);
      return 1;
    }
    EXPECT_EQ(run.exit_code, 4) << kb << " KiB: " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_NE(run.err.find(mount_point + "/"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << kb << " KiB";
    std::smatch m;
    if (std::regex_search(run.err, m, std::regex("/([a-z0-9.-]+): "))) failed_files.insert(m[1]);
    return 0;
  };
  int top = 0;  // the first size, in steps of 128 KiB, that holds the run
  for (int kb = 128; kb <= 8192 && top == 0; kb += 128) {
    const int r = run_at(kb);
    if (r < 0) GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno) << ")";
    if (r == 1) top = kb;
  }
  ASSERT_GT(top, 128) << "the run fits in 128 KiB: nothing was tested";
  // Then down from there a page at a time until each of the stitch's last files has failed (it
  // writes them last, so they fail just below the top), at most 1 MiB down.
  const char* const last_files[] = {"loop-positions.bin", "loop-vertices.bin", "loop-ids.bin"};
  auto all_failed = [&] {
    return std::all_of(std::begin(last_files), std::end(last_files), [&](const char* f) { return failed_files.count(f) > 0; });
  };
  for (int kb = top - 4; kb >= std::max(128, top - 1024) && !all_failed(); kb -= 4) run_at(kb);
  std::string seen;
  for (const auto& f : failed_files) seen += f + " ";
  std::printf("holds at %d KiB; failures in %s\n", top, seen.c_str());
  for (const char* f : last_files) EXPECT_TRUE(failed_files.count(f)) << f << " never failed; failures in " << seen;
}

TEST(SimplifyCli, OutOfCoreGivesTheInCoreBytesFromFilesAndPipes) {
  ScratchDir dir, tmp;
  for (const char* name : {"real/cow.off", "real/fandisk.off", "real/mech-holes-shark.off", "real/bunny-lowres.ply"}) {
    const std::string in = q(fixture(name));
    ASSERT_EQ(run_command(binary() + " simplify " + in + " -o " + q(dir.file("a.drc"))).exit_code, 0);
    const auto ooc = run_command(binary() + " simplify " + in + " -o " + q(dir.file("b.drc")) + " --memory 16M --tmp " +
                                 q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
    ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
    const auto piped = run_command("cat " + in + " | " + binary() + " simplify - -o - --memory 16M --threads 1 --tmp " +
                                   q(tmp.path().string()) + " > " + q(dir.file("c.drc")));
    ASSERT_EQ(piped.exit_code, 0) << piped.err;
    const std::string a = read_file(dir.file("a.drc"));
    EXPECT_GT(a.size(), 100u);
    EXPECT_EQ(a, read_file(dir.file("b.drc"))) << name;
    EXPECT_EQ(a, read_file(dir.file("c.drc"))) << name;
    const auto report = nlohmann::json::parse(read_file(dir.file("r.json")));
    EXPECT_EQ(report["out_of_core"], true);
    for (const char* key : {"chunks", "bytes_spilled", "peak_rss_bytes", "stitch_half_edges"})
      EXPECT_TRUE(report.contains(key)) << key;
    double passes = 0;
    for (const char* key : {"ingest", "partition", "sample", "stitch", "mesh", "cleanup", "write"}) {
      ASSERT_TRUE(report["seconds"].contains(key)) << key;
      EXPECT_GE(report["seconds"][key].get<double>(), 0.0) << key;
      passes += report["seconds"][key].get<double>();
    }
    EXPECT_LE(passes, report["seconds"]["total"].get<double>() + 1e-6) << name;
    // The stitch's steps are parts of its time.
    double steps = 0;
    for (const char* key : {"pieces", "merge", "loops", "loop_stitch"}) {
      ASSERT_TRUE(report["stitch_seconds"].contains(key)) << key;
      EXPECT_GE(report["stitch_seconds"][key].get<double>(), 0.0) << key;
      steps += report["stitch_seconds"][key].get<double>();
    }
    EXPECT_LE(steps, report["seconds"]["stitch"].get<double>() + 1e-6) << name;
    EXPECT_EQ(files_in(tmp.path().string()), 0u) << name;
  }
}

// The paper sample test out of core: the same bytes as in core, from a file and from a pipe.
TEST(SimplifyCli, OutOfCorePaperTestGivesTheInCoreBytesFromFilesAndPipes) {
  ScratchDir dir, tmp;
  for (const char* name : {"real/cow.off", "real/fandisk.off", "real/homer.off", "real/knot1.off",
                           "real/mech-holes-shark.off", "real/mushroom.off", "real/bunny-lowres.ply"}) {
    for (const char* smooth : {"0", "2 --orientations 2"}) {
      const std::string in = q(fixture(name));
      const std::string flags = std::string(" --sample-test paper --smooth ") + smooth;
      ASSERT_EQ(run_command(binary() + " simplify " + in + " -o " + q(dir.file("a.drc")) + flags).exit_code, 0);
      const auto ooc = run_command(binary() + " simplify " + in + " -o " + q(dir.file("b.drc")) + flags +
                                   " --memory 16M --tmp " + q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
      ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
      const auto piped = run_command("cat " + in + " | " + binary() + " simplify - -o -" + flags +
                                     " --memory 16M --threads 1 --tmp " + q(tmp.path().string()) + " > " +
                                     q(dir.file("c.drc")));
      ASSERT_EQ(piped.exit_code, 0) << piped.err;
      const std::string a = read_file(dir.file("a.drc"));
      EXPECT_GT(a.size(), 100u);
      EXPECT_EQ(a, read_file(dir.file("b.drc"))) << name << " smooth " << smooth;
      EXPECT_EQ(a, read_file(dir.file("c.drc"))) << name << " smooth " << smooth;
      const auto report = nlohmann::json::parse(read_file(dir.file("r.json")));
      EXPECT_EQ(report["sample_test"], "paper");
      EXPECT_TRUE(report.contains("candidate_pairs"));
      EXPECT_TRUE(report["stitch_seconds"].contains("chains"));
      EXPECT_EQ(files_in(tmp.path().string()), 0u) << name;
    }
  }
}

TEST(SimplifyCli, WithoutMemoryASmallFileRunsInCoreAsDoesAShortPipe) {
  // The automatic engine (docs/cli.md, "Memory budget"): a fixture file is small enough for in
  // core; a pipe that short is copied to a file first and runs in core too; a budget smaller than
  // the in-core working set streams a file. The bytes are the same each way.
  ScratchDir dir, tmp;
  const std::string input = q(fixture("real/fandisk.off"));
  const std::string tmp_flag = " --tmp " + q(tmp.path().string());
  auto file = run_command(binary() + " simplify " + input + " -o " + q(dir.file("a.drc")) + " -q --report " +
                          q(dir.file("a.json")) + tmp_flag);
  ASSERT_EQ(file.exit_code, 0) << file.err;
  auto pipe = run_command("cat " + input + " | " + binary() + " simplify - -o " + q(dir.file("b.drc")) +
                          " -q --report " + q(dir.file("b.json")) + tmp_flag);
  ASSERT_EQ(pipe.exit_code, 0) << pipe.err;
  auto tight = run_command(binary() + " simplify " + input + " -o " + q(dir.file("c.drc")) + " -q --memory 16M --report " +
                           q(dir.file("c.json")) + tmp_flag);
  ASSERT_EQ(tight.exit_code, 0) << tight.err;
  const auto a = nlohmann::json::parse(read_file(dir.file("a.json")));
  const auto b = nlohmann::json::parse(read_file(dir.file("b.json")));
  const auto c = nlohmann::json::parse(read_file(dir.file("c.json")));
  EXPECT_FALSE(a["out_of_core"].get<bool>());
  EXPECT_FALSE(b["out_of_core"].get<bool>());
  EXPECT_TRUE(c["out_of_core"].get<bool>());
  EXPECT_EQ(c["memory_bytes"].get<std::uint64_t>(), std::uint64_t{16} << 20);
  EXPECT_EQ(read_file(dir.file("a.drc")), read_file(dir.file("b.drc")));
  EXPECT_EQ(read_file(dir.file("a.drc")), read_file(dir.file("c.drc")));
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
}

// A pipe longer than the largest file the size rule holds in core streams as before, through the
// copy of its first 64 MiB and then the rest: fandisk as OBJ followed by 65 MiB of comment lines
// gives the bytes of the same file (which streams by its size) and of the fixture, within the
// automatic budget, and leaves nothing in --tmp.
TEST(SimplifyCli, APipeLongerThanTheLargestInCoreFileStreamsAsTheFileDoes) {
  ScratchDir dir, tmp;
  auto mesh = stream::load_mesh(fixture("real/fandisk.off"));
  ASSERT_TRUE(mesh) << mesh.status().to_string();
  std::string text;
  char line[128];
  for (const auto& p : mesh->positions) {
    std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
    text += line;
  }
  for (const auto& t : mesh->triangles) {
    std::snprintf(line, sizeof line, "f %u %u %u\n", t.v[0] + 1, t.v[1] + 1, t.v[2] + 1);
    text += line;
  }
  const std::string comment = "# " + std::string(125, 'x') + "\n";
  text.reserve(text.size() + (std::size_t{65} << 20) + comment.size());
  while (text.size() < gaussmesh::kInCoreMaxFileBytes + (std::size_t{1} << 20)) text += comment;
  const std::string in = dir.file("padded.obj");
  write_file(in, text);
  const std::string flags = " -q --ratio 0.1 --tmp " + q(tmp.path().string());
  auto file = run_command(binary() + " simplify " + q(in) + " -o " + q(dir.file("a.ply")) + flags + " --report " + q(dir.file("a.json")));
  ASSERT_EQ(file.exit_code, 0) << file.err;
  auto pipe = run_command("cat " + q(in) + " | " + binary() + " simplify - -o " + q(dir.file("b.ply")) + flags + " --report " +
                          q(dir.file("b.json")));
  ASSERT_EQ(pipe.exit_code, 0) << pipe.err;
  auto plain = run_command(binary() + " simplify " + q(fixture("real/fandisk.off")) + " -o " + q(dir.file("c.ply")) + flags +
                           " --engine out-of-core");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_TRUE(nlohmann::json::parse(read_file(dir.file("a.json")))["out_of_core"].get<bool>());
  EXPECT_TRUE(nlohmann::json::parse(read_file(dir.file("b.json")))["out_of_core"].get<bool>());
  EXPECT_TRUE(read_file(dir.file("a.ply")) == read_file(dir.file("b.ply")));
  EXPECT_TRUE(read_file(dir.file("a.ply")) == read_file(dir.file("c.ply")));
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
}

// A Draco file is counted by the faces its header declares, not by its size (Draco takes far
// fewer than 16 bytes a face): a torus of 400k faces to 10 % under --memory 64M would need more
// than 200 MiB in core with its target, so it streams, the decode within the budget.
TEST(SimplifyCli, ADracoFileIsChosenByItsFacesNotItsSize) {
  ScratchDir dir, tmp;
  Mesh torus;
  const std::string in = torus_file(dir.file("torus.drc"), 200000, torus);
  // Small enough that its size alone (16 B a face) would have it held in core under this budget:
  // 16 MiB + 96 B a face, and 512 B a face more with a target (docs/cli.md, "Memory budget").
  ASSERT_LT((std::uint64_t{16} << 20) + (96 + 512) * (std::filesystem::file_size(in) / 16), std::uint64_t{64} << 20);
  auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(dir.file("out.ply")) +
                         " -q --ratio 0.1 --memory 64M --tmp " + q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(read_file(dir.file("r.json")));
  EXPECT_TRUE(report["out_of_core"].get<bool>());
  EXPECT_EQ(report["input_faces"].get<std::size_t>(), torus.triangles.size());
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
}

TEST(SimplifyCli, OutOfCoreBadInputAndRefusedOptions) {
  ScratchDir dir, tmp;
  const std::string mem = " --memory 16M --tmp " + q(tmp.path().string());
  for (const char* bad : {"bad/OutOfMemory.off", "bad/empty.ply", "bad/invalid.off", "bad/malformed2.obj", "bad/nan-vertex.ply", "bad/inf-vertex.ply"}) {
    auto run = run_command(binary() + " simplify " + q(fixture(bad)) + " -o " + q(dir.file("out.drc")) + mem);
    EXPECT_EQ(run.exit_code, 2) << bad << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_EQ(files_in(dir.path().string()), 0u) << bad;
    EXPECT_EQ(files_in(tmp.path().string()), 0u) << bad;
  }
  for (const std::string bad : {"--mesher voronoi", "--memory 1M", "--engine sideways", "--memory auto --engine out-of-core --mesher voronoi"}) {
    auto run = run_command(binary() + " simplify " + q(fixture("real/cow.off")) + " -o " + q(dir.file("out.drc")) + mem +
                           " " + bad);
    EXPECT_EQ(run.exit_code, 1) << bad << ": " << run.err;
    EXPECT_EQ(files_in(dir.path().string()), 0u) << bad;
  }
  EXPECT_EQ(files_in(tmp.path().string()), 0u);
}

}  // namespace
}  // namespace gaussmesh::testing
