// `gaussmesh simplify` under the memory limits a process runs under (docs/cli.md, "Memory budget"): an
// rlimit (ulimit -v) or a memory cgroup (a container's limit). The automatic budget and the
// choice of engine come from the limit, not from physical memory, so an input that would run in
// core on the machine streams inside the limit instead of being killed; an explicit --memory above
// the limit is refused with exit 5 and one line, before any output.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/support/scattered_copy.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }

std::string simplify_command(const ScratchDir& dir, const std::string& in, const std::string& flags) {
  return q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(dir.file("out.ply")) + " --format ply --report " +
         q(dir.file("report.json")) + " " + flags;
}

TEST(MemoryLimitCli, AnAddressSpaceLimitSetsTheAutomaticBudgetAndCapsAnExplicitOne) {
  ScratchDir dir;
  const std::string in = fixture("real/cow.off");
  // 2 GiB of address space: the automatic budget is 1/64 of it.
  auto run = run_command("ulimit -v 2097152; " + simplify_command(dir, in, "--engine out-of-core"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(read_file(dir.file("report.json")));
  EXPECT_EQ(report["memory_bytes"].get<std::uint64_t>(), (std::uint64_t{2} << 30) / 64);
  std::filesystem::remove(dir.file("out.ply"));
  run = run_command("ulimit -v 2097152; " + simplify_command(dir, in, "--memory 3G"));
  EXPECT_EQ(run.exit_code, 5) << run.err;
  EXPECT_NE(run.err.find("--memory"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("RLIMIT_AS"), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.ply")));
}

// A child memory cgroup of this process's with `bytes` as its limit, or "" with `why` set when
// this machine does not let the test make one (not root, no cgroup v1 memory hierarchy or v2
// memory controller mounted, as in a bare chroot).
std::string make_memory_cgroup(std::uint64_t bytes, std::string& why) {
  std::ifstream self("/proc/self/cgroup");
  for (std::string line; std::getline(self, line);) {
    const std::size_t a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    // Built by appends: GCC 12 warns (-Wrestrict, a false positive) on "," + substr + "," here.
    std::string controllers = ",";
    controllers.append(line, a + 1, b - a - 1).push_back(',');
    const std::string group = line.substr(b + 1);
    std::string base, file;
    if (controllers.find(",memory,") != std::string::npos) {
      base = "/sys/fs/cgroup/memory" + group, file = "memory.limit_in_bytes";
    } else if (line.compare(0, 2, "0:") == 0 && controllers == ",,") {
      base = "/sys/fs/cgroup" + group, file = "memory.max";
    } else {
      continue;
    }
    const std::string dir = base + "/gaussmesh-test-" + std::to_string(::getpid());
    std::error_code error;
    std::filesystem::create_directory(dir, error);
    if (error) {
      why = "cannot create " + dir + ": " + error.message();
      continue;
    }
    std::ofstream(dir + "/" + file) << bytes << "\n";
    std::ifstream check(dir + "/" + file);
    std::uint64_t set = 0;
    if (check >> set && set == bytes) return dir;
    std::filesystem::remove(dir, error);
    why = "cannot set " + file + " in " + dir;
  }
  if (why.empty()) why = "no memory cgroup is mounted";
  return "";
}

TEST(MemoryLimitCli, InsideAMemoryCgroupAnInputTooLargeForItStreamsInsteadOfBeingKilled) {
  std::string why;
  const std::uint64_t limit = std::uint64_t{96} << 20;
  const std::string group = make_memory_cgroup(limit, why);
  if (group.empty()) GTEST_SKIP() << "needs a memory cgroup of its own: " << why;
  ScratchDir dir;
  // 581k faces: under a quarter of this machine's memory it would run in core (a few hundred
  // MiB), which the cgroup's 96 MiB would not survive.
  const std::string in = dir.file("sheet.ply");
  ASSERT_TRUE(write_binary_ply(in, make_wavy_sheet(540)));
  const std::string enter = "echo $$ > " + q(group + "/cgroup.procs") + " && exec ";
  auto run = run_command("sh -c " + q(enter + simplify_command(dir, in, "--ratio 0.05")));
  const auto report = run.exit_code == 0 ? nlohmann::json::parse(read_file(dir.file("report.json"))) : nlohmann::json();
  std::filesystem::remove(dir.file("out.ply"));
  // An explicit budget above the cgroup's: refused, one line, nothing written.
  auto refused = run_command("sh -c " + q(enter + simplify_command(dir, in, "--memory 1G")));
  std::error_code ignored;
  std::filesystem::remove(group, ignored);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(report["out_of_core"].get<bool>());
  EXPECT_EQ(report["memory_bytes"].get<std::uint64_t>(), std::uint64_t{16} << 20);  // 1/64, clamped to 16 MiB
  EXPECT_LT(report["peak_rss_bytes"].get<std::uint64_t>(), limit);
  EXPECT_EQ(refused.exit_code, 5) << refused.err;
  EXPECT_NE(refused.err.find("cgroup memory limit"), std::string::npos) << refused.err;
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.ply")));
}

TEST(MemoryLimitCli, AnExplicitBudgetIsGuarded) {
  // A triangle soup left unwelded makes every face a patch, and the passes hold about 1 KB a face
  // (docs/pipeline.md, "Memory"): 581k faces cannot stay within --memory 16M. Without any
  // system limit the command's guard stops the run once it holds more than the budget allows,
  // with exit 5 and one line naming the budget, no output and no temporary file left; welded,
  // the same soup runs within the budget.
  ScratchDir dir;
  const std::string sheet = dir.file("sheet.ply"), soup = dir.file("soup.ply"), tmp = dir.file("tmp");
  ASSERT_TRUE(write_binary_ply(sheet, make_wavy_sheet(540)));
  ASSERT_TRUE(write_soup_copy(sheet, soup, 5, false));
  std::filesystem::create_directory(tmp);
  const std::string flags = "--engine out-of-core --memory 16M --threads 2 --tmp " + q(tmp);
  auto run = run_command(simplify_command(dir, soup, flags + " --no-weld"));
  EXPECT_EQ(run.exit_code, 5) << run.err;
  EXPECT_NE(run.err.find("--memory: "), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("past the budget of 16 MiB"), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.ply")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("report.json")));
  EXPECT_TRUE(std::filesystem::is_empty(tmp));
  run = run_command(simplify_command(dir, soup, flags));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(read_file(dir.file("report.json")));
  EXPECT_LT(report["peak_rss_bytes"].get<std::uint64_t>(), std::uint64_t{16 + 4 + 32} << 20);
  EXPECT_TRUE(std::filesystem::is_empty(tmp));
  // --engine in-core holds the whole mesh whatever the budget: not guarded (the sheet's finish
  // at 50 % holds far more than 16 MiB).
  run = run_command(simplify_command(dir, sheet, "--engine in-core --memory 16M --ratio 0.5"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_GT(nlohmann::json::parse(read_file(dir.file("report.json")))["peak_rss_bytes"].get<std::uint64_t>(), std::uint64_t{52} << 20);
}

// A large parent does not count against the budget: the command is started by a process that
// holds 384 MiB resident (a Python pipeline holding a mesh, say). getrusage's peak carries over
// exec, so a guard that read it stopped this run at once with exit 5 ("410 MiB resident in the
// ingest pass"); the peak since exec is the command's own.
TEST(MemoryLimitCli, ALargeParentDoesNotCountAgainstTheBudget) {
  ScratchDir dir;
  const std::string tmp = dir.file("tmp");
  std::filesystem::create_directory(tmp);
  const std::string command = simplify_command(dir, fixture("real/cow.off"), "--engine out-of-core --memory 16M --tmp " + q(tmp));
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const std::size_t bytes = std::size_t{384} << 20;
    char* held = static_cast<char*>(std::malloc(bytes));
    if (held == nullptr) std::_Exit(98);
    std::memset(held, 1, bytes);  // resident
    ::execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
    std::_Exit(99);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const auto report = nlohmann::json::parse(read_file(dir.file("report.json")));
  EXPECT_LT(report["peak_rss_bytes"].get<std::uint64_t>(), std::uint64_t{16 + 4 + 32} << 20);
  EXPECT_TRUE(std::filesystem::is_empty(tmp));
}

}  // namespace
}  // namespace gaussmesh::testing
