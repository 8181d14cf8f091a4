// gaussmesh view's refusals: one line and the documented exit code, nothing written. (The page
// and the server themselves are tested in a browser: tests/web/viewer_browser.mjs.)
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "tests/support/test_util.h"

namespace gaussmesh {
namespace {

using testing::fixture;
using testing::gaussmesh_binary;
using testing::run_command;
using testing::ScratchDir;

std::string q(const std::string& text) { return "'" + text + "'"; }

int lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

TEST(ViewCli, AMissingModelIsExitTwoWithOneLine) {
  ScratchDir dir;
  auto run = run_command(q(gaussmesh_binary()) + " view " + q(dir.file("missing.glb")) + " --html " + q(dir.file("page.html")));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_EQ(lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("missing.glb"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("page.html")));
}

TEST(ViewCli, APortOutOfRangeIsExitOne) {
  auto run = run_command(q(gaussmesh_binary()) + " view " + q(fixture("real/cow.off")) + " --port 70000");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_EQ(lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("--port"), std::string::npos) << run.err;
}

TEST(ViewCli, ADirectoryIsNotAModel) {
  ScratchDir dir;
  auto run = run_command(q(gaussmesh_binary()) + " view " + q(dir.path().string()) + " --html " + q(dir.file("page.html")));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_EQ(lines(run.err), 1) << run.err;
}

}  // namespace
}  // namespace gaussmesh
