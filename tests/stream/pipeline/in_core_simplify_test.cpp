// The in-core simplification job on the real fixtures and on analytic shapes: topology kept,
// no degenerate or duplicate faces, samples kept, bounded error (docs/design.md, paper Fig. 18).
#include "stream/pipeline/in_core_simplify.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <set>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/mesh_topology.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

size_t duplicate_faces(const Mesh& m) {
  std::set<std::array<format::VertexIndex, 3>> seen;
  size_t duplicates = 0;
  for (const auto& t : m.triangles) {
    std::array<format::VertexIndex, 3> key{t.v[0], t.v[1], t.v[2]};
    std::sort(key.begin(), key.end());
    if (!seen.insert(key).second) ++duplicates;
  }
  return duplicates;
}

struct Checked {
  MeshTopology in, out;
  double hausdorff_pct = 0, rms_pct = 0;
};

Checked simplify_and_check(const Mesh& input, const SimplifyOptions& options, const std::string& name) {
  Checked c;
  auto in = compute_topology(input.view());
  EXPECT_TRUE(in.is_ok());
  c.in = *in;
  auto result = simplify_mesh(input.view(), options);
  EXPECT_TRUE(result.is_ok()) << name << ": " << result.status().to_string();
  if (!result.is_ok()) return c;
  const Mesh& out = result->mesh;
  auto topo = compute_topology(out.view());
  EXPECT_TRUE(topo.is_ok());
  c.out = *topo;
  EXPECT_GT(out.triangles.size(), 0u) << name;
  EXPECT_LT(out.triangles.size(), input.triangles.size()) << name;
  EXPECT_EQ(c.out.degenerate_faces, 0u) << name;
  EXPECT_EQ(c.out.zero_area_faces, 0u) << name;
  EXPECT_EQ(duplicate_faces(out), 0u) << name;
  EXPECT_EQ(c.out.unreferenced_vertices, 0u) << name;
  if (c.in.is_manifold() && c.in.genus) {
    // Holes survive (paper Fig. 19): every boundary loop of the input is still there.
    EXPECT_EQ(c.out.boundary_loops, c.in.boundary_loops) << name;
  }
  if (c.in.is_manifold() && c.in.is_closed() && c.in.genus) {
    EXPECT_TRUE(c.out.is_manifold()) << name;
    EXPECT_TRUE(c.out.is_closed()) << name;
    EXPECT_EQ(c.out.euler_characteristic, c.in.euler_characteristic) << name;
    EXPECT_EQ(c.out.genus, c.in.genus) << name;
  }
  // Every output vertex is an input vertex, unmoved; every sample survives (per-patch mesher).
  EXPECT_EQ(result->birth.size(), out.positions.size());
  if (result->birth.size() != out.positions.size()) return c;
  for (size_t i = 0; i < out.positions.size(); ++i) {
    EXPECT_EQ(out.positions[i], input.positions[result->birth[i]]) << name;
  }
  if (options.mesher == MesherKind::kPatch) {
    EXPECT_GE(out.positions.size(), result->samples) << name;
    // The polygon-first mesher built it (the collapse mesher is only a safety net).
    EXPECT_FALSE(result->mesher_fallback) << name << ": " << result->mesher_fallback_reason;
  }
  DistanceOptions distance_options;
  distance_options.samples = 100000;
  auto distance = mesh_distance(input.view(), out.view(), distance_options);
  EXPECT_TRUE(distance.is_ok()) << name;
  if (distance.is_ok()) {
    c.hausdorff_pct = distance->hausdorff_pct();
    c.rms_pct = distance->rms_pct();
  }
  return c;
}

class FixtureSimplify : public ::testing::TestWithParam<std::string> {};

TEST_P(FixtureSimplify, KeepsTopologyAndErrorBoundOverEightOrientations) {
  auto mesh = load_mesh(testing::fixture("real/" + GetParam()));
  ASSERT_TRUE(mesh.is_ok()) << mesh.status().to_string();
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    SimplifyOptions options;
    options.spheres[0].frequency = 4;
    options.spheres[0].rotation = gauss_rotation_from_seed(seed);
    Checked c = simplify_and_check(*mesh, options, GetParam() + " seed " + std::to_string(seed));
    EXPECT_LE(c.hausdorff_pct, 8.0) << GetParam() << " seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Real, FixtureSimplify,
                         ::testing::Values("cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off",
                                           "mushroom.off", "bunny-lowres.ply"),
                         [](const auto& info) {
                           std::string name = info.param.substr(0, info.param.find('.'));
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

TEST(Simplify, AnalyticShapesKeepGenus) {
  testing::ShapeOptions shape;
  shape.vertices = 4000;
  SimplifyOptions options;
  options.spheres[0].frequency = 3;
  simplify_and_check(testing::make_sphere(shape), options, "sphere");
  simplify_and_check(testing::make_torus(1.0, 0.3, shape), options, "torus");
  simplify_and_check(testing::make_genus2(shape), options, "genus2");
}

TEST(Simplify, VoronoiMesherProducesAnApproximation) {
  auto mesh = load_mesh(testing::fixture("real/cow.off"));
  ASSERT_TRUE(mesh.is_ok());
  SimplifyOptions options;
  options.mesher = MesherKind::kVoronoi;
  options.spheres[0].frequency = 4;
  auto result = simplify_mesh(mesh->view(), options);
  ASSERT_TRUE(result.is_ok()) << result.status().to_string();
  EXPECT_GT(result->mesh.triangles.size(), result->samples / 2);
  EXPECT_LE(result->mesh.positions.size(), result->samples);
}

TEST(Simplify, MoreOrientationsNeverGiveMoreSamples) {
  auto mesh = load_mesh(testing::fixture("real/fandisk.off"));
  ASSERT_TRUE(mesh.is_ok());
  SimplifyOptions one, eight;
  for (std::uint64_t k = 1; k < 8; ++k) {
    GaussSphereOptions sphere;
    sphere.rotation = gauss_rotation_from_seed(kDefaultGaussSeed + k);
    eight.spheres.push_back(sphere);
  }
  auto a = simplify_mesh(mesh->view(), one);
  auto b = simplify_mesh(mesh->view(), eight);
  ASSERT_TRUE(a.is_ok() && b.is_ok());
  ASSERT_EQ(b->samples_per_orientation.size(), 8u);
  EXPECT_EQ(b->samples_per_orientation[0], a->samples);
  EXPECT_EQ(b->samples, *std::min_element(b->samples_per_orientation.begin(), b->samples_per_orientation.end()));
}

}  // namespace
}  // namespace gaussmesh::stream
