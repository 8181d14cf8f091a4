// The first half of the quadric finish: every input face's plane quadric lands on the
// approximation vertex nearest to its corners, on the side it faces, and the fixed-point sums
// are the same bits whatever the order of the faces or their split into chunks.
#include "stream/finish/face_quadrics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "stream/finish/quadric_decimation.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using testing::make_sphere;
using testing::make_torus;
using testing::ShapeOptions;

bool same_bits(const std::vector<FixedQuadric>& a, const std::vector<FixedQuadric>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].q != b[i].q) return false;
  return true;
}

TEST(FaceQuadrics, SumsDoNotDependOnFaceOrderOrChunks) {
  const Mesh input = make_torus(1.0, 0.35, {.vertices = 6000, .noise = 0.002, .seed = 3});
  const Mesh coarse = make_torus(1.0, 0.35, {.vertices = 300});
  const FaceQuadrics quadrics(coarse.view());
  auto whole = quadrics.new_accumulator();
  quadrics.add_mesh(input.view(), whole);
  const auto& in_order = whole.sums;

  std::vector<std::size_t> order(input.triangles.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::mt19937 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  // Three "chunks", each summed on its own and added at the end, in another order.
  std::vector<FaceQuadrics::Accumulator> chunks(3, quadrics.new_accumulator());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const auto& t = input.triangles[order[k]];
    quadrics.add_face(input.positions[t.v[0]], input.positions[t.v[1]], input.positions[t.v[2]], chunks[k % 3]);
  }
  auto shuffled = quadrics.new_sums();
  for (int c : {2, 0, 1}) add_sums(shuffled, chunks[c].sums);
  EXPECT_TRUE(same_bits(in_order, shuffled));

  // And the sums are not trivially zero: every face's area is in some vertex's weight.
  double weight = 0;
  for (const auto& s : in_order) weight += s.to_double().weight;
  EXPECT_GT(weight, 0);
}

TEST(FaceQuadrics, EveryVertexOfTheInputItselfGetsZeroErrorAtItsPosition) {
  // Approximation = input: each face goes to its own corners (Garland & Heckbert's quadrics), so
  // every vertex lies on all its planes.
  const Mesh input = make_sphere({.vertices = 800});
  const FaceQuadrics quadrics(input.view());
  auto acc = quadrics.new_accumulator();
  quadrics.add_mesh(input.view(), acc);
  const auto& sums = acc.sums;
  double worst = 0;
  for (std::size_t v = 0; v < input.positions.size(); ++v) {
    const auto& p = input.positions[v];
    worst = std::max(worst, decimation_error(sums[v].to_double(), quadrics.frame().to_frame(p.x, p.y, p.z)));
  }
  EXPECT_LT(worst, 1e-5);
}

TEST(FaceQuadrics, TheTwoSidesOfAThinPlateKeepTheirOwnPlanes) {
  // Two parallel squares 1e-3 apart facing away from each other (a thin plate's top and
  // bottom), each as two triangles; the approximation is the same plate. Every face's quadric
  // goes to the vertices of its own side: those vertices have zero error, the others' planes
  // would put them 1e-3 off.
  Mesh plate;
  const float h = 0.0005f;
  plate.positions = {{0, 0, h}, {1, 0, h}, {1, 1, h}, {0, 1, h}, {0, 0, -h}, {1, 0, -h}, {1, 1, -h}, {0, 1, -h}};
  plate.triangles = {{{0, 1, 2}}, {{0, 2, 3}}, {{4, 6, 5}}, {{4, 7, 6}}};
  const FaceQuadrics quadrics(plate.view());
  auto acc = quadrics.new_accumulator();
  quadrics.add_mesh(plate.view(), acc);
  const auto& sums = acc.sums;
  for (std::size_t v = 0; v < plate.positions.size(); ++v) {
    const auto& p = plate.positions[v];
    const Quadric q = sums[v].to_double();
    ASSERT_GT(q.weight, 0) << v;
    EXPECT_LT(decimation_error(q, quadrics.frame().to_frame(p.x, p.y, p.z)), 1e-6) << v;
  }
}

}  // namespace
}  // namespace gaussmesh::stream
