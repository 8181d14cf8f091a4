// Tests for the tessellated Gaussian sphere (stream/core/gauss_sphere.h): counts, ids, adjacency
// tables, and exact point location checked with exact orientation predicates.
#include "stream/core/gauss_sphere.h"

#include <cmath>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "stream/core/exact_predicates.h"

namespace gaussmesh::stream {
namespace {

GaussSphere make(GaussBase base, std::uint32_t f, std::uint64_t seed = kDefaultGaussSeed) {
  GaussSphereOptions options;
  options.base = base;
  options.frequency = f;
  options.rotation = gauss_rotation_from_seed(seed);
  auto g = GaussSphere::create(options);
  EXPECT_TRUE(g.is_ok()) << g.status().to_string();
  return std::move(g).value();
}

// True when direction n is inside or on spherical triangle t (exact signs).
bool contains(const GaussSphere& g, std::uint32_t t, const Vec3d& n) {
  const auto& tv = g.triangle_vertices(t);
  for (int i = 0; i < 3; ++i)
    if (orientation_sign(g.vertex(tv[i]), g.vertex(tv[(i + 1) % 3]), n) < 0) return false;
  return true;
}

struct BaseCase {
  GaussBase base;
  std::size_t faces, vertices, edges;
};
const BaseCase kBases[] = {{GaussBase::kTetrahedron, 4, 4, 6},
                           {GaussBase::kOctahedron, 8, 6, 12},
                           {GaussBase::kIcosahedron, 20, 12, 30}};

TEST(GaussSphere, CountsFollowEulerForEveryBaseAndFrequency) {
  for (const BaseCase& bc : kBases) {
    for (std::uint32_t f : {1u, 2u, 3u, 4u, 7u, 16u}) {
      const GaussSphere g = make(bc.base, f);
      // |T| = F f², |V| = V + E (f-1) + F (f-1)(f-2)/2; icosa: 10 f² + 2.
      EXPECT_EQ(g.triangle_count(), bc.faces * f * f);
      EXPECT_EQ(g.vertex_count(), bc.vertices + bc.edges * (f - 1) + bc.faces * (f - 1) * (f - 2) / 2);
      EXPECT_EQ(static_cast<long>(g.vertex_count()) - static_cast<long>(3 * g.triangle_count() / 2) +
                    static_cast<long>(g.triangle_count()),
                2);
      if (bc.base == GaussBase::kIcosahedron) {
        EXPECT_EQ(g.vertex_count(), 10 * f * f + 2);
      }
    }
  }
}

TEST(GaussSphere, VerticesAreUnitAndDistinct) {
  const GaussSphere g = make(GaussBase::kIcosahedron, 5);
  std::set<std::tuple<long, long, long>> seen;
  for (std::uint32_t v = 0; v < g.vertex_count(); ++v) {
    const Vec3d& p = g.vertex(v);
    EXPECT_NEAR(dot(p, p), 1.0, 1e-12);
    seen.insert({std::lround(p.x * 1e6), std::lround(p.y * 1e6), std::lround(p.z * 1e6)});
  }
  EXPECT_EQ(seen.size(), g.vertex_count());
}

TEST(GaussSphere, TrianglesAreCounterClockwiseAndAdjacencyIsSymmetric) {
  for (const BaseCase& bc : kBases) {
    const GaussSphere g = make(bc.base, 4);
    for (std::uint32_t t = 0; t < g.triangle_count(); ++t) {
      const auto& tv = g.triangle_vertices(t);
      EXPECT_GT(orientation_sign(g.vertex(tv[0]), g.vertex(tv[1]), g.vertex(tv[2])), 0) << t;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t n = g.triangle_neighbors(t)[i];
        ASSERT_NE(n, GaussSphere::kNone);
        EXPECT_TRUE(g.are_edge_adjacent(n, t));
        // The neighbour holds the shared edge reversed.
        EXPECT_TRUE(g.triangle_has_vertex(n, tv[i]) && g.triangle_has_vertex(n, tv[(i + 1) % 3]));
      }
    }
  }
}

TEST(GaussSphere, VertexIncidenceIsCompleteAndCyclic) {
  const GaussSphere g = make(GaussBase::kIcosahedron, 4);
  std::size_t total = 0;
  for (std::uint32_t v = 0; v < g.vertex_count(); ++v) {
    const auto ts = g.vertex_triangles(v);
    total += ts.size();
    EXPECT_TRUE(ts.size() == 5 || ts.size() == 6) << v;  // icosa: 12 of valence 5
    std::set<std::uint32_t> unique(ts.begin(), ts.end());
    EXPECT_EQ(unique.size(), ts.size());
    for (std::size_t k = 0; k < ts.size(); ++k) {
      EXPECT_TRUE(g.triangle_has_vertex(ts[k], v));
      EXPECT_TRUE(g.are_edge_adjacent(ts[k], ts[(k + 1) % ts.size()]));
    }
  }
  EXPECT_EQ(total, 3 * g.triangle_count());
}

TEST(GaussSphere, EveryCellCentroidLocatesToItsCell) {
  for (const BaseCase& bc : kBases) {
    for (std::uint32_t f : {1u, 2u, 3u, 8u}) {
      const GaussSphere g = make(bc.base, f, 7);
      for (std::uint32_t t = 0; t < g.triangle_count(); ++t) EXPECT_EQ(g.locate(g.triangle_center(t)), t);
    }
  }
}

TEST(GaussSphere, RandomDirectionsLocateToATriangleThatHoldsThem) {
  const std::uint64_t seed = 20240611;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  for (const BaseCase& bc : kBases) {
    for (std::uint32_t f : {1u, 2u, 5u, 32u}) {
      const GaussSphere g = make(bc.base, f, 3);
      for (int i = 0; i < 20000; ++i) {
        const Vec3d n{normal(rng), normal(rng), normal(rng)};
        const std::uint32_t t = g.locate(n);
        ASSERT_LT(t, g.triangle_count());
        ASSERT_TRUE(contains(g, t, n)) << "seed " << seed << " base " << gauss_base_name(bc.base) << " f " << f;
      }
    }
  }
}

// locate() answers most directions from its fine table; it must give exactly what the full
// computation gives, on random directions of any length and on directions on and within
// 1e-16 .. 1e-6 of G's edges and vertices (where the table's cells fall back or split).
TEST(GaussSphere, LocateTableAgreesWithTheFullComputation) {
  const std::uint64_t seed = 20261123;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const BaseCase& bc : kBases) {
    for (std::uint32_t f : {1u, 3u, 8u, 16u, 32u}) {
      const GaussSphere g = make(bc.base, f, 11);
      if (f <= 16) {
        EXPECT_GT(g.locate_table_cells(), 0u);
      }
      auto check = [&](const Vec3d& n) {
        EXPECT_EQ(g.locate(n), g.locate_without_table(n))
            << "seed " << seed << " base " << gauss_base_name(bc.base) << " f " << f << " n " << n.x << " " << n.y
            << " " << n.z;
      };
      for (int i = 0; i < 20000; ++i) {
        const Vec3d n{normal(rng), normal(rng), normal(rng)};
        check(n);
        check(std::pow(10.0, 60 * unit(rng) - 30) * n);
      }
      for (std::uint32_t t = 0; t < g.triangle_count(); ++t) {
        const auto& tv = g.triangle_vertices(t);
        for (int e = 0; e < 3; ++e) {
          const Vec3d& a = g.vertex(tv[e]);
          const Vec3d& b = g.vertex(tv[(e + 1) % 3]);
          check(a);
          for (int k = 0; k < 4; ++k) {
            const double s = unit(rng);
            const Vec3d on = s * a + (1 - s) * b;
            check(on);
            const double eps = std::pow(10.0, -16 + 10 * unit(rng));
            check(on + eps * Vec3d{normal(rng), normal(rng), normal(rng)});
            check(a + eps * Vec3d{normal(rng), normal(rng), normal(rng)});
          }
        }
      }
    }
  }
}

// The batch locate (the sampler's labels) answers each float direction as locate() does, the
// zero vector (either sign) with for_zero; also with no table (f = 64), on G's vertices
// rounded to float, and on non-finite input.
TEST(GaussSphere, BatchLocateAgreesWithLocateAndTellsZeroApart) {
  const std::uint64_t seed = 20261124;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  constexpr std::uint32_t kForZero = 0xFFFFFFFFu;
  for (std::uint32_t f : {1u, 8u, 64u}) {
    const GaussSphere g = make(GaussBase::kIcosahedron, f, 7);
    std::vector<format::Vec3f> d = {{0, 0, 0}, {-0.0f, 0, -0.0f}, {1, 0, 0}, {0, -1, 0}, {1, 1, 1}, {1, -1, 0},
                                    {1e-30f, 0, 0}, {0, 0, 1e30f}, {INFINITY, 0, 0}, {NAN, 1, 0}};
    for (std::uint32_t v = 0; v < g.vertex_count(); ++v)
      d.push_back({float(g.vertex(v).x), float(g.vertex(v).y), float(g.vertex(v).z)});
    for (int i = 0; i < 20000; ++i) d.push_back({float(normal(rng)), float(normal(rng)), float(normal(rng))});
    std::vector<std::uint32_t> out(d.size());
    g.locate(d, out, kForZero);
    for (std::size_t i = 0; i < d.size(); ++i) {
      const Vec3d n{d[i].x, d[i].y, d[i].z};
      const bool is_zero = n.x == 0 && n.y == 0 && n.z == 0;
      EXPECT_EQ(out[i], is_zero ? kForZero : g.locate(n))
          << "seed " << seed << " f " << f << " n " << n.x << " " << n.y << " " << n.z;
    }
  }
}

TEST(GaussSphere, RotationIsReproducibleFromTheSeedAndChangesTheVertices) {
  const GaussSphere a = make(GaussBase::kIcosahedron, 2, 5);
  const GaussSphere b = make(GaussBase::kIcosahedron, 2, 5);
  const GaussSphere c = make(GaussBase::kIcosahedron, 2, 6);
  EXPECT_EQ(a.vertex(0).x, b.vertex(0).x);
  EXPECT_NE(a.vertex(0).x, c.vertex(0).x);
}

TEST(GaussSphere, RejectsBadFrequencyAndRotation) {
  GaussSphereOptions options;
  options.frequency = 0;
  EXPECT_EQ(GaussSphere::create(options).status().code(), format::Code::kUsage);
  options.frequency = kMaxGaussFrequency + 1;
  EXPECT_FALSE(GaussSphere::create(options).is_ok());
  options.frequency = 2;
  options.rotation = {0, 0, 0, 0};
  EXPECT_FALSE(GaussSphere::create(options).is_ok());
}

TEST(ExactPredicates, OrientationMatchesTheDeterminantAndIsExactOnCoplanarInput) {
  EXPECT_EQ(orientation_sign({1, 0, 0}, {0, 1, 0}, {0, 0, 1}), 1);
  EXPECT_EQ(orientation_sign({0, 1, 0}, {1, 0, 0}, {0, 0, 1}), -1);
  // c = a + b exactly: coplanar, though a naive double determinant can round away from zero.
  const Vec3d a{0.1, 0.2, 0.3}, b{1e-17, 0.7, 0.11};
  EXPECT_EQ(orientation_sign(a, b, Vec3d{0.2, 0.4, 0.6}), 0);  // 2a: coplanar
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Vec3d p{u(rng), u(rng), u(rng)}, q{u(rng), u(rng), u(rng)}, r{u(rng), u(rng), u(rng)};
    const double det = dot(cross(p, q), r);
    if (std::abs(det) > 1e-9) {
      EXPECT_EQ(orientation_sign(p, q, r), det > 0 ? 1 : -1) << "seed 11";
    }
  }
}

}  // namespace
}  // namespace gaussmesh::stream
