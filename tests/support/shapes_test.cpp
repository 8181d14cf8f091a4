// Tests of the analytic shape generator and its convex hull: closed, manifold, outward,
// right topology and volume, edges that bend with the surface, rotation and noise.
#include "tests/support/shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <functional>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace gaussmesh::testing {
namespace {

using format::Triangle;

constexpr double kPi = std::numbers::pi;

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }

// What is wrong with a mesh as a closed, consistently oriented 2-manifold ("" if nothing).
std::string closed_manifold_problem(const Mesh& mesh) {
  std::map<std::uint64_t, std::uint32_t> next;  // directed edge (a, b) -> third vertex
  std::vector<std::size_t> out_degree(mesh.positions.size(), 0);
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      if (a >= mesh.positions.size()) return "index out of range";
      if (a == b) return "degenerate triangle";
      if (!next.emplace(edge_key(a, b), t.v[(k + 2) % 3]).second) {
        return "directed edge used twice (" + std::to_string(a) + "," + std::to_string(b) + ")";
      }
      ++out_degree[a];
    }
  }
  for (const auto& [key, c] : next) {
    if (!next.count(edge_key(std::uint32_t(key), std::uint32_t(key >> 32)))) return "boundary edge";
  }
  for (std::size_t v = 0; v < out_degree.size(); ++v) {
    if (out_degree[v] == 0) return "unused vertex " + std::to_string(v);
  }
  // One fan per vertex: walking around it from any edge visits all its edges.
  std::vector<bool> walked(mesh.positions.size(), false);
  for (const auto& [key, c] : next) {
    const auto a = std::uint32_t(key >> 32), first = std::uint32_t(key);
    if (walked[a]) continue;
    walked[a] = true;
    std::uint32_t b = first;
    std::size_t steps = 0;
    do {
      b = next.at(edge_key(a, b));
      ++steps;
    } while (b != first && steps <= out_degree[a]);
    if (steps != out_degree[a]) return "vertex with several fans " + std::to_string(a);
  }
  return "";
}

long long euler_characteristic(const Mesh& mesh) {
  std::set<std::uint64_t> edges;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      edges.insert(edge_key(std::min(a, b), std::max(a, b)));
    }
  }
  return static_cast<long long>(mesh.positions.size()) - static_cast<long long>(edges.size()) +
         static_cast<long long>(mesh.triangles.size());
}

double signed_volume(const Mesh& mesh) {
  double volume = 0;
  for (const Triangle& t : mesh.triangles) {
    const Vec3f& a = mesh.positions[t.v[0]];
    const Vec3f& b = mesh.positions[t.v[1]];
    const Vec3f& c = mesh.positions[t.v[2]];
    volume += (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) -
               double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
               double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) / 6.0;
  }
  return volume;
}

// Each interior edge once, with the vertex opposite it in each of its two faces:
// face (a, b, c) and face (b, a, d).
struct EdgeQuad {
  std::uint32_t a, b, c, d;
};
std::vector<EdgeQuad> edge_quads(const Mesh& mesh) {
  std::map<std::uint64_t, std::uint32_t> opposite;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) opposite[edge_key(t.v[k], t.v[(k + 1) % 3])] = t.v[(k + 2) % 3];
  }
  std::vector<EdgeQuad> quads;
  for (const auto& [key, c] : opposite) {
    const auto a = std::uint32_t(key >> 32), b = std::uint32_t(key);
    if (a > b) continue;
    const auto it = opposite.find(edge_key(b, a));
    if (it != opposite.end()) quads.push_back({a, b, c, it->second});
  }
  return quads;
}

// +1 convex (a ridge), -1 reflex, 0 flat, exactly.
int edge_bend(const Mesh& mesh, const EdgeQuad& q) {
  const auto& p = mesh.positions;
  return -exact_orientation(p[q.a], p[q.b], p[q.c], p[q.d]);
}

std::vector<double> sorted_edge_lengths(const Mesh& mesh) {
  std::vector<double> lengths;
  for (const EdgeQuad& q : edge_quads(mesh)) {
    const Vec3f& a = mesh.positions[q.a];
    const Vec3f& b = mesh.positions[q.b];
    lengths.push_back(std::hypot(double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z));
  }
  std::sort(lengths.begin(), lengths.end());
  return lengths;
}

double diagonal(const Mesh& mesh) {
  Vec3f lo = mesh.positions[0], hi = lo;
  for (const Vec3f& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return std::hypot(double(hi.x) - lo.x, double(hi.y) - lo.y, double(hi.z) - lo.z);
}

// Hull checks shared by the convex_hull tests: closed manifold sphere, every edge convex or
// flat, every point inside or on every face's plane.
void expect_valid_hull(const Mesh& hull, std::span<const Vec3f> points) {
  ASSERT_FALSE(hull.triangles.empty());
  EXPECT_EQ(closed_manifold_problem(hull), "");
  EXPECT_EQ(euler_characteristic(hull), 2);
  EXPECT_GT(signed_volume(hull), 0);
  for (const EdgeQuad& q : edge_quads(hull)) {
    ASSERT_GE(edge_bend(hull, q), 0) << "reflex hull edge " << q.a << "-" << q.b;
  }
  for (const Triangle& t : hull.triangles) {
    const auto& p = hull.positions;
    for (const Vec3f& point : points) {
      ASSERT_LE(exact_orientation(p[t.v[0]], p[t.v[1]], p[t.v[2]], point), 0)
          << "point outside the hull: " << point.x << " " << point.y << " " << point.z;
    }
  }
}

// --- convex_hull ------------------------------------------------------------------------------

TEST(ConvexHull, CubeWithCoplanarAndInteriorPointsKeepsTheCorners) {
  std::vector<Vec3f> points;
  for (int i = 0; i < 8; ++i) points.push_back({float(i & 1), float((i >> 1) & 1), float(i >> 2)});
  // Interior points and face centres (coplanar with two hull triangles) come after the corners,
  // so they are inserted when the cube is already complete and must leave it unchanged.
  points.push_back({0.5f, 0.5f, 0.5f});
  points.push_back({0.5f, 0.5f, 0.0f});
  points.push_back({0.5f, 0.5f, 1.0f});
  points.push_back({0.0f, 0.5f, 0.5f});
  points.push_back({0.25f, 0.75f, 0.5f});
  const Mesh hull = convex_hull(points);
  expect_valid_hull(hull, points);
  EXPECT_NEAR(signed_volume(hull), 1.0, 1e-12);
}

TEST(ConvexHull, IntegerLatticeFullOfCoplanarAndCollinearPoints) {
  std::vector<Vec3f> points;
  for (int x = 0; x <= 4; ++x) {
    for (int y = 0; y <= 4; ++y) {
      for (int z = 0; z <= 4; ++z) points.push_back({float(x), float(y), float(z)});
    }
  }
  const Mesh hull = convex_hull(points);
  expect_valid_hull(hull, points);
  EXPECT_NEAR(signed_volume(hull), 64.0, 1e-9);
  EXPECT_GE(hull.positions.size(), 8u);
  EXPECT_LE(hull.positions.size(), 98u);  // boundary lattice points at most
}

TEST(ConvexHull, RandomPointsInABall) {
  const std::uint64_t seed = 20240611;
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<float> coordinate(-1, 1);
  std::vector<Vec3f> points;
  while (points.size() < 3000) {
    const Vec3f p{coordinate(random), coordinate(random), coordinate(random)};
    if (p.x * p.x + p.y * p.y + p.z * p.z <= 1) points.push_back(p);
  }
  const Mesh hull = convex_hull(points);
  expect_valid_hull(hull, points);
  EXPECT_LT(hull.positions.size(), points.size());
}

TEST(ConvexHull, DegenerateInputGivesAnEmptyMesh) {
  std::vector<Vec3f> planar = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 3, 0}};
  EXPECT_TRUE(convex_hull(planar).triangles.empty());
  std::vector<Vec3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_TRUE(convex_hull(three).triangles.empty());
}

TEST(ConvexHull, FiftyThousandSpherePointsAllBecomeVertices) {
  ShapeOptions options;
  options.vertices = 50000;
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  const Mesh sphere = make_sphere(options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_seconds = double(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  // Figures, not assertions (the machine is shared).
  std::printf("make_sphere(50000): %.3f s wall, %.3f s cpu\n", seconds, cpu_seconds);
  EXPECT_EQ(sphere.positions.size(), 50000u);
  EXPECT_EQ(sphere.triangles.size(), 2 * 50000u - 4);
  EXPECT_EQ(closed_manifold_problem(sphere), "");
}

// --- shapes ------------------------------------------------------------------------------------

struct ShapeCase {
  std::string name;
  std::function<Mesh(const ShapeOptions&)> make;
  long long euler;
  double volume;  // analytic volume of the smooth shape; 0 if not checked
  bool convex;
  double count_tolerance;  // relative
};

double superellipsoid_volume(double p) {
  return 8 * std::pow(std::tgamma(1 + 1 / p), 3) / std::tgamma(1 + 3 / p);
}

std::vector<ShapeCase> shape_cases() {
  return {
      {"sphere", [](const ShapeOptions& o) { return make_sphere(o); }, 2, 4 * kPi / 3, true, 0},
      {"ellipsoid", [](const ShapeOptions& o) { return make_ellipsoid(1.5, 1, 0.5, o); }, 2,
       4 * kPi * 1.5 * 0.5 / 3, true, 0},
      {"rounded_cube_p4", [](const ShapeOptions& o) { return make_rounded_cube(4, o); }, 2,
       superellipsoid_volume(4), true, 0.01},
      {"rounded_cube_p8", [](const ShapeOptions& o) { return make_rounded_cube(8, o); }, 2,
       superellipsoid_volume(8), true, 0.02},
      {"rounded_cube_p16", [](const ShapeOptions& o) { return make_rounded_cube(16, o); }, 2,
       superellipsoid_volume(16), true, 0.05},
      {"thin_torus", [](const ShapeOptions& o) { return make_torus(1, 0.25, o); }, 0,
       2 * kPi * kPi * 0.25 * 0.25, false, 0.05},
      {"thick_torus", [](const ShapeOptions& o) { return make_torus(1, 0.8, o); }, 0,
       2 * kPi * kPi * 0.8 * 0.8, false, 0.05},
      {"dented_sphere", [](const ShapeOptions& o) { return make_dented_sphere(0.3, o); }, 2, 0,
       false, 0},
      {"genus2", [](const ShapeOptions& o) { return make_genus2(o); }, -2, 0, false, 0.05},
  };
}

class Shapes : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(Shapes, ClosedManifoldOutwardWithTheRightTopologyAndSize) {
  const ShapeCase& shape = GetParam();
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE("rotation seed " + std::to_string(seed));
    ShapeOptions options;
    options.vertices = 4000;
    options.rotation = random_rotation(seed);
    const Mesh mesh = shape.make(options);
    EXPECT_EQ(closed_manifold_problem(mesh), "");
    EXPECT_EQ(euler_characteristic(mesh), shape.euler);
    const double volume = signed_volume(mesh);
    EXPECT_GT(volume, 0);
    if (shape.volume > 0) {
      EXPECT_NEAR(volume, shape.volume, 0.01 * shape.volume);
    }
    EXPECT_NEAR(double(mesh.positions.size()), 4000.0, 4000.0 * shape.count_tolerance);
    if (shape.convex) {
      std::size_t flat = 0;
      for (const EdgeQuad& q : edge_quads(mesh)) {
        const int bend = edge_bend(mesh, q);
        ASSERT_GE(bend, 0) << "reflex edge " << q.a << "-" << q.b;
        flat += bend == 0;
      }
      EXPECT_EQ(flat, 0u) << "flat edges";
    }
  }
}

TEST_P(Shapes, ClosedManifoldAtCoarseAndFineResolutions) {
  const ShapeCase& shape = GetParam();
  for (std::size_t vertices : {300u, 1000u, 25000u}) {
    SCOPED_TRACE("vertices " + std::to_string(vertices));
    ShapeOptions options;
    options.vertices = vertices;
    options.rotation = random_rotation(vertices);
    const Mesh mesh = shape.make(options);
    EXPECT_EQ(closed_manifold_problem(mesh), "");
    EXPECT_EQ(euler_characteristic(mesh), shape.euler);
    EXPECT_GT(signed_volume(mesh), 0);
    EXPECT_NEAR(double(mesh.positions.size()), double(vertices),
                double(vertices) * std::max(shape.count_tolerance, 0.1));
  }
}

TEST_P(Shapes, RotationPreservesEdgeLengths) {
  const ShapeCase& shape = GetParam();
  ShapeOptions options;
  options.vertices = 2000;
  const Mesh plain = shape.make(options);
  options.rotation = random_rotation(7);
  const Mesh rotated = shape.make(options);
  const auto a = sorted_edge_lengths(plain), b = sorted_edge_lengths(rotated);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-5) << "edge " << i;
}

TEST_P(Shapes, NoiseIsSeededAndScaledByTheDiagonal) {
  const ShapeCase& shape = GetParam();
  ShapeOptions options;
  options.vertices = 2000;
  const Mesh plain = shape.make(options);
  options.noise = 0.001;
  options.seed = 5;
  const Mesh noisy = shape.make(options);
  const Mesh again = shape.make(options);
  options.seed = 6;
  const Mesh other = shape.make(options);
  ASSERT_EQ(noisy.positions.size(), plain.positions.size());
  EXPECT_TRUE(noisy.positions == again.positions);
  EXPECT_FALSE(noisy.positions == other.positions);
  EXPECT_TRUE(noisy.triangles == plain.triangles);
  double sum = 0;
  for (std::size_t i = 0; i < plain.positions.size(); ++i) {
    const Vec3f& a = plain.positions[i];
    const Vec3f& b = noisy.positions[i];
    sum += std::pow(double(a.x) - b.x, 2) + std::pow(double(a.y) - b.y, 2) +
           std::pow(double(a.z) - b.z, 2);
  }
  // Per-coordinate sigma = noise * diagonal, so the mean squared displacement is 3 sigma^2.
  const double sigma = 0.001 * diagonal(plain);
  const double rms_per_coordinate = std::sqrt(sum / (3.0 * plain.positions.size()));
  EXPECT_NEAR(rms_per_coordinate, sigma, 0.1 * sigma);
}

INSTANTIATE_TEST_SUITE_P(All, Shapes, ::testing::ValuesIn(shape_cases()),
                         [](const auto& info) { return info.param.name; });

// --- edges bend with the surface (unrotated, so the analytic regions are easy to state) -------

TEST(ShapeEdges, TorusEdgesOnTheOuterHalfAreConvex) {
  for (double minor : {0.25, 0.8}) {
    SCOPED_TRACE("minor radius " + std::to_string(minor));
    ShapeOptions options;
    options.vertices = 3000;
    const Mesh torus = make_torus(1, minor, options);
    auto cos_v = [&](std::uint32_t v) {
      const Vec3f& p = torus.positions[v];
      return (std::hypot(double(p.x), double(p.y)) - 1.0) / minor;
    };
    std::size_t checked = 0;
    for (const EdgeQuad& q : edge_quads(torus)) {
      if (std::min({cos_v(q.a), cos_v(q.b), cos_v(q.c), cos_v(q.d)}) < 0.05) continue;
      ++checked;
      ASSERT_EQ(edge_bend(torus, q), 1) << "edge " << q.a << "-" << q.b;
    }
    EXPECT_GT(checked, torus.triangles.size() / 3);  // about half of the 3F/2 edges
  }
}

TEST(ShapeEdges, DentedSphereIsConcaveInTheDentAndConvexAwayFromIt) {
  ShapeOptions options;
  options.vertices = 4000;
  const Mesh mesh = make_dented_sphere(0.3, options);
  auto angle = [&](std::uint32_t v) {
    const Vec3f& p = mesh.positions[v];
    return std::acos(p.z / std::hypot(double(p.x), double(p.y), double(p.z)));
  };
  std::size_t concave = 0, convex = 0;
  for (const EdgeQuad& q : edge_quads(mesh)) {
    const double lo = std::min({angle(q.a), angle(q.b), angle(q.c), angle(q.d)});
    const double hi = std::max({angle(q.a), angle(q.b), angle(q.c), angle(q.d)});
    if (hi < 0.2) {
      ++concave;
      ASSERT_EQ(edge_bend(mesh, q), -1) << "edge in the dent " << q.a << "-" << q.b;
    } else if (lo > 0.8) {
      ++convex;
      ASSERT_EQ(edge_bend(mesh, q), 1) << "edge away from the dent " << q.a << "-" << q.b;
    }
  }
  EXPECT_GT(concave, 20u);
  EXPECT_GT(convex, 1000u);
}

TEST(ShapeEdges, Genus2EdgesBendWithTheSurface) {
  ShapeOptions options;
  options.vertices = 6000;
  const Mesh mesh = make_genus2(options);
  std::size_t convex = 0, concave = 0, wrong = 0;
  for (const EdgeQuad& q : edge_quads(mesh)) {
    const Vec3f& a = mesh.positions[q.a];
    const Vec3f& b = mesh.positions[q.b];
    const LocalShape shape =
        genus2_local_shape({(a.x + b.x) / 2, (a.y + b.y) / 2, (a.z + b.z) / 2});
    if (shape == LocalShape::kConvex) {
      ++convex;
      wrong += edge_bend(mesh, q) != 1;
    } else if (shape == LocalShape::kConcave) {
      ++concave;
      wrong += edge_bend(mesh, q) != -1;
    }
  }
  EXPECT_GT(convex, 1000u);
  EXPECT_EQ(wrong, 0u) << "of " << convex << " convex and " << concave << " concave edges";
}

// --- random_rotation -----------------------------------------------------------------------------

TEST(RandomRotation, UnitQuaternionsSpreadUniformly) {
  double mean[3] = {0, 0, 0};
  const int count = 4000;
  for (int seed = 0; seed < count; ++seed) {
    const auto q = random_rotation(seed);
    ASSERT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    // The image of +z: third column of the rotation matrix.
    mean[0] += 2 * (q[1] * q[3] + q[0] * q[2]);
    mean[1] += 2 * (q[2] * q[3] - q[0] * q[1]);
    mean[2] += 1 - 2 * (q[1] * q[1] + q[2] * q[2]);
  }
  for (double m : mean) EXPECT_NEAR(m / count, 0.0, 0.05);  // sigma ~ 0.009
  EXPECT_NE(random_rotation(1), random_rotation(2));
  EXPECT_EQ(random_rotation(3), random_rotation(3));
}

}  // namespace
}  // namespace gaussmesh::testing
