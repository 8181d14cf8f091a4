// Spherical segmentation (paper §6): g+1 connected segments covering every face once on the
// analytic shapes (sphere, rounded cube, thin and thick torus, genus 2) in random orientations
// and on the genus-0/1 fixtures; clean 2-convex cases need no fallback; refusals of open,
// split, mis-oriented and collapsed meshes; the smoothing cap is reported (the cow).
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "stream/core/mesh_adjacency.h"
#include "stream/analysis/segmentation.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using testing::ShapeOptions;

GaussSphere make_gauss(std::uint32_t frequency, std::uint64_t seed = kDefaultGaussSeed) {
  GaussSphereOptions o;
  o.frequency = frequency;
  o.rotation = gauss_rotation_from_seed(seed);
  return GaussSphere::create(o).value();
}

// Every face has a segment in range, the sizes add up, and each segment is edge-connected.
void expect_partition(const Mesh& mesh, const SegmentationResult& r, const std::string& what) {
  const std::size_t nf = mesh.triangles.size();
  ASSERT_EQ(r.face_segment.size(), nf) << what;
  std::vector<std::size_t> sizes(r.segment_count, 0);
  for (std::uint32_t s : r.face_segment) {
    ASSERT_LT(s, r.segment_count) << what;
    ++sizes[s];
  }
  EXPECT_EQ(sizes, r.segment_faces) << what;
  const MeshAdjacency adj = build_mesh_adjacency(mesh.view()).value();
  std::vector<std::uint8_t> seen(nf, 0);
  std::vector<std::uint32_t> stack;
  std::vector<int> components(r.segment_count, 0);
  for (std::uint32_t s = 0; s < nf; ++s) {
    if (seen[s]) continue;
    ++components[r.face_segment[s]];
    seen[s] = 1;
    stack.assign(1, s);
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = adj.edge_neighbor[3 * f + i];
        if (g == MeshAdjacency::kNoFace || seen[g] || r.face_segment[g] != r.face_segment[f]) continue;
        seen[g] = 1;
        stack.push_back(g);
      }
    }
  }
  for (std::size_t s = 0; s < r.segment_count; ++s) EXPECT_EQ(components[s], 1) << what << ": segment " << s;
}

struct Shape {
  std::string name;
  std::uint32_t genus;
  bool two_convex;  // tight: the paper's steps alone must give g+1 aggregates
  Mesh (*make)(const ShapeOptions&);
};

const std::vector<Shape>& shapes() {
  static const std::vector<Shape> s = {
      {"sphere", 0, true, [](const ShapeOptions& o) { return testing::make_sphere(o); }},
      {"rounded cube p=6", 0, true, [](const ShapeOptions& o) { return testing::make_rounded_cube(6, o); }},
      {"thin torus r/R=0.25", 1, true, [](const ShapeOptions& o) { return testing::make_torus(1, 0.25, o); }},
      {"thick torus r/R=0.7", 1, true, [](const ShapeOptions& o) { return testing::make_torus(1, 0.7, o); }},
      // Fused tori: concave waists, so not 2-convex until smoothed (often past the cap).
      {"genus 2", 2, false, [](const ShapeOptions& o) { return testing::make_genus2(o); }},
  };
  return s;
}

TEST(Segmentation, AnalyticShapesGiveGenusPlusOneConnectedSegmentsInEveryOrientation) {
  for (std::uint32_t frequency : {1u, 2u}) {
    const GaussSphere gauss = make_gauss(frequency);
    for (const Shape& shape : shapes()) {
      for (std::uint64_t seed = 11; seed < 15; ++seed) {
        ShapeOptions o;
        o.vertices = shape.genus == 2 ? 8000 : 5000;
        o.rotation = testing::random_rotation(seed);
        const Mesh mesh = shape.make(o);
        const std::string what = shape.name + ", G frequency " + std::to_string(frequency) +
                                 ", shape rotation seed " + std::to_string(seed);
        auto r = segment_mesh(mesh.view(), gauss, {});
        ASSERT_TRUE(r.is_ok()) << what << ": " << r.status().to_string();
        EXPECT_EQ(r->genus, shape.genus) << what;
        EXPECT_EQ(r->segment_count, shape.genus + 1) << what;
        expect_partition(mesh, *r, what);
        if (shape.two_convex) {
          // The paper's steps alone: no smoothing needed, greedy gives g+1 aggregates, each
          // holding every label at most once; tori have exactly two poles (the axis directions).
          EXPECT_EQ(r->smooth_iterations, 0u) << what;
          EXPECT_FALSE(r->smooth_cap_hit) << what;
          EXPECT_LE(r->max_preimages, shape.genus + 1) << what;
          EXPECT_EQ(r->greedy_aggregates, shape.genus + 1) << what;
          EXPECT_EQ(r->merges, 0u) << what;
          for (std::size_t d : r->duplicate_labels) EXPECT_EQ(d, 0u) << what;
          EXPECT_EQ(r->poles, shape.genus == 1 ? 2u : 0u) << what;
          if (shape.genus == 1) {
            EXPECT_GT(r->pole_faces, 0u) << what;
            // Outer and inner sheets are of comparable size: neither segment is a sliver.
            for (std::size_t n : r->segment_faces) EXPECT_GT(n, mesh.triangles.size() / 4) << what;
          }
        }
      }
    }
  }
}

TEST(Segmentation, Genus2ConvergesWithinTheCapAtFrequencyOne) {
  // At frequency 1 the default cap suffices for most orientations, and then no fallback merge
  // is needed: three aggregates straight from the greedy step.
  const GaussSphere gauss = make_gauss(1);
  int converged = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    ShapeOptions o;
    o.vertices = 8000;
    o.rotation = testing::random_rotation(seed);
    const Mesh mesh = testing::make_genus2(o);
    auto r = segment_mesh(mesh.view(), gauss, {});
    ASSERT_TRUE(r.is_ok()) << r.status().to_string();
    if (!r->smooth_cap_hit) {
      ++converged;
      EXPECT_GT(r->smooth_iterations, 0u) << "seed " << seed;
      EXPECT_LE(r->max_preimages, 3u) << "seed " << seed;
      EXPECT_EQ(r->merges, 0u) << "seed " << seed;
    }
  }
  EXPECT_GE(converged, 3);
}

TEST(Segmentation, FixturesGiveOneAndTwoSegments) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const GaussSphere gauss = make_gauss(1, seed);
    for (const auto& [name, genus] : {std::pair<const char*, std::uint32_t>{"real/cow.off", 0}, {"real/knot1.off", 1}}) {
      const Mesh mesh = load_mesh(testing::fixture(name)).value();
      auto r = segment_mesh(mesh.view(), gauss, {});
      const std::string what = std::string(name) + ", G seed " + std::to_string(seed);
      ASSERT_TRUE(r.is_ok()) << what << ": " << r.status().to_string();
      EXPECT_EQ(r->genus, genus) << what;
      EXPECT_EQ(r->segment_count, genus + 1) << what;
      expect_partition(mesh, *r, what);
    }
  }
}

TEST(Segmentation, TheSmoothingCapIsReported) {
  // The cow's concavities (legs, ears, belly) give Gaussian triangles several pre-images that
  // only smoothing removes.
  const Mesh mesh = load_mesh(testing::fixture("real/cow.off")).value();
  const GaussSphere gauss = make_gauss(1);
  SegmentationOptions capped;
  capped.max_smooth = 0;
  auto r0 = segment_mesh(mesh.view(), gauss, capped);
  ASSERT_TRUE(r0.is_ok()) << r0.status().to_string();
  EXPECT_TRUE(r0->smooth_cap_hit);
  EXPECT_EQ(r0->smooth_iterations, 0u);
  EXPECT_GT(r0->max_preimages, 1u);
  EXPECT_EQ(r0->segment_count, 1u);  // genus 0: merges always reach one segment
  EXPECT_GT(r0->merges, 0u);
  auto r = segment_mesh(mesh.view(), gauss, {});
  ASSERT_TRUE(r.is_ok()) << r.status().to_string();
  EXPECT_FALSE(r->smooth_cap_hit);
  EXPECT_GT(r->smooth_iterations, 0u);
  EXPECT_EQ(r->max_preimages, 1u);
  EXPECT_EQ(r->merges, 0u);
  EXPECT_EQ(r->segment_count, 1u);
  // Same input, same answer.
  auto again = segment_mesh(mesh.view(), gauss, {});
  ASSERT_TRUE(again.is_ok());
  EXPECT_EQ(again->face_segment, r->face_segment);
  EXPECT_EQ(again->face_label, r->face_label);
}

format::Code code_of(const Mesh& mesh) {
  auto r = segment_mesh(mesh.view(), make_gauss(1), {});
  return r.is_ok() ? format::Code::kOk : r.status().code();
}

TEST(Segmentation, RefusesWhatIsNotOneClosedOrientedManifold) {
  ShapeOptions o;
  o.vertices = 500;
  const Mesh sphere = testing::make_sphere(o);
  ASSERT_EQ(code_of(sphere), format::Code::kOk);

  EXPECT_EQ(code_of(Mesh{}), format::Code::kBadInput);

  Mesh open = sphere;
  open.triangles.pop_back();
  EXPECT_EQ(code_of(open), format::Code::kBadInput);

  Mesh flipped = sphere;
  std::swap(flipped.triangles[0].v[1], flipped.triangles[0].v[2]);
  EXPECT_EQ(code_of(flipped), format::Code::kBadInput);

  Mesh two = sphere;
  const auto offset = static_cast<std::uint32_t>(sphere.positions.size());
  for (const auto& p : sphere.positions) two.positions.push_back({p.x + 3, p.y, p.z});
  for (auto t : sphere.triangles) {
    for (auto& v : t.v) v += offset;
    two.triangles.push_back(t);
  }
  EXPECT_EQ(code_of(two), format::Code::kBadInput);

  Mesh collapsed = sphere;
  collapsed.triangles.push_back({{0, 0, 1}});
  EXPECT_EQ(code_of(collapsed), format::Code::kBadInput);

  SegmentationOptions backwards;
  backwards.min_smooth = 5;
  backwards.max_smooth = 4;
  auto r = segment_mesh(sphere.view(), make_gauss(1), backwards);
  ASSERT_FALSE(r.is_ok());
  EXPECT_EQ(r.status().code(), format::Code::kUsage);
}

}  // namespace
}  // namespace gaussmesh::stream
