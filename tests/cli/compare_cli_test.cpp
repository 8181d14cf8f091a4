// Tests for `gaussmesh compare`: known distances through files and stdin, the --report JSON,
// determinism by seed, and usage / bad-input errors with their exit codes. Runs the binary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

using Json = nlohmann::json;

// OFF text of a mesh, every float written so it reads back exactly.
std::string off_text(const Mesh& mesh, double dx = 0, double scale = 1) {
  std::string out = "OFF\n" + std::to_string(mesh.positions.size()) + " " +
                    std::to_string(mesh.triangles.size()) + " 0\n";
  char line[128];
  for (const Vec3f& p : mesh.positions) {
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", static_cast<float>(scale * p.x + dx),
                  static_cast<float>(scale * p.y), static_cast<float>(scale * p.z));
    out += line;
  }
  for (const auto& t : mesh.triangles) {
    out += "3 " + std::to_string(t.v[0]) + " " + std::to_string(t.v[1]) + " " +
           std::to_string(t.v[2]) + "\n";
  }
  return out;
}

std::string shell_quoted(const std::string& s) { return "'" + s + "'"; }

std::string compare(const std::string& arguments) {
  return shell_quoted(gaussmesh_binary()) + " compare " + arguments;
}

class CompareCli : public ::testing::Test {
 protected:
  void SetUp() override {
    ShapeOptions options;
    options.vertices = 1500;
    sphere_ = make_sphere(options);
    a_ = dir_.file("a.off");
    b_ = dir_.file("b.off");
    write_file(a_, off_text(sphere_));
    write_file(b_, off_text(sphere_, kShift));  // translated along x
  }
  // A convex polyhedron and its translate are exactly the translation apart (Hausdorff).
  static constexpr double kShift = 0.05;
  ScratchDir dir_;
  Mesh sphere_;
  std::string a_, b_;
};

TEST_F(CompareCli, TranslatedSphereReportsTheShiftInPercentOfTheDiagonal) {
  const std::string report = dir_.file("r.json");
  const CommandResult r = run_command(compare(shell_quoted(a_) + " " + shell_quoted(b_) + " --samples 20000 --report " + shell_quoted(report)));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("hausdorff"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("A -> B"), std::string::npos) << r.out;
  const Json j = Json::parse(read_file(report));
  const double diagonal = j.at("diagonal").get<double>();
  const double expected = 100 * kShift / diagonal;
  EXPECT_NEAR(j.at("hausdorff_pct").get<double>(), expected, 1e-4 * expected);
  EXPECT_NEAR(j.at("hausdorff_a_to_b_pct").get<double>(), expected, 1e-4 * expected);
  EXPECT_NEAR(j.at("hausdorff_b_to_a_pct").get<double>(), expected, 1e-4 * expected);
  for (const char* key : {"rms_pct", "rms_a_to_b_pct", "rms_b_to_a_pct"}) {
    EXPECT_GT(j.at(key).get<double>(), 0.1 * expected) << key;
    EXPECT_LT(j.at(key).get<double>(), expected) << key;
  }
  // 20000 area samples plus every vertex and three edge midpoints per triangle.
  const std::size_t features = sphere_.positions.size() + 3 * sphere_.triangles.size();
  EXPECT_NEAR(double(j.at("samples_a").get<std::size_t>()), 20000.0 + features, 200.0);
  EXPECT_NEAR(double(j.at("samples_b").get<std::size_t>()), 20000.0 + features, 200.0);
  EXPECT_EQ(j.at("a_faces").get<std::size_t>(), sphere_.triangles.size());
}

TEST_F(CompareCli, ReportOnStdoutIsTheOnlyOutputAndStdinWorks) {
  const CommandResult files =
      run_command(compare(shell_quoted(a_) + " " + shell_quoted(b_) + " --samples 5000 --report -"));
  ASSERT_EQ(files.exit_code, 0) << files.err;
  const Json from_files = Json::parse(files.out);  // throws (fails) on any extra text
  const CommandResult piped =
      run_command("cat " + shell_quoted(b_) + " | " + compare(shell_quoted(a_) + " - --samples 5000 --report -"));
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  const Json from_stdin = Json::parse(piped.out);
  EXPECT_EQ(from_stdin.at("hausdorff_pct"), from_files.at("hausdorff_pct"));
  EXPECT_EQ(from_stdin.at("rms_pct"), from_files.at("rms_pct"));
  EXPECT_EQ(from_stdin.at("b"), "<stdin>");
}

TEST_F(CompareCli, SameSeedSameFiguresOtherSeedOtherSamples) {
  auto rms = [&](const std::string& extra) {
    const CommandResult r = run_command(
        compare(shell_quoted(a_) + " " + shell_quoted(b_) + " --samples 5000 --report - " + extra));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return Json::parse(r.out).at("rms_pct").get<double>();
  };
  const double first = rms("--seed 3"), again = rms("--seed 3 --threads 1"), other = rms("--seed 4");
  EXPECT_EQ(first, again);
  EXPECT_NE(first, other);
  EXPECT_NEAR(first, other, 0.1 * first);
}

TEST_F(CompareCli, AMeshAgainstItselfIsAtZero) {
  const CommandResult r = run_command(compare(shell_quoted(fixture("real/cow.off")) + " " +
                                              shell_quoted(fixture("real/cow.off")) + " --samples 20000 --report -"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_LT(j.at("hausdorff_pct").get<double>(), 1e-5);
  EXPECT_GT(j.at("samples_a").get<std::size_t>(), 20000u);
}

TEST_F(CompareCli, ErrorsGiveOneLineAndTheDocumentedExitCode) {
  struct Case {
    std::string arguments;
    int exit_code;
    std::string mentions;
  };
  const std::string missing = dir_.file("missing.off");
  const std::string no_faces = dir_.file("points.off");
  write_file(no_faces, "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
  const Case cases[] = {
      {shell_quoted(a_), 1, "B"},                                           // B missing
      {"- -", 1, "'-'"},                                              // two stdins
      {shell_quoted(a_) + " " + shell_quoted(b_) + " --samples 0", 1, "--samples"},
      {shell_quoted(a_) + " " + shell_quoted(b_) + " --bogus", 1, "bogus"},
      {shell_quoted(a_) + " " + shell_quoted(missing), 2, "missing.off"},
      {shell_quoted(fixture("bad/invalid.off")) + " " + shell_quoted(a_), 2, "invalid.off"},
      {shell_quoted(a_) + " " + shell_quoted(no_faces), 2, "points.off"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments);
    const CommandResult r = run_command(compare(c.arguments) + " < /dev/null");
    EXPECT_EQ(r.exit_code, c.exit_code) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_NE(r.err.find(c.mentions), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

}  // namespace
}  // namespace gaussmesh::testing
