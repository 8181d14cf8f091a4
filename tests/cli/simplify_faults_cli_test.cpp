// Faults around `gaussmesh simplify`'s files, run on the real binary: a run killed with SIGKILL
// (no handler runs) and run again, two runs sharing one --tmp, a --tmp that cannot be written, and
// an output on a full disk. (A full --tmp at every step, unwritable outputs and caught signals are
// in simplify_cli_test.cpp.)
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

namespace fs = std::filesystem;

std::string q(const std::string& text) { return "'" + text + "'"; }
std::string binary() { return q(gaussmesh_binary()); }

std::vector<std::string> names_in(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// A torus of 250k vertices as binary PLY: long enough out of core (about a second) to be killed
// in each of its passes.
std::string write_torus(const ScratchDir& dir) {
  ShapeOptions shape;
  shape.vertices = 250000;
  const Mesh torus = make_torus(1.0, 0.35, shape);
  const std::string in = dir.file("torus.ply");
  auto out = format::OutputFile::create(in, true);
  EXPECT_TRUE(out.is_ok());
  EXPECT_TRUE(format::write_ply(**out, torus.view(), {}).is_ok());
  EXPECT_TRUE((*out)->commit().is_ok());
  return in;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TEST(SimplifyFaults, ARunKilledAtAnyMomentDoesNotBreakTheNextAndItsFilesAreRemoved) {
  ScratchDir dir, tmp, outputs;
  const std::string in = write_torus(dir);
  const std::string out = outputs.file("out.ply");
  // PLY output, so that the last passes write a large file beside the output.
  const std::string command = binary() + " simplify " + q(in) + " -o " + q(out) + " --memory 16M --threads 2 -q --tmp " +
                              q(tmp.path().string());
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(run_command(command).exit_code, 0);
  const double whole = seconds_since(start);
  const std::string expected = read_file(out);
  fs::remove(out);
  int left_behind = 0;
  for (double at : {0.2, 0.45, 0.7, 0.85, 0.95}) {
    char delay[32];
    std::snprintf(delay, sizeof delay, "%.3f", at * whole);
    SCOPED_TRACE(std::string("SIGKILL after ") + delay + " s of " + std::to_string(whole));
    const auto killed = run_command("(" + command + " & pid=$!; sleep " + delay + "; kill -KILL $pid; wait $pid; echo status=$?)");
    if (killed.out.find("status=137") == std::string::npos) {
      EXPECT_NE(killed.out.find("status=0"), std::string::npos) << killed.out << killed.err;  // it had finished
      fs::remove(out);
      continue;
    }
    // SIGKILL runs no handler: whatever the run had made is still there.
    left_behind += !names_in(tmp.path().string()).empty() || !names_in(outputs.path().string()).empty();
    const auto rerun = run_command(command);
    ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
    EXPECT_EQ(read_file(out), expected);
    EXPECT_TRUE(names_in(tmp.path().string()).empty());
    EXPECT_EQ(names_in(outputs.path().string()), std::vector<std::string>{"out.ply"});
    fs::remove(out);
  }
  EXPECT_GT(left_behind, 0) << "no kill left anything behind: nothing was tested";
}

TEST(SimplifyFaults, TwoRunsSharingOneTmpBothFinishAndLeaveItEmpty) {
  ScratchDir dir, tmp;
  const std::string in = write_torus(dir);
  const std::string flags = " --memory 16M --threads 1 -q --tmp " + q(tmp.path().string());
  ASSERT_EQ(run_command(binary() + " simplify " + q(in) + " -o " + q(dir.file("alone.drc")) + flags).exit_code, 0);
  const std::string a = binary() + " simplify " + q(in) + " -o " + q(dir.file("a.drc")) + flags;
  const std::string b = binary() + " simplify " + q(in) + " -o " + q(dir.file("b.drc")) + flags;
  std::string script = "(";
  script += a;
  script += " & a=$!; ";
  script += b;
  script += " & b=$!; wait $a; echo a=$?; wait $b; echo b=$?)";
  const auto both = run_command(script);
  EXPECT_NE(both.out.find("a=0"), std::string::npos) << both.out << both.err;
  EXPECT_NE(both.out.find("b=0"), std::string::npos) << both.out << both.err;
  EXPECT_EQ(read_file(dir.file("a.drc")), read_file(dir.file("alone.drc")));
  EXPECT_EQ(read_file(dir.file("b.drc")), read_file(dir.file("alone.drc")));
  EXPECT_TRUE(names_in(tmp.path().string()).empty());
}

TEST(SimplifyFaults, ATmpThatCannotBeWrittenIsExitFourWithOneLine) {
  ScratchDir dir;
  write_file(dir.file("a-file"), "not a directory");
  const std::string input = q(fixture("real/cow.off"));
  const std::string out = dir.file("out.drc");
  for (const std::string& tmp : {dir.file("missing"), dir.file("a-file")}) {
    SCOPED_TRACE(tmp);
    const auto run = run_command(binary() + " simplify " + input + " -o " + q(out) + " --memory 16M --tmp " + q(tmp));
    EXPECT_EQ(run.exit_code, 4) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_EQ(run.err.rfind("gaussmesh: " + tmp + ": cannot create a temporary directory: ", 0), 0u) << run.err;
    EXPECT_FALSE(fs::exists(out));
  }
  // Read-only: root ignores permission bits, so a read-only mount.
  if (::geteuid() != 0) GTEST_SKIP() << "not root: cannot mount a read-only tmpfs (the other cases ran)";
  const std::string mount_point = dir.file("read-only");
  fs::create_directory(mount_point);
  if (::mount("tmpfs", mount_point.c_str(), "tmpfs", MS_RDONLY, "size=64k") != 0) {
    GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno) << "): the read-only case did not run";
  }
  const auto run = run_command(binary() + " simplify " + input + " -o " + q(out) + " --memory 16M --tmp " + q(mount_point));
  ::umount(mount_point.c_str());
  EXPECT_EQ(run.exit_code, 4) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_NE(run.err.find("Read-only file system"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(SimplifyFaults, AnOutputOnAFullDiskIsExitFourAndLeavesNothing) {
  if (::geteuid() != 0) GTEST_SKIP() << "not root: cannot mount a small tmpfs for the output";
  ScratchDir dir;
  const std::string mount_point = dir.file("small");
  fs::create_directory(mount_point);
  // The homer fixture's plain PLY output is about 300 KB; in core and out of core, PLY and Draco.
  for (const std::string& flags : {std::string(" --format ply"), std::string(" --format ply --memory 16M"),
                                   std::string(" --format drc --qp 24 --ratio 0.9")}) {
    SCOPED_TRACE(flags);
    if (::mount("tmpfs", mount_point.c_str(), "tmpfs", 0, "size=16k") != 0) {
      GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno) << ")";
    }
    const std::string out = mount_point + "/out";
    const auto run = run_command(binary() + " simplify " + q(fixture("real/homer.off")) + " -o " + q(out) + flags +
                                 " -q --tmp " + q(dir.path().string()));
    const std::vector<std::string> left = names_in(mount_point);
    ::umount(mount_point.c_str());
    EXPECT_EQ(run.exit_code, 4) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_EQ(run.err.rfind("gaussmesh: " + out + ": ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("No space left on device"), std::string::npos) << run.err;
    EXPECT_TRUE(left.empty()) << left.front();
    EXPECT_EQ(names_in(dir.path().string()), std::vector<std::string>{"small"});
  }
}

}  // namespace
}  // namespace gaussmesh::testing
