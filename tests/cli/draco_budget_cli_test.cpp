// Tests that a Draco input whose decode cannot fit --memory is refused before it is decoded:
// exit 5, one line naming the file, its counts, the estimate and the budget; no output, no
// temporary file; in core and out of core, simplify and sample alike.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }

size_t files_in(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

// A torus of ~300k faces as Draco: about 1 MB of file whose decode needs well over 16 MiB.
class DracoBudgetCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new ScratchDir;
    ShapeOptions shape;
    shape.vertices = 150000;
    const Mesh torus = make_torus(1.0, 0.35, shape);
    faces_ = torus.triangles.size();
    points_ = torus.positions.size();
    auto out = format::OutputFile::create(dir_->file("big.drc"), true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_draco(**out, torus.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  static void TearDownTestSuite() { delete dir_; }

  static std::string input() { return dir_->file("big.drc"); }

  // The refusal: exactly one line on stderr, naming the file, the counts and the budget.
  static void expect_refused(const CommandResult& run) {
    EXPECT_EQ(run.exit_code, 5) << run.err;
    const std::regex line("gaussmesh: " + std::regex_replace(input(), std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                          ": decoding this Draco mesh \\(" + std::to_string(faces_) + " faces, " +
                          std::to_string(points_) + " points\\) needs about [0-9]+ MiB, over the --memory budget of 16 MiB\n");
    EXPECT_TRUE(std::regex_match(run.err, line)) << run.err;
  }

  static inline ScratchDir* dir_ = nullptr;
  static inline size_t faces_ = 0, points_ = 0;
};

TEST_F(DracoBudgetCli, SimplifyOutOfCoreRefusesBeforeDecoding) {
  ScratchDir out, tmp;
  const auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(input()) + " -o " + q(out.file("out.ply")) +
                               " --memory 16M --engine out-of-core --tmp " + q(tmp.path().string()));
  expect_refused(run);
  EXPECT_EQ(files_in(out.path().string()), 0u) << "no out.ply";
  EXPECT_EQ(files_in(tmp.path().string()), 0u) << "no temporary file";
}

TEST_F(DracoBudgetCli, SimplifyInCoreRefusesUnderAnExplicitBudget) {
  // The engine choice guesses the faces from the file size, which Draco's compression defeats:
  // this runs in core, and the reader refuses all the same.
  ScratchDir out;
  const auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(input()) + " -o " + q(out.file("out.ply")) +
                               " --memory 16M");
  expect_refused(run);
  EXPECT_EQ(files_in(out.path().string()), 0u);
}

TEST_F(DracoBudgetCli, SampleRefusesInAndOutOfCore) {
  for (const char* engine : {"in-core", "out-of-core"}) {
    ScratchDir out, tmp;
    const auto run = run_command(q(gaussmesh_binary()) + " sample " + q(input()) + " -o " + q(out.file("s.ply")) +
                                 " --memory 16M --engine " + engine + " --tmp " + q(tmp.path().string()));
    expect_refused(run);
    EXPECT_EQ(files_in(out.path().string()), 0u) << engine;
    EXPECT_EQ(files_in(tmp.path().string()), 0u) << engine;
  }
}

TEST_F(DracoBudgetCli, InfoHasNoBudgetAndDecodes) {
  const auto run = run_command(q(gaussmesh_binary()) + " info " + q(input()) + " -q");
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

}  // namespace
}  // namespace gaussmesh::testing
