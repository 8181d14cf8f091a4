// `gaussmesh simplify --color-weight` on a flat square whose colour jumps from red to blue along a
// wavy line (per-vertex colours, so the jump is one row of faces wide). The plane alone gives the
// collapses no reason to keep that line; with a colour weight the output's faces follow it, so the
// colour they interpolate is the input's far more closely. Bad weights and a streamed input are
// refused with one line.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "stream/core/mesh.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }

constexpr int kGrid = 100;
constexpr double kPi = 3.14159265358979323846;

// Red (1) right of the wavy line, blue (0) left of it.
double side(double x, double y) { return x > 0.5 + 0.15 * std::sin(2 * kPi * y) ? 1.0 : 0.0; }

// The input: the unit square as a kGrid × kGrid grid of quads, each cut along its diagonal.
std::string grid_ply() {
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string((kGrid + 1) * (kGrid + 1)) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
                    "property uchar blue\nelement face " + std::to_string(2 * kGrid * kGrid) +
                    "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int j = 0; j <= kGrid; ++j)
    for (int i = 0; i <= kGrid; ++i) {
      const int red = int(255 * side(double(i) / kGrid, double(j) / kGrid));
      ply += std::to_string(double(i) / kGrid) + " " + std::to_string(double(j) / kGrid) + " 0 " + std::to_string(red) +
             " 0 " + std::to_string(255 - red) + "\n";
    }
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const int a = j * (kGrid + 1) + i, b = a + 1, c = a + kGrid + 1, d = c + 1;
      ply += "3 " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\n";
      ply += "3 " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + "\n";
    }
  return ply;
}

// The input's red at (x, y): its grid's piecewise-linear colour.
double input_red(double x, double y) {
  const int i = std::min(int(x * kGrid), kGrid - 1), j = std::min(int(y * kGrid), kGrid - 1);
  const double u = x * kGrid - i, v = y * kGrid - j;
  const double a = side(double(i) / kGrid, double(j) / kGrid), b = side(double(i + 1) / kGrid, double(j) / kGrid);
  const double c = side(double(i) / kGrid, double(j + 1) / kGrid), d = side(double(i + 1) / kGrid, double(j + 1) / kGrid);
  return u >= v ? a + u * (b - a) + v * (d - b) : a + v * (c - a) + u * (d - c);
}

// The area-weighted mean, over 28 points of each output face, of the difference between the red
// the face interpolates and the input's red there.
double mean_colour_error(const stream::Mesh& out) {
  double sum = 0, area = 0;
  for (const auto& t : out.triangles) {
    const auto &a = out.positions[t.v[0]], &b = out.positions[t.v[1]], &c = out.positions[t.v[2]];
    const double face_area = std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y)) / 2;
    constexpr int kSteps = 6;
    for (int p = 0; p <= kSteps; ++p)
      for (int r = 0; r <= kSteps - p; ++r) {
        const double w0 = double(p) / kSteps, w1 = double(r) / kSteps, w2 = 1 - w0 - w1;
        const double x = w0 * a.x + w1 * b.x + w2 * c.x, y = w0 * a.y + w1 * b.y + w2 * c.y;
        const double red = w0 * out.colors[t.v[0]].r + w1 * out.colors[t.v[1]].r + w2 * out.colors[t.v[2]].r;
        sum += face_area * std::abs(red - input_red(x, y));
        area += face_area;
      }
  }
  return sum / area;
}

TEST(SimplifyColourWeightCli, FacesFollowAColourEdgeWithAWeight) {
  ScratchDir dir;
  const std::string in = dir.file("grid.ply");
  write_file(in, grid_ply());
  for (const std::string ratio : {"0.05", "0.01"}) {
    double error[2];
    for (int weighted = 0; weighted < 2; ++weighted) {
      const std::string out = dir.file("out.ply");
      auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " -q --ratio " + ratio +
                             (weighted ? " --color-weight 0.01" : ""));
      ASSERT_EQ(run.exit_code, 0) << run.err;
      auto mesh = stream::load_mesh(out);
      ASSERT_TRUE(mesh) << mesh.status().to_string();
      ASSERT_EQ(mesh->colors.size(), mesh->positions.size());
      error[weighted] = mean_colour_error(*mesh);
    }
    std::printf("  ratio %s: mean colour error %.4f without a weight, %.4f with --color-weight 0.01\n", ratio.c_str(),
                error[0], error[1]);
    EXPECT_LT(error[1], error[0] / 4) << "ratio " << ratio;
  }
}

TEST(SimplifyColourWeightCli, BadWeightsAndAStreamedInputAreRefused) {
  ScratchDir dir;
  const std::string in = dir.file("grid.ply");
  write_file(in, grid_ply());
  for (const std::string weight : {"-1", "nan", "inf"}) {
    auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(dir.file("o.ply")) +
                           " --ratio 0.1 --color-weight " + weight);
    EXPECT_EQ(run.exit_code, 1) << weight << ": " << run.err;
    EXPECT_NE(run.err.find("--color-weight"), std::string::npos) << run.err;
  }
  auto streamed = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(dir.file("o.ply")) +
                              " --ratio 0.1 --color-weight 0.01 --engine out-of-core");
  EXPECT_EQ(streamed.exit_code, 1) << streamed.err;
  EXPECT_NE(streamed.err.find("in core only"), std::string::npos) << streamed.err;
}

}  // namespace
}  // namespace gaussmesh::testing
