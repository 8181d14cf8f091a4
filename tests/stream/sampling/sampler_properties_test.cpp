// The paper's sampling properties (§3.2, Figs. 2-4) on generated analytic shapes:
// exact test: |V(G)| samples on closed convex genus-0 polyhedra, 2|V(G)| on 2-convex tori, more
// on a dented sphere; paper test: within 25 % of those; smoothing on a noisy sphere.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "stream/sampling/sampler.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using testing::ShapeOptions;

struct Shape {
  std::string name;
  Mesh mesh;
  int sheets;  // g + 1 for a 2-convex shape: expected samples / |V(G)|
};

const std::vector<Shape>& convex_and_tori() {
  static const std::vector<Shape> shapes = [] {
    ShapeOptions o;
    o.vertices = 6000;
    o.seed = 3;
    std::vector<Shape> s;
    s.push_back({"sphere", testing::make_sphere(o), 1});
    s.push_back({"ellipsoid 1:0.7:0.4", testing::make_ellipsoid(1, 0.7, 0.4, o), 1});
    ShapeOptions dense = o;
    dense.vertices = 20000;
    s.push_back({"rounded cube p=4", testing::make_rounded_cube(4, dense), 1});
    s.push_back({"rounded cube p=8", testing::make_rounded_cube(8, dense), 1});
    s.push_back({"thin torus R=1 r=0.25", testing::make_torus(1, 0.25, dense), 2});
    s.push_back({"thick torus R=1 r=0.7", testing::make_torus(1, 0.7, dense), 2});
    return s;
  }();
  return shapes;
}

std::size_t count_samples(const Mesh& mesh, std::uint32_t f, std::uint64_t seed, SampleTest test, std::uint32_t smooth = 0,
                          bool literal = false) {
  GaussSphereOptions go;
  go.frequency = f;
  go.rotation = testing::random_rotation(seed);
  const GaussSphere g = GaussSphere::create(go).value();
  SamplerOptions so;
  so.sample_test = test;
  so.smooth_iterations = smooth;
  so.drop_unwinding_candidates = !literal;
  auto r = sample_mesh(mesh.view(), g, so);
  EXPECT_TRUE(r.is_ok()) << r.status().to_string();
  return r->samples.size();
}

TEST(SamplerProperties, ExactTestGivesOneSamplePerGaussVertexPerSheet) {
  for (const Shape& s : convex_and_tori()) {
    for (std::uint32_t f : {2u, 3u, 4u}) {
      const std::size_t gv = 10 * f * f + 2;
      for (std::uint64_t seed = 100; seed < 108; ++seed) {
        const std::size_t n = count_samples(s.mesh, f, seed, SampleTest::kExact);
        EXPECT_EQ(n, s.sheets * gv) << s.name << " f=" << f << " orientation seed " << seed;
      }
    }
  }
}

TEST(SamplerProperties, PaperTestIsOnAverageWithinAQuarterOfTheIdealCount) {
  std::printf("%-24s %3s %6s %10s %10s %10s %14s\n", "shape", "f", "ideal", "paper min", "paper max", "mean err%",
              "literal mean");
  for (const Shape& s : convex_and_tori()) {
    for (std::uint32_t f : {2u, 3u, 4u}) {
      const double ideal = double(s.sheets) * (10 * f * f + 2);
      std::size_t lo = SIZE_MAX, hi = 0;
      double err = 0, literal = 0;
      for (std::uint64_t seed = 100; seed < 108; ++seed) {
        literal += double(count_samples(s.mesh, f, seed, SampleTest::kPaper, 0, true)) / 8;
        const std::size_t n = count_samples(s.mesh, f, seed, SampleTest::kPaper);
        lo = std::min(lo, n);
        hi = std::max(hi, n);
        err += std::abs(double(n) - ideal) / ideal / 8;
      }
      std::printf("%-24s %3u %6.0f %10zu %10zu %10.1f %14.1f\n", s.name.c_str(), f, ideal, lo, hi, 100 * err, literal);
      // The mean over the 8 orientations; single orientations of the thin torus go further.
      EXPECT_LE(err, 0.25) << s.name << " f=" << f;
      EXPECT_GT(lo, 0u);
    }
  }
}

TEST(SamplerProperties, DentAddsSamples) {
  ShapeOptions o;
  o.vertices = 20000;
  o.seed = 5;
  const Mesh sphere = testing::make_sphere(o);
  const Mesh dented = testing::make_dented_sphere(0.4, o);
  for (std::uint64_t seed = 100; seed < 104; ++seed) {
    const std::size_t a = count_samples(sphere, 3, seed, SampleTest::kExact);
    const std::size_t b = count_samples(dented, 3, seed, SampleTest::kExact);
    EXPECT_GT(b, a) << "orientation seed " << seed;
    std::printf("orientation %llu: sphere %zu dented %zu (exact, f=3)\n", static_cast<unsigned long long>(seed), a, b);
  }
}

TEST(SamplerProperties, OneSmoothingIterationRemovesNoiseSamples) {
  ShapeOptions o;
  o.vertices = 20000;
  o.seed = 9;
  o.noise = 0.002;
  const Mesh noisy = testing::make_sphere(o);
  for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) {
    const std::size_t raw = count_samples(noisy, 3, 100, test, 0);
    const std::size_t smooth1 = count_samples(noisy, 3, 100, test, 1);
    const std::size_t smooth3 = count_samples(noisy, 3, 100, test, 3);
    std::printf("noisy sphere (%s, f=3, |V(G)|=92): smooth 0: %zu, 1: %zu, 3: %zu\n", sample_test_name(test), raw,
                smooth1, smooth3);
    EXPECT_LT(smooth1, raw);
  }
}

}  // namespace
}  // namespace gaussmesh::stream
