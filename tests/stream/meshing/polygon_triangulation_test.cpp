// Tests of the polygon-with-holes triangulator (paper §5, per-patch mesher): invariants on
// small hand-built polygons, tilted 3D copies, random star polygons with holes, degenerate and
// failing inputs, forbidden edges and determinism.
#include "stream/meshing/polygon_triangulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace gaussmesh::stream {
namespace {

using P2 = PolygonPoint2;
using P3 = PolygonPoint3;
using Loops = std::vector<std::vector<std::uint32_t>>;
using Triangles = std::vector<PolygonTriangle>;

// A polygon under construction: points plus loops of indices into them.
struct Polygon {
  std::vector<P2> points;
  Loops loops;

  // Appends a loop through the given points (new indices).
  void add_loop(const std::vector<P2>& loop) {
    std::vector<std::uint32_t> ids;
    for (const P2& p : loop) {
      ids.push_back(std::uint32_t(points.size()));
      points.push_back(p);
    }
    loops.push_back(ids);
  }
  std::size_t vertex_count() const {
    std::size_t n = 0;
    for (const auto& loop : loops) n += loop.size();
    return n;
  }
  // n + 2h - 2: the count when no loops touch.
  std::size_t expected_triangles() const { return vertex_count() + 2 * (loops.size() - 1) - 2; }
};

std::vector<P2> regular_polygon(std::size_t n, double radius, P2 centre, bool clockwise = false) {
  std::vector<P2> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double angle = 2 * std::numbers::pi * double(i) / double(n) * (clockwise ? -1 : 1);
    out.push_back({centre[0] + radius * std::cos(angle), centre[1] + radius * std::sin(angle)});
  }
  return out;
}

long double loop_area(const std::vector<P2>& points, const std::vector<std::uint32_t>& loop) {
  long double twice = 0;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const P2 &a = points[loop[i]], &b = points[loop[(i + 1) % loop.size()]];
    twice += (long double)a[0] * b[1] - (long double)a[1] * b[0];
  }
  return twice / 2;
}

long double triangle_area(const std::vector<P2>& points, const PolygonTriangle& t) {
  const P2 &a = points[t[0]], &b = points[t[1]], &c = points[t[2]];
  return ((long double)(b[0] - a[0]) * (c[1] - a[1]) - (long double)(b[1] - a[1]) * (c[0] - a[0])) / 2;
}

std::uint64_t key(std::uint32_t u, std::uint32_t v) {
  return (std::uint64_t(std::min(u, v)) << 32) | std::max(u, v);
}

// Do closed segments ab and cd meet anywhere but at a shared endpoint index?
bool segments_meet(const std::vector<P2>& pts, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  const int shared = (a == c) + (a == d) + (b == c) + (b == d);
  if (shared == 2) return true;
  auto on = [&](std::uint32_t p, std::uint32_t q, std::uint32_t x) {
    const P2 &pp = pts[p], &pq = pts[q], &px = pts[x];
    return orientation_2d(pp, pq, px) == 0 && std::min(pp[0], pq[0]) <= px[0] && px[0] <= std::max(pp[0], pq[0]) &&
           std::min(pp[1], pq[1]) <= px[1] && px[1] <= std::max(pp[1], pq[1]);
  };
  const int o1 = orientation_2d(pts[a], pts[b], pts[c]), o2 = orientation_2d(pts[a], pts[b], pts[d]);
  const int o3 = orientation_2d(pts[c], pts[d], pts[a]), o4 = orientation_2d(pts[c], pts[d], pts[b]);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  if (c != a && c != b && on(a, b, c)) return true;
  if (d != a && d != b && on(a, b, d)) return true;
  if (a != c && a != d && on(c, d, a)) return true;
  if (b != c && b != d && on(c, d, b)) return true;
  return false;
}

// Every invariant of a valid triangulation of `polygon` (2D points). `expected` is the
// triangle count; pairwise edge crossings are checked when the polygon is small.
::testing::AssertionResult is_valid_triangulation(const Polygon& polygon, const Triangles& triangles,
                                                  std::size_t expected) {
  const auto& pts = polygon.points;
  if (triangles.size() != expected) {
    return ::testing::AssertionFailure() << triangles.size() << " triangles, expected " << expected;
  }
  std::set<std::uint32_t> vertices;
  std::multiset<std::uint64_t> loop_edges;
  long double area = 0;
  for (std::size_t k = 0; k < polygon.loops.size(); ++k) {
    const auto& loop = polygon.loops[k];
    vertices.insert(loop.begin(), loop.end());
    for (std::size_t i = 0; i < loop.size(); ++i) loop_edges.insert(key(loop[i], loop[(i + 1) % loop.size()]));
    area += (k == 0 ? 1 : -1) * std::abs(loop_area(pts, loop));
  }
  std::map<std::uint64_t, int> uses;
  std::set<std::uint64_t> directed;
  long double sum = 0;
  for (const auto& t : triangles) {
    for (std::uint32_t v : t) {
      if (!vertices.count(v)) return ::testing::AssertionFailure() << "vertex " << v << " is not on a loop";
    }
    if (orientation_2d(pts[t[0]], pts[t[1]], pts[t[2]]) <= 0) {
      return ::testing::AssertionFailure() << "triangle " << t[0] << " " << t[1] << " " << t[2]
                                           << " is not strictly counter-clockwise";
    }
    sum += triangle_area(pts, t);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = t[k], v = t[(k + 1) % 3];
      ++uses[key(u, v)];
      if (!directed.insert((std::uint64_t(u) << 32) | v).second) {
        return ::testing::AssertionFailure() << "directed edge " << u << "->" << v << " used twice";
      }
    }
  }
  if (std::abs(sum - area) > 1e-9 * std::abs(area)) {
    return ::testing::AssertionFailure() << "triangle area " << double(sum) << " != polygon area " << double(area);
  }
  for (auto [edge, count] : uses) {
    const bool on_loop = loop_edges.count(edge) > 0;
    if (count != (on_loop ? 1 : 2)) {
      return ::testing::AssertionFailure() << (on_loop ? "loop" : "interior") << " edge " << (edge >> 32) << "-"
                                           << (edge & 0xffffffffu) << " is in " << count << " triangles";
    }
  }
  for (std::uint64_t edge : loop_edges) {
    if (!uses.count(edge)) return ::testing::AssertionFailure() << "loop edge " << (edge >> 32) << " missing";
  }
  if (uses.size() <= 600) {
    std::vector<std::uint64_t> edges;
    for (auto [edge, count] : uses) edges.push_back(edge);
    for (std::size_t i = 0; i < edges.size(); ++i) {
      for (std::size_t j = i + 1; j < edges.size(); ++j) {
        const std::uint32_t a = edges[i] >> 32, b = edges[i] & 0xffffffffu, c = edges[j] >> 32, d = edges[j] & 0xffffffffu;
        if (segments_meet(pts, a, b, c, d)) {
          return ::testing::AssertionFailure() << "edges " << a << "-" << b << " and " << c << "-" << d << " cross";
        }
      }
    }
  }
  return ::testing::AssertionSuccess();
}

Triangles triangulate_or_fail(const Polygon& polygon, const ForbiddenEdge& forbidden = {}) {
  auto result = triangulate_polygon_2d(polygon.points, polygon.loops, forbidden);
  EXPECT_TRUE(result.is_ok()) << result.status().to_string();
  return result.is_ok() ? result.value() : Triangles{};
}

// Triangles as a sorted set of rotations starting at their smallest index.
std::vector<PolygonTriangle> canonical(Triangles triangles) {
  for (auto& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
  return triangles;
}

// A star-shaped polygon around `centre` with n vertices at random radii in [r_min, r_max].
std::vector<P2> random_star(std::mt19937_64& rng, std::size_t n, P2 centre, double r_min, double r_max) {
  std::uniform_real_distribution<double> radius(r_min, r_max), jitter(-0.3, 0.3);
  std::vector<P2> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double angle = 2 * std::numbers::pi * (double(i) + jitter(rng)) / double(n);
    const double r = radius(rng);
    out.push_back({centre[0] + r * std::cos(angle), centre[1] + r * std::sin(angle)});
  }
  return out;
}

// A random star polygon (radii in [0.5, 1]) with up to `holes` random star holes inside the
// disk of radius 0.42 (which the outer star contains for n >= 8).
Polygon random_polygon_with_holes(std::mt19937_64& rng, std::size_t n, std::size_t holes) {
  Polygon polygon;
  polygon.add_loop(random_star(rng, n, {0, 0}, 0.5, 1.0));
  std::uniform_real_distribution<double> unit(-1, 1), size(0.03, 0.1);
  std::uniform_int_distribution<std::size_t> count(3, 9);
  std::vector<std::pair<P2, double>> placed;
  for (std::size_t attempt = 0; attempt < 50 * holes && placed.size() < holes; ++attempt) {
    const double r = size(rng);
    const P2 c = {unit(rng) * 0.42, unit(rng) * 0.42};
    if (std::hypot(c[0], c[1]) + r > 0.42) continue;
    bool apart = true;
    for (auto [other, other_r] : placed) apart = apart && std::hypot(c[0] - other[0], c[1] - other[1]) > r + other_r + 0.01;
    if (!apart) continue;
    placed.push_back({c, r});
    auto hole = random_star(rng, count(rng), c, 0.4 * r, r);
    if (attempt % 2 == 0) std::reverse(hole.begin(), hole.end());  // either orientation
    polygon.add_loop(hole);
  }
  return polygon;
}

// ---------------------------------------------------------------------------------------------

TEST(PolygonTriangulation, Triangle) {
  Polygon p;
  p.add_loop({{0, 0}, {1, 0}, {0, 1}});
  const Triangles t = triangulate_or_fail(p);
  EXPECT_TRUE(is_valid_triangulation(p, t, 1));
}

TEST(PolygonTriangulation, Square) {
  Polygon p;
  p.add_loop({{0, 0}, {1, 0}, {1, 1}, {0, 1}});
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), 2));
}

TEST(PolygonTriangulation, ConvexPolygonsAndTheirDelaunayEdges) {
  for (std::size_t n : {5u, 12u, 64u}) {
    Polygon p;
    p.add_loop(regular_polygon(n, 1.0, {0.25, -3}));
    const Triangles t = triangulate_or_fail(p);
    EXPECT_TRUE(is_valid_triangulation(p, t, n - 2)) << "n = " << n;
  }
  // An elongated convex polygon: a fan would be needle-thin; the Delaunay flips make every
  // interior edge locally Delaunay (checked in long double on this well-conditioned input).
  Polygon ellipse;
  for (int i = 0; i < 40; ++i) {
    const double a = 2 * std::numbers::pi * i / 40;
    ellipse.points.push_back({10 * std::cos(a), std::sin(a)});
  }
  ellipse.loops.push_back({});
  for (std::uint32_t i = 0; i < 40; ++i) ellipse.loops[0].push_back(i);
  const Triangles t = triangulate_or_fail(ellipse);
  ASSERT_TRUE(is_valid_triangulation(ellipse, t, 38));
  std::map<std::uint64_t, std::vector<std::uint32_t>> opposite;
  for (const auto& tri : t) {
    for (int k = 0; k < 3; ++k) opposite[key(tri[k], tri[(k + 1) % 3])].push_back(tri[(k + 2) % 3]);
  }
  for (const auto& tri : t) {
    for (int k = 0; k < 3; ++k) {
      const auto& others = opposite[key(tri[k], tri[(k + 1) % 3])];
      for (std::uint32_t x : others) {
        if (x == tri[(k + 2) % 3]) continue;
        auto d = [&](std::uint32_t i) { return ellipse.points[i]; };
        const P2 a = d(tri[0]), b = d(tri[1]), c = d(tri[2]), q = d(x);
        auto row = [&](const P2& p) {
          return std::array<long double, 3>{p[0] - q[0], p[1] - q[1],
                                            (long double)(p[0] - q[0]) * (p[0] - q[0]) + (long double)(p[1] - q[1]) * (p[1] - q[1])};
        };
        const auto ra = row(a), rb = row(b), rc = row(c);
        const long double det = ra[0] * (rb[1] * rc[2] - rb[2] * rc[1]) - ra[1] * (rb[0] * rc[2] - rb[2] * rc[0]) +
                                ra[2] * (rb[0] * rc[1] - rb[1] * rc[0]);
        EXPECT_LE(double(det), 1e-9) << "edge " << tri[k] << "-" << tri[(k + 1) % 3] << " is not locally Delaunay";
      }
    }
  }
}

TEST(PolygonTriangulation, Comb) {
  Polygon p;
  std::vector<P2> comb = {{0, 0}, {10, 0}};
  for (int tooth = 4; tooth >= 0; --tooth) {
    const double x = 2.0 * tooth;
    comb.push_back({x + 2, 5});
    comb.push_back({x + 1, 5});
    comb.push_back({x + 1, 1});
    if (tooth > 0) comb.push_back({x, 1});
  }
  comb.push_back({0, 5});
  p.add_loop(comb);
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), p.expected_triangles()));
}

TEST(PolygonTriangulation, Spiral) {
  // A thick square spiral: an arm that turns four times inwards, then comes back out.
  Polygon p;
  std::vector<P2> outer_path = {{0, 0}, {10, 0}, {10, 10}, {2, 10}, {2, 4}, {6, 4}, {6, 6}};
  std::vector<P2> inner_path = {{4, 6}, {4, 8}, {8, 8}, {8, 2}, {0, 2}};  // the same turns, one lane in
  std::vector<P2> loop = outer_path;
  loop.insert(loop.end(), inner_path.begin(), inner_path.end());
  p.add_loop(loop);
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), p.expected_triangles()));
}

TEST(PolygonTriangulation, Star) {
  Polygon p;
  std::vector<P2> star;
  for (int i = 0; i < 14; ++i) {
    const double a = 2 * std::numbers::pi * i / 14, r = i % 2 ? 0.3 : 1.0;
    star.push_back({r * std::cos(a), r * std::sin(a)});
  }
  p.add_loop(star);
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), 12));
}

TEST(PolygonTriangulation, OneHole) {
  Polygon p;
  p.add_loop({{0, 0}, {4, 0}, {4, 4}, {0, 4}});
  p.add_loop({{1, 1}, {1, 3}, {3, 3}, {3, 1}});
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), 8));
}

TEST(PolygonTriangulation, SeveralHolesAlignedWithEachOtherAndTheBoundary) {
  // A 4x3 grid of square holes in a rectangle: hole vertices share x and y with each other and
  // with outer vertices, so the ray casts hit vertices exactly and several holes tie for the
  // rightmost position.
  Polygon p;
  p.add_loop({{0, 0}, {1, 0}, {9, 0}, {9, 7}, {5, 7}, {0, 7}});
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double x = 1 + 2 * i, y = 1 + 2 * j;
      p.add_loop({{x, y}, {x + 1, y}, {x + 1, y + 1}, {x, y + 1}});
    }
  }
  EXPECT_TRUE(is_valid_triangulation(p, triangulate_or_fail(p), p.expected_triangles()));
}

TEST(PolygonTriangulation, CollinearVerticesAreKept) {
  Polygon p;
  std::vector<P2> square;
  for (int i = 0; i < 4; ++i) square.push_back({double(i), 0});
  for (int i = 0; i < 4; ++i) square.push_back({4, double(i)});
  for (int i = 0; i < 4; ++i) square.push_back({4 - double(i), 4});
  for (int i = 0; i < 4; ++i) square.push_back({0, 4 - double(i)});
  p.add_loop(square);
  p.add_loop({{1.5, 1.5}, {1.5, 2}, {1.5, 2.5}, {2.5, 2.5}, {2.5, 2}, {2.5, 1.5}, {2, 1.5}});  // a hole, collinear too
  const Triangles t = triangulate_or_fail(p);
  EXPECT_TRUE(is_valid_triangulation(p, t, p.expected_triangles()));
  // A triangle with many points on one edge: only a fan from the opposite corner works.
  Polygon fan;
  std::vector<P2> loop = {{0, 1}};
  for (int i = 0; i <= 10; ++i) loop.push_back({double(i), 0});
  fan.add_loop(loop);
  EXPECT_TRUE(is_valid_triangulation(fan, triangulate_or_fail(fan), 10));
}

TEST(PolygonTriangulation, ReversedOrientationGivesTheSameTriangles) {
  Polygon p;
  p.add_loop({{0, 0}, {4, 0}, {4, 4}, {2, 1}, {0, 4}});
  p.add_loop({{1, 0.5}, {3, 0.5}, {3, 0.8}});  // counter-clockwise hole
  const Triangles forward = triangulate_or_fail(p);
  EXPECT_TRUE(is_valid_triangulation(p, forward, p.expected_triangles()));
  Polygon reversed = p;
  for (auto& loop : reversed.loops) std::reverse(loop.begin(), loop.end());
  const Triangles backward = triangulate_or_fail(reversed);
  EXPECT_TRUE(is_valid_triangulation(reversed, backward, p.expected_triangles()));
  EXPECT_EQ(canonical(forward), canonical(backward));
}

TEST(PolygonTriangulation, TiltedPolygonsIn3d) {
  const std::uint64_t seed = 20240611;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss;
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " trial " + std::to_string(trial));
    const Polygon flat = random_polygon_with_holes(rng, 30, 3);
    // A random rotation (columns e1, e2, n) and offset; the normal is the rotated z axis.
    P3 n = {gauss(rng), gauss(rng), gauss(rng)};
    const double ln = std::hypot(n[0], n[1], n[2]);
    n = {n[0] / ln, n[1] / ln, n[2] / ln};
    P3 e1 = {-n[1], n[0], 0};
    if (std::hypot(e1[0], e1[1]) < 0.1) e1 = {0, -n[2], n[1]};
    const double l1 = std::hypot(e1[0], e1[1], e1[2]);
    e1 = {e1[0] / l1, e1[1] / l1, e1[2] / l1};
    const P3 e2 = {n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2], n[0] * e1[1] - n[1] * e1[0]};
    const P3 offset = {100 * gauss(rng), 100 * gauss(rng), 100 * gauss(rng)};
    std::vector<P3> points;
    for (const P2& q : flat.points) {
      points.push_back({offset[0] + q[0] * e1[0] + q[1] * e2[0], offset[1] + q[0] * e1[1] + q[1] * e2[1],
                        offset[2] + q[0] * e1[2] + q[1] * e2[2]});
    }
    const P3 scaled_normal = {3 * n[0], 3 * n[1], 3 * n[2]};  // the length must not matter
    auto result = triangulate_polygon(points, flat.loops, scaled_normal);
    ASSERT_TRUE(result.is_ok()) << result.status().to_string();
    // Exact checks in the plane coordinates the triangulator documents.
    Polygon projected = flat;
    projected.points = project_to_plane(points, scaled_normal, points[flat.loops[0][0]]);
    EXPECT_TRUE(is_valid_triangulation(projected, result.value(), flat.expected_triangles()));
    // And in 3D: every triangle faces the viewer at the tip of the normal.
    for (const auto& t : result.value()) {
      const P3 &a = points[t[0]], &b = points[t[1]], &c = points[t[2]];
      const P3 u = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const P3 cr = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      EXPECT_GT(cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2], 0.0);
    }
    // Seen from the other side, the same loops give the mirror image: still valid, reversed.
    const P3 flipped = {-n[0], -n[1], -n[2]};
    auto mirrored = triangulate_polygon(points, flat.loops, flipped);
    ASSERT_TRUE(mirrored.is_ok()) << mirrored.status().to_string();
    Polygon mirror_plane = flat;
    mirror_plane.points = project_to_plane(points, flipped, points[flat.loops[0][0]]);
    EXPECT_TRUE(is_valid_triangulation(mirror_plane, mirrored.value(), flat.expected_triangles()));
  }
}

TEST(PolygonTriangulation, RandomStarPolygonsWithHoles) {
  const std::uint64_t seed = 7;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> sizes(8, 120), hole_counts(0, 6);
  for (int trial = 0; trial < 300; ++trial) {
    const Polygon p = random_polygon_with_holes(rng, sizes(rng), hole_counts(rng));
    SCOPED_TRACE("seed " + std::to_string(seed) + " trial " + std::to_string(trial) + " vertices " +
                 std::to_string(p.vertex_count()) + " holes " + std::to_string(p.loops.size() - 1));
    auto result = triangulate_polygon_2d(p.points, p.loops);
    ASSERT_TRUE(result.is_ok()) << result.status().to_string();
    ASSERT_TRUE(is_valid_triangulation(p, result.value(), p.expected_triangles()));
  }
}

TEST(PolygonTriangulation, LargeRandomPolygon) {
  const std::uint64_t seed = 99;
  std::mt19937_64 rng(seed);
  const Polygon p = random_polygon_with_holes(rng, 3000, 20);
  auto result = triangulate_polygon_2d(p.points, p.loops);
  ASSERT_TRUE(result.is_ok()) << "seed " << seed << ": " << result.status().to_string();
  EXPECT_TRUE(is_valid_triangulation(p, result.value(), p.expected_triangles())) << "seed " << seed;
}

TEST(PolygonTriangulation, DeterministicAndIndependentOfLoopRotation) {
  const std::uint64_t seed = 11;
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < 30; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " trial " + std::to_string(trial));
    const Polygon p = random_polygon_with_holes(rng, 60, 4);
    const Triangles first = triangulate_or_fail(p), second = triangulate_or_fail(p);
    EXPECT_EQ(first, second);
    Polygon rotated = p;
    for (auto& loop : rotated.loops) std::rotate(loop.begin(), loop.begin() + std::ptrdiff_t(loop.size() / 3), loop.end());
    EXPECT_EQ(canonical(first), canonical(triangulate_or_fail(rotated)));
  }
}

TEST(PolygonTriangulation, HoleTouchingTheOuterLoopAtAVertex) {
  // The hole shares point 0 (index and position) with the outer loop: a weakly simple polygon
  // of 4 + 3 visits, so 5 triangles (2 fewer than for a free hole).
  Polygon p;
  p.points = {{0, 0}, {4, 0}, {4, 4}, {0, 4}, {2, 1}, {1, 2}};
  p.loops = {{0, 1, 2, 3}, {0, 5, 4}};
  const Triangles t = triangulate_or_fail(p);
  EXPECT_TRUE(is_valid_triangulation(p, t, 5));
  // Touching from outside is not a hole of this polygon.
  Polygon outside;
  outside.points = {{0, 0}, {4, 0}, {4, 4}, {0, 4}, {-2, -1}, {-1, -2}};
  outside.loops = {{0, 1, 2, 3}, {0, 5, 4}};
  EXPECT_FALSE(triangulate_polygon_2d(outside.points, outside.loops).is_ok());
}

TEST(PolygonTriangulation, HolesTouchingEachOther) {
  Polygon p;
  p.points = {{0, 0}, {6, 0}, {6, 4}, {0, 4}, {1, 1}, {3, 2}, {1, 3}, {5, 1}, {5, 3}};
  p.loops = {{0, 1, 2, 3}, {4, 5, 6}, {5, 7, 8}};  // two triangles sharing point 5
  const Triangles t = triangulate_or_fail(p);
  // 10 visits, one hole bridged (+2), one spliced at the shared point: 10 + 2 - 2 = 10.
  EXPECT_TRUE(is_valid_triangulation(p, t, 10));
}

TEST(PolygonTriangulation, LoopTouchingItselfAtAVertex) {
  // A square whose boundary, at corner 0, makes a closed clockwise excursion
  // into the square (a hole attached at a corner, given as one loop).
  Polygon q;
  q.points = {{0, 0}, {4, 0}, {4, 4}, {0, 4}, {1, 2}, {2, 1}};
  q.loops = {{0, 1, 2, 3, 0, 4, 5}};  // 0 -> 1 -> 2 -> 3 -> 0, then 0 -> 4 -> 5 -> 0 (clockwise)
  const Triangles t = triangulate_or_fail(q);
  EXPECT_TRUE(is_valid_triangulation(q, t, 5));
  // A figure eight (two counter-clockwise lobes joined at point 0) is two polygons, not one:
  // rejected with a clear error (documented), like a loop crossing itself at a vertex.
  const std::vector<P2> eight = {{0, 0}, {2, -1}, {2, 1}, {-2, 1}, {-2, -1}};
  const Loops eight_loop = {{0, 1, 2, 0, 3, 4}};
  auto result = triangulate_polygon_2d(eight, eight_loop);
  ASSERT_FALSE(result.is_ok());
  EXPECT_NE(result.status().message().find("point 0"), std::string::npos) << result.status().message();
}

TEST(PolygonTriangulation, ForbiddenDiagonalIsAvoided) {
  Polygon p;
  p.add_loop({{0, 0}, {1, 0}, {1.1, 1}, {0, 1}});
  for (auto [u, v] : {std::pair{0u, 2u}, std::pair{1u, 3u}}) {
    const ForbiddenEdge forbid = [u = u, v = v](std::uint32_t a, std::uint32_t b) {
      EXPECT_LT(a, b);  // documented: called with the smaller index first
      return a == u && b == v;
    };
    auto result = triangulate_polygon_2d(p.points, p.loops, forbid);
    ASSERT_TRUE(result.is_ok()) << result.status().to_string();
    EXPECT_TRUE(is_valid_triangulation(p, result.value(), 2));
    for (const auto& t : result.value()) {
      for (int k = 0; k < 3; ++k) EXPECT_NE(key(t[k], t[(k + 1) % 3]), key(u, v));
    }
  }
  auto both = triangulate_polygon_2d(p.points, p.loops, [](std::uint32_t, std::uint32_t) { return true; });
  ASSERT_FALSE(both.is_ok());
  EXPECT_EQ(both.status().code(), format::Code::kProcessing);
  EXPECT_EQ(both.status().where(), "polygon triangulation");
}

TEST(PolygonTriangulation, ForbiddenEdgesNeverAppearInRandomPolygons) {
  // Forbid a pseudo-random twentieth of all pairs (a pure function of the pair): every success
  // must avoid them, and failures must be clean errors.
  const std::uint64_t seed = 5;
  std::mt19937_64 rng(seed);
  const ForbiddenEdge forbid = [](std::uint32_t a, std::uint32_t b) {
    std::uint64_t z = (std::uint64_t(a) << 32 | b) + 0x9e3779b97f4a7c15u;  // splitmix64 finaliser
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return (z ^ (z >> 31)) % 20 == 0;
  };
  int successes = 0;
  for (int trial = 0; trial < 100; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " trial " + std::to_string(trial));
    const Polygon p = random_polygon_with_holes(rng, 20, 2);
    auto result = triangulate_polygon_2d(p.points, p.loops, forbid);
    if (!result.is_ok()) {
      EXPECT_EQ(result.status().code(), format::Code::kProcessing);
      continue;
    }
    ++successes;
    ASSERT_TRUE(is_valid_triangulation(p, result.value(), p.expected_triangles()));
    std::set<std::uint64_t> loop_edges;
    for (const auto& loop : p.loops) {
      for (std::size_t i = 0; i < loop.size(); ++i) loop_edges.insert(key(loop[i], loop[(i + 1) % loop.size()]));
    }
    for (const auto& t : result.value()) {
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = std::min(t[k], t[(k + 1) % 3]), b = std::max(t[k], t[(k + 1) % 3]);
        if (!loop_edges.count(key(a, b))) {
          EXPECT_FALSE(forbid(a, b)) << a << "-" << b;
        }
      }
    }
  }
  // Greedy clipping can paint itself into a corner (typically a last non-convex quad whose one
  // diagonal is forbidden); the mesher's forbidden edges are far sparser than one in twenty.
  EXPECT_GT(successes, 30);
  std::printf("forbidden twentieth of pairs: %d of 100 random polygons triangulated\n", successes);
}

TEST(PolygonTriangulation, FailuresAreErrorsNotCrashes) {
  auto fails = [](const std::vector<P2>& points, const Loops& loops, const std::string& why) {
    auto result = triangulate_polygon_2d(points, loops);
    EXPECT_FALSE(result.is_ok()) << why;
    if (!result.is_ok()) {
      EXPECT_EQ(result.status().code(), format::Code::kProcessing) << why;
      EXPECT_FALSE(result.status().message().empty()) << why;
    }
  };
  fails({{0, 0}, {2, 2}, {2, 0}, {0, 2}}, {{0, 1, 2, 3}}, "bow-tie");
  fails({{0, 0}, {1, 0}, {2, 0}, {3, 0}}, {{0, 1, 2, 3}}, "all collinear");
  fails({{0, 0}, {1, 0}, {2, 0}}, {{0, 1, 2}}, "collinear triangle");
  fails({{0, 0}, {1, 0}}, {{0, 1}}, "two vertices");
  fails({{0, 0}, {1, 0}, {0, 1}}, {{0, 1, 7}}, "index out of range");
  fails({{0, 0}, {1, 0}, {0, 1}}, {}, "no loop");
  fails({{0, 0}, {1, 0}, {0, std::nan("")}}, {{0, 1, 2}}, "NaN");
  fails({{0, 0}, {1, 0}, {1, 0}, {0, 1}}, {{0, 1, 2, 3}}, "zero-length edge");
  fails({{0, 0}, {1, 0}, {0, 1}}, {{0, 1, 0, 2}}, "spike back along an edge");
  fails({{0, 0}, {4, 0}, {4, 4}, {0, 4}, {5, 5}, {6, 5}, {6, 6}}, {{0, 1, 2, 3}, {4, 5, 6}}, "hole outside");
  fails({{0, 0}, {4, 0}, {4, 4}, {0, 4}, {3, 3}, {5, 3}, {5, 2}}, {{0, 1, 2, 3}, {4, 5, 6}}, "hole crossing outer");
  fails({{0, 0}, {4, 0}, {4, 4}, {0, 4}, {1, 1}, {3, 1}, {3, 3}, {1.5, 1.5}, {2.5, 1.5}, {2, 2}},
        {{0, 1, 2, 3}, {4, 5, 6}, {7, 8, 9}}, "nested hole");
  fails({{0, 0}, {4, 0}, {4, 4}, {0, 4}, {0, 2}, {2, 2}}, {{0, 1, 2, 3}, {4, 5, 2}}, "hole on an edge");
  // A loop crossing itself exactly at a repeated vertex (an X at point 0).
  fails({{0, 0}, {1, 1}, {-1, 1}, {-1, -1}, {1, -1}}, {{0, 1, 3, 0, 2, 4}}, "crossing at a repeated vertex");
  // 3D: a zero normal.
  const std::vector<P3> p3 = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Loops loop = {{0, 1, 2}};
  EXPECT_FALSE(triangulate_polygon(p3, loop, {0, 0, 0}).is_ok());
  // Seen edge-on (normal in the polygon's plane) the projection is all collinear.
  auto edge_on = triangulate_polygon(p3, loop, {1, 1, 0});
  EXPECT_FALSE(edge_on.is_ok());
}

TEST(PolygonTriangulation, NearlyDegenerateProjectionStaysConsistent) {
  // A thin sliver of 3D points whose projection is almost collinear: every decision is exact
  // on the projected doubles, so the result is either a valid triangulation of them or an error.
  const std::uint64_t seed = 3;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> tiny(-1e-14, 1e-14);
  int ok = 0;
  for (int trial = 0; trial < 50; ++trial) {
    Polygon p;
    std::vector<P2> loop;
    for (int i = 0; i < 12; ++i) loop.push_back({double(i), (i % 3 == 0 ? 1e-13 : 0) + tiny(rng)});
    for (int i = 11; i >= 0; --i) loop.push_back({double(i) + 0.5, 1e-12 + tiny(rng)});
    p.add_loop(loop);
    auto result = triangulate_polygon_2d(p.points, p.loops);
    if (!result.is_ok()) continue;
    ++ok;
    // Only the exact properties: the area equality is meaningless at this scale.
    for (const auto& t : result.value()) EXPECT_GT(orientation_2d(p.points[t[0]], p.points[t[1]], p.points[t[2]]), 0);
    EXPECT_EQ(result.value().size(), p.vertex_count() - 2) << "seed " << seed << " trial " << trial;
  }
  std::printf("near-degenerate slivers: %d of 50 triangulated, the rest clean errors\n", ok);
}

TEST(PolygonTriangulation, WorkspaceGivesTheSameTrianglesAndErrors) {
  // One workspace reused over polygons of every size, with and without holes and forbidden
  // edges, in an order that makes its buffers shrink and grow: the same triangles in the same
  // order as a fresh call, and the same errors.
  const std::uint64_t seed = 11;
  std::mt19937_64 rng(seed);
  const ForbiddenEdge forbid = [](std::uint32_t a, std::uint32_t b) { return (a * 7 + b * 13) % 17 == 0; };
  PolygonWorkspace workspace;
  Triangles reused;
  for (int trial = 0; trial < 120; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(seed) + " trial " + std::to_string(trial));
    const std::size_t n = trial % 3 == 0 ? 400 : 3 + trial % 25;
    const Polygon p = random_polygon_with_holes(rng, n, trial % 4);
    const ForbiddenEdge& f = trial % 2 ? forbid : ForbiddenEdge{};
    auto fresh = triangulate_polygon_2d(p.points, p.loops, f);
    const format::Status status = triangulate_polygon_2d(p.points, p.loops, f, workspace, reused);
    ASSERT_EQ(fresh.is_ok(), status.is_ok());
    if (fresh.is_ok()) {
      EXPECT_EQ(fresh.value(), reused);
    } else {
      EXPECT_EQ(fresh.status().message(), status.message());
    }
  }
}

TEST(PolygonTriangulation, OrientationOfEqualPointsIsZero) {
  const P2 a{0.1, 0.3}, b{0.7, -2.5};
  EXPECT_EQ(orientation_2d(a, a, b), 0);
  EXPECT_EQ(orientation_2d(a, b, b), 0);
  EXPECT_EQ(orientation_2d(b, a, b), 0);
  EXPECT_EQ(orientation_2d(P2{0, 0}, P2{1, 0}, P2{0, 1}), 1);
  EXPECT_EQ(orientation_2d(P2{0, 0}, P2{0, 1}, P2{1, 0}), -1);
}

}  // namespace
}  // namespace gaussmesh::stream
