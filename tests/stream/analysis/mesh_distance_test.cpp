// Tests of the mesh distance: point-triangle distance against brute force, the AABB tree
// against a linear scan, and the measure on pairs with known answers (identical, translated,
// concentric spheres, sphere vs ellipsoid), determinism, sample counts and errors.
#include "stream/analysis/mesh_distance.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Triangle;
using format::Vec3f;
using testing::ShapeOptions;

Vec3d to_double(const Vec3f& p) { return {p.x, p.y, p.z}; }
double distance(const Vec3d& a, const Vec3d& b) { return std::sqrt(dot(a - b, a - b)); }

Mesh transformed(const Mesh& mesh, double scale, Vec3d offset) {
  Mesh out = mesh;
  for (Vec3f& p : out.positions) {
    p = {static_cast<float>(scale * p.x + offset.x), static_cast<float>(scale * p.y + offset.y),
         static_cast<float>(scale * p.z + offset.z)};
  }
  return out;
}

Mesh unit_cube() {
  Mesh cube;
  for (int i = 0; i < 8; ++i) cube.positions.push_back({float(i & 1), float((i >> 1) & 1), float(i >> 2)});
  // Outward, counter-clockwise: two triangles per face.
  const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    cube.triangles.push_back({{q[0], q[1], q[2]}});
    cube.triangles.push_back({{q[0], q[2], q[3]}});
  }
  return cube;
}

// --- point-triangle distance -------------------------------------------------------------------

TEST(PointTriangle, AgreesWithADenseBarycentricGridOnRandomCases) {
  const std::uint64_t seed = 987654321;
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> coordinate(-1, 1);
  auto point = [&] { return Vec3d{coordinate(random), coordinate(random), coordinate(random)}; };
  constexpr int kGrid = 120;
  for (int trial = 0; trial < 600; ++trial) {
    Vec3d a = point(), b = point(), c = point();
    if (trial % 10 == 1) c = a + 0.3 * (b - a);  // collinear
    if (trial % 10 == 2) b = c = a;               // a point
    if (trial % 10 == 3) c = b;                   // a segment
    Vec3d p = point();
    if (trial % 10 == 4) p = (1.0 / 3) * (a + b + c) + 1e-3 * point();  // nearly on it
    Vec3d closest;
    const double d2 = point_triangle_distance_squared(p, a, b, c, &closest);
    ASSERT_NEAR(std::sqrt(d2), distance(p, closest), 1e-12) << "trial " << trial;
    // The reported point lies in the triangle: it is a convex combination of the corners,
    // i.e. its distance to the triangle is zero by the grid below (within the grid step).
    double grid_best = std::numeric_limits<double>::infinity(), closest_to_grid = grid_best;
    for (int i = 0; i <= kGrid; ++i) {
      for (int j = 0; i + j <= kGrid; ++j) {
        const double u = double(i) / kGrid, v = double(j) / kGrid;
        const Vec3d q = a + u * (b - a) + v * (c - a);
        grid_best = std::min(grid_best, distance(p, q));
        closest_to_grid = std::min(closest_to_grid, distance(closest, q));
      }
    }
    const double step = std::max({distance(a, b), distance(b, c), distance(c, a)}) / kGrid;
    const double d = std::sqrt(d2);
    ASSERT_LE(d, grid_best + 1e-12) << "trial " << trial;  // no grid point is nearer
    ASSERT_GE(d, grid_best - step) << "trial " << trial;   // and the grid gets close
    ASSERT_LE(closest_to_grid, step) << "trial " << trial;
  }
}

TEST(PointTriangle, ExactCases) {
  const Vec3d a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_DOUBLE_EQ(point_triangle_distance_squared({0.25, 0.25, 2}, a, b, c), 4.0);  // face
  EXPECT_DOUBLE_EQ(point_triangle_distance_squared({-3, -4, 0}, a, b, c), 25.0);     // corner
  EXPECT_DOUBLE_EQ(point_triangle_distance_squared({0.5, -2, 0}, a, b, c), 4.0);     // side
  EXPECT_DOUBLE_EQ(point_triangle_distance_squared({1, 1, 0}, a, b, c), 0.5);        // hypotenuse
}

// --- AABB tree -----------------------------------------------------------------------------------

TEST(TriangleTree, NearestEqualsALinearScan) {
  const std::uint64_t seed = 424242;
  SCOPED_TRACE("seed " + std::to_string(seed));
  ShapeOptions options;
  options.vertices = 800;
  options.noise = 0.01;
  const Mesh mesh = testing::make_genus2(options);
  const TriangleTree tree(mesh.view());
  EXPECT_EQ(tree.triangle_count(), mesh.triangles.size());
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> coordinate(-3, 3);
  std::uint32_t hint = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3d p{coordinate(random), coordinate(random) / 2, coordinate(random) / 4};
    double expected = std::numeric_limits<double>::infinity();
    for (const Triangle& t : mesh.triangles) {
      expected = std::min(expected, point_triangle_distance_squared(
                                        p, to_double(mesh.positions[t.v[0]]),
                                        to_double(mesh.positions[t.v[1]]),
                                        to_double(mesh.positions[t.v[2]])));
    }
    ASSERT_EQ(tree.nearest_distance_squared(p, &hint), expected) << "trial " << trial;
    ASSERT_EQ(tree.nearest_distance_squared(p), expected) << "trial " << trial;
  }
}

// --- the measure ---------------------------------------------------------------------------------

DistanceOptions few_samples() {
  DistanceOptions options;
  options.samples = 60000;
  return options;
}

TEST(MeshDistance, IdenticalMeshesAreAtDistanceZero) {
  ShapeOptions shape;
  shape.vertices = 3000;
  shape.rotation = testing::random_rotation(3);
  const Mesh mesh = testing::make_torus(1, 0.4, shape);
  auto result = mesh_distance(mesh.view(), mesh.view(), few_samples());
  ASSERT_TRUE(result) << result.status().to_string();
  EXPECT_LT(result->hausdorff_pct(), 1e-5);
  EXPECT_LT(result->rms_pct(), 1e-5);
  EXPECT_GT(result->a_to_b.area_samples, 0u);
}

TEST(MeshDistance, TranslationByDGivesD) {
  // For convex polyhedra, the Hausdorff distance to a translate is the translation's length,
  // attained at a vertex (which is sampled).
  ShapeOptions shape;
  shape.vertices = 2000;
  for (const Mesh& mesh : {unit_cube(), testing::make_sphere(shape)}) {
    for (double d : {0.01, 0.1}) {
      const Mesh moved = transformed(mesh, 1, {d * 0.6, -d * 0.8, 0});
      auto result = mesh_distance(mesh.view(), moved.view(), few_samples());
      ASSERT_TRUE(result) << result.status().to_string();
      const double expected = 100 * d / result->diagonal;
      EXPECT_NEAR(result->hausdorff_pct(), expected, 1e-4 * expected) << "d " << d;
      EXPECT_NEAR(MeshDistance::pct(result->a_to_b.max, result->diagonal), expected, 1e-4 * expected);
      EXPECT_NEAR(MeshDistance::pct(result->b_to_a.max, result->diagonal), expected, 1e-4 * expected);
      EXPECT_LT(result->rms, d);
      EXPECT_GT(result->rms, 0.2 * d);
    }
  }
}

TEST(MeshDistance, ConcentricSpheresAreEverywhereTheRadiusGapApart) {
  ShapeOptions shape;
  shape.vertices = 20000;
  const Mesh inner = testing::make_sphere(shape);
  const Mesh outer = transformed(inner, 1.05, {0, 0, 0});
  auto result = mesh_distance(inner.view(), outer.view(), few_samples());
  ASSERT_TRUE(result) << result.status().to_string();
  // Inscribed polyhedra: distances are 0.05 up to the chordal error (~1e-4 here).
  EXPECT_NEAR(result->hausdorff, 0.05, 0.05 * 0.01);
  EXPECT_NEAR(result->rms, 0.05, 0.05 * 0.01);
  EXPECT_NEAR(result->a_to_b.mean, 0.05, 0.05 * 0.01);
}

TEST(MeshDistance, SphereAgainstEllipsoidMatchesTheAnalyticHausdorff) {
  // Unit sphere inside the ellipsoid (1.3, 1.1, 1.0): every point of either surface is within
  // 0.3 of the other, attained at (+-1.3, 0, 0) one way and (+-1, 0, 0) the other.
  ShapeOptions shape;
  shape.vertices = 20000;
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE("rotation seed " + std::to_string(seed));
    shape.rotation = testing::random_rotation(seed);
    const Mesh sphere = testing::make_sphere(shape);
    const Mesh ellipsoid = testing::make_ellipsoid(1.3, 1.1, 1.0, shape);
    auto result = mesh_distance(sphere.view(), ellipsoid.view(), few_samples());
    ASSERT_TRUE(result) << result.status().to_string();
    EXPECT_NEAR(result->hausdorff, 0.3, 0.3 * 0.01);
    EXPECT_NEAR(result->a_to_b.max, 0.3, 0.3 * 0.01);
    EXPECT_NEAR(result->b_to_a.max, 0.3, 0.3 * 0.01);
    EXPECT_NEAR(result->hausdorff_pct(), 100 * 0.3 / result->diagonal, 0.3);
  }
}

TEST(MeshDistance, SampleCountsFollowAreaAndFeatures) {
  ShapeOptions shape;
  shape.vertices = 1500;
  const Mesh a = testing::make_sphere(shape);
  const Mesh b = transformed(a, 1.5, {0.1, 0, 0});  // 2.25x the area
  DistanceOptions options = few_samples();
  auto result = mesh_distance(a.view(), b.view(), options);
  ASSERT_TRUE(result) << result.status().to_string();
  const double n = double(options.samples);
  EXPECT_NEAR(double(result->a_to_b.area_samples), n, 0.01 * n);
  EXPECT_NEAR(double(result->b_to_a.area_samples), 2.25 * n, 0.01 * 2.25 * n);
  EXPECT_EQ(result->a_to_b.feature_samples, a.positions.size() + 3 * a.triangles.size());
  EXPECT_EQ(result->b_to_a.feature_samples, b.positions.size() + 3 * b.triangles.size());
}

TEST(MeshDistance, NamesWhereTheLargestDistanceLies) {
  // One vertex of a sphere pulled outwards: B's farthest sample from A is that vertex, and A's
  // farthest sample from B lies on A below it, nearer to it than to anything else of A.
  ShapeOptions shape;
  shape.vertices = 2000;
  const Mesh a = testing::make_sphere(shape);
  Mesh b = a;
  const std::size_t pulled = a.positions.size() / 3;
  const Vec3f& p = a.positions[pulled];
  b.positions[pulled] = {1.2f * p.x, 1.2f * p.y, 1.2f * p.z};
  auto result = mesh_distance(a.view(), b.view(), few_samples());
  ASSERT_TRUE(result) << result.status().to_string();
  EXPECT_EQ(result->b_to_a.max_at.x, b.positions[pulled].x);
  EXPECT_EQ(result->b_to_a.max_at.y, b.positions[pulled].y);
  EXPECT_EQ(result->b_to_a.max_at.z, b.positions[pulled].z);
  std::size_t nearest = 0;
  for (std::size_t v = 1; v < a.positions.size(); ++v) {
    if (distance(to_double(a.positions[v]), result->a_to_b.max_at) <
        distance(to_double(a.positions[nearest]), result->a_to_b.max_at))
      nearest = v;
  }
  EXPECT_EQ(nearest, pulled);
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    auto one = mesh_distance(a.view(), b.view(), few_samples());
    ASSERT_TRUE(one);
    EXPECT_EQ(one->a_to_b.max_at.x, result->a_to_b.max_at.x);
    EXPECT_EQ(one->a_to_b.max_at.y, result->a_to_b.max_at.y);
    EXPECT_EQ(one->a_to_b.max_at.z, result->a_to_b.max_at.z);
  }
}

TEST(MeshDistance, CountsTheFacesThatFaceAway) {
  // The same sphere with three faces turned over (two corners swapped): each side counts exactly
  // those three, and their share of the area; the sphere against itself counts none.
  ShapeOptions shape;
  shape.vertices = 2000;
  const Mesh a = testing::make_sphere(shape);
  Mesh b = a;
  double turned_area = 0, area = 0;
  for (std::size_t t = 0; t < b.triangles.size(); ++t) {
    const Vec3d p = to_double(a.positions[a.triangles[t].v[0]]), q = to_double(a.positions[a.triangles[t].v[1]]),
                r = to_double(a.positions[a.triangles[t].v[2]]);
    const Vec3d n = cross(q - p, r - p);
    const double face_area = 0.5 * std::sqrt(dot(n, n));
    area += face_area;
    if (t % 500 == 7) {
      std::swap(b.triangles[t].v[1], b.triangles[t].v[2]);
      turned_area += face_area;
    }
  }
  auto same = mesh_distance(a.view(), a.view(), few_samples());
  ASSERT_TRUE(same);
  EXPECT_EQ(same->a_to_b.facing_away, 0u);
  EXPECT_EQ(same->b_to_a.facing_away, 0u);
  auto turned = mesh_distance(a.view(), b.view(), few_samples());
  ASSERT_TRUE(turned);
  const std::size_t expected = (b.triangles.size() + 492) / 500;
  EXPECT_EQ(turned->b_to_a.facing_away, expected);
  EXPECT_EQ(turned->a_to_b.facing_away, expected);
  EXPECT_NEAR(turned->b_to_a.facing_away_area, turned_area, 1e-9 * area);
  EXPECT_NEAR(turned->b_to_a.area, area, 1e-9 * area);
}

TEST(MeshDistance, DeterministicWhateverTheThreadCount) {
  ShapeOptions shape;
  shape.vertices = 3000;
  const Mesh a = testing::make_dented_sphere(0.3, shape);
  shape.noise = 0.002;
  const Mesh b = testing::make_dented_sphere(0.3, shape);
  MeshDistance one, two, other_seed;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    auto r = mesh_distance(a.view(), b.view(), few_samples());
    ASSERT_TRUE(r);
    one = *r;
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    auto r = mesh_distance(a.view(), b.view(), few_samples());
    ASSERT_TRUE(r);
    two = *r;
  }
  EXPECT_EQ(one.hausdorff, two.hausdorff);
  EXPECT_EQ(one.rms, two.rms);
  EXPECT_EQ(one.a_to_b.area_samples, two.a_to_b.area_samples);
  DistanceOptions options = few_samples();
  options.seed = 99;
  auto r = mesh_distance(a.view(), b.view(), options);
  ASSERT_TRUE(r);
  EXPECT_NE(r->rms, one.rms);
  EXPECT_NEAR(r->rms, one.rms, 0.05 * one.rms);  // same quantity, other samples
}

TEST(MeshDistance, RejectsUnmeasurableInput) {
  const Mesh cube = unit_cube();
  Mesh empty;
  auto r = mesh_distance(cube.view(), empty.view());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), Code::kBadInput);
  EXPECT_EQ(r.status().where(), "B");

  Mesh bad_index = cube;
  bad_index.triangles.push_back({{0, 1, 8}});
  r = mesh_distance(bad_index.view(), cube.view());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), Code::kBadInput);
  EXPECT_EQ(r.status().where(), "A");

  Mesh nan = cube;
  nan.positions[3].y = std::numeric_limits<float>::quiet_NaN();
  r = mesh_distance(cube.view(), nan.view());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), Code::kBadInput);

  Mesh point;
  point.positions = {{1, 1, 1}};
  point.triangles = {{{0, 0, 0}}};
  r = mesh_distance(point.view(), cube.view());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), Code::kBadInput);

  DistanceOptions none;
  none.samples = 0;
  r = mesh_distance(cube.view(), cube.view(), none);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status().code(), Code::kUsage);
}

}  // namespace
}  // namespace gaussmesh::stream
