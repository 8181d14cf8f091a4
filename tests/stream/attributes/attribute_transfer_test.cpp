// The attribute transfer: an input vertex keeps its values, a point of a face gets them
// interpolated, a point off the surface gets those of the nearest surface point; normals kept,
// computed or left out; the same values whatever the threads.
#include <gtest/gtest.h>

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <atomic>
#include <cmath>
#include <limits>

#include "stream/analysis/mesh_distance.h"
#include "stream/attributes/attribute_transfer.h"
#include "tests/support/shapes.h"

namespace gaussmesh::stream {
namespace {

using format::Color;
using format::Vec2f;

// A linear function of position as colour (inside 0..1 on the torus) and texture coordinate.
Color colour_at(const Vec3f& p) { return {0.5f + 0.3f * p.x, 0.5f + 0.3f * p.y, 0.5f + 0.8f * p.z, 1.0f}; }
Vec2f uv_at(const Vec3f& p) { return {p.x - 2 * p.y, 3 * p.z}; }

Mesh coloured_torus(std::size_t vertices) {
  testing::ShapeOptions shape;
  shape.vertices = vertices;
  Mesh m = testing::make_torus(1.0, 0.4, shape);
  for (const Vec3f& p : m.positions) {
    m.colors.push_back(colour_at(p));
    m.texcoords.push_back(uv_at(p));
    const double r = std::hypot(p.x, p.y);
    const double nx = p.x - p.x / r, ny = p.y - p.y / r, l = std::sqrt(nx * nx + ny * ny + double(p.z) * p.z);
    m.normals.push_back({float(nx / l), float(ny / l), float(p.z / l)});
  }
  return m;
}

TEST(AttributeTransfer, InputVerticesKeepTheirValues) {
  const Mesh input = coloured_torus(4000);
  Mesh output;
  output.positions = input.positions;
  output.triangles = input.triangles;
  transfer_attributes(input.view(), output, NormalsMode::kKeep);
  ASSERT_EQ(output.colors.size(), input.positions.size());
  for (std::size_t v = 0; v < input.positions.size(); ++v) {
    EXPECT_NEAR(output.colors[v].r, input.colors[v].r, 1e-6) << v;
    EXPECT_NEAR(output.colors[v].g, input.colors[v].g, 1e-6) << v;
    EXPECT_NEAR(output.colors[v].b, input.colors[v].b, 1e-6) << v;
    EXPECT_NEAR(output.texcoords[v].u, input.texcoords[v].u, 1e-6) << v;
    EXPECT_NEAR(output.normals[v].x, input.normals[v].x, 1e-6) << v;
    EXPECT_NEAR(output.normals[v].z, input.normals[v].z, 1e-6) << v;
  }
}

// A point inside a face gets the linear function's value there (it is linear on the face); a
// point above the surface gets the value at its nearest surface point, so it is off the function
// by at most the gradient times its distance.
TEST(AttributeTransfer, PointsOnAndOffTheSurfaceGetTheSurfacesValues) {
  const Mesh input = coloured_torus(20000);
  Mesh output;
  for (std::size_t f = 0; f < input.triangles.size(); f += 7) {
    const auto& t = input.triangles[f].v;
    const Vec3f &a = input.positions[t[0]], &b = input.positions[t[1]], &c = input.positions[t[2]];
    const float w[3] = {0.2f, 0.3f, 0.5f};
    output.positions.push_back({w[0] * a.x + w[1] * b.x + w[2] * c.x, w[0] * a.y + w[1] * b.y + w[2] * c.y,
                                w[0] * a.z + w[1] * b.z + w[2] * c.z});
    const Vec3f& p = output.positions.back();
    const float lift = (f % 2 == 0) ? 0.0f : 0.01f;  // every other point off the surface
    const double r = std::hypot(p.x, p.y);
    output.positions.push_back({float(p.x + lift * p.x / r), float(p.y + lift * p.y / r), p.z + lift * (p.z > 0 ? 1 : -1)});
  }
  transfer_attributes(input.view(), output, NormalsMode::kNone);
  EXPECT_TRUE(output.normals.empty());
  const TriangleTree tree(input.view());
  double worst_on = 0, worst_off_excess = 0;
  std::size_t on = 0, off = 0;
  for (std::size_t v = 0; v < output.positions.size(); ++v) {
    const Vec3f& p = output.positions[v];
    const Color want = colour_at(p);
    const double error = std::max({std::abs(output.colors[v].r - want.r), std::abs(output.colors[v].g - want.g),
                                   std::abs(output.colors[v].b - want.b)});
    const double distance = std::sqrt(tree.nearest_distance_squared({p.x, p.y, p.z}));
    if (v % 2 == 0 && distance < 1e-6) worst_on = std::max(worst_on, error), ++on;
    if (distance > 1e-3) ++off;
    worst_off_excess = std::max(worst_off_excess, error - 0.8 * distance);  // 0.8: the largest gradient
  }
  EXPECT_EQ(on, output.positions.size() / 2);
  EXPECT_GT(off, output.positions.size() / 5);
  EXPECT_LT(worst_on, 1e-5);
  EXPECT_LT(worst_off_excess, 1e-5);
}

TEST(AttributeTransfer, NormalsAreKeptComputedOrLeftOut) {
  Mesh input = coloured_torus(6000);
  Mesh output;
  output.positions = input.positions;
  output.triangles = input.triangles;
  transfer_attributes(input.view(), output, NormalsMode::kCompute);
  ASSERT_EQ(output.normals.size(), input.positions.size());
  double worst = 1;
  for (std::size_t v = 0; v < input.positions.size(); ++v) {
    const Vec3f &n = output.normals[v], &m = input.normals[v];
    EXPECT_NEAR(n.x * n.x + n.y * n.y + n.z * n.z, 1.0, 1e-5);
    worst = std::min(worst, double(n.x * m.x + n.y * m.y + n.z * m.z));
  }
  EXPECT_GT(worst, std::cos(10 * std::acos(-1.0) / 180));  // computed from faces: within 10° of the true normal
  transfer_attributes(input.view(), output, NormalsMode::kNone);
  EXPECT_TRUE(output.normals.empty());
  EXPECT_EQ(output.colors.size(), input.positions.size());
  input.normals.clear();
  transfer_attributes(input.view(), output, NormalsMode::kKeep);
  EXPECT_TRUE(output.normals.empty());  // none to keep
}

TEST(AttributeTransfer, TheSameValuesWhateverTheThreads) {
  const Mesh input = coloured_torus(8000);
  testing::ShapeOptions shape;
  shape.vertices = 3000;
  Mesh one = testing::make_torus(1.0, 0.41, shape);  // a different surface near the input
  Mesh two = one;
  tbb::task_arena(1).execute([&] { transfer_attributes(input.view(), one, NormalsMode::kKeep); });
  tbb::task_arena(2).execute([&] { transfer_attributes(input.view(), two, NormalsMode::kKeep); });
  EXPECT_EQ(one.colors, two.colors);
  EXPECT_EQ(one.normals, two.normals);
  EXPECT_EQ(one.texcoords, two.texcoords);
}

// The streamed form: the input's vertices in batches of any size give each output vertex the
// nearest input vertex's values (an input vertex its own, exactly), the first in input order on
// a tie, whatever the batches.
TEST(AttributeTransfer, StreamedVerticesGiveTheNearestVertexsValues) {
  const Mesh input = coloured_torus(6000);
  std::vector<format::VertexAttributes> values(input.positions.size());
  for (std::size_t v = 0; v < values.size(); ++v) {
    values[v].color = input.colors[v];
    values[v].normal = input.normals[v];
    values[v].texcoord = input.texcoords[v];
  }
  auto pass_in = [&](std::size_t batch) {
    return [&, batch](const VertexBatchFn& fn) {
      for (std::size_t i = 0; i < input.positions.size(); i += batch) {
        const std::size_t n = std::min(batch, input.positions.size() - i);
        GM_RETURN_IF_ERROR(fn(std::span(input.positions).subspan(i, n), std::span<const format::VertexAttributes>(values).subspan(i, n)));
      }
      return format::Status();
    };
  };
  testing::ShapeOptions shape;
  shape.vertices = 2000;
  Mesh output = testing::make_torus(1.0, 0.41, shape);  // off the input's vertices
  for (std::size_t v = 0; v < 50; ++v) output.positions[v] = input.positions[7 * v];  // and on some
  Mesh other = output;
  ASSERT_TRUE(transfer_nearest_vertex(pass_in(7), {true, true, true}, output, NormalsMode::kKeep).is_ok());
  ASSERT_TRUE(transfer_nearest_vertex(pass_in(100000), {true, true, true}, other, NormalsMode::kKeep).is_ok());
  EXPECT_EQ(output.colors, other.colors);
  EXPECT_EQ(output.normals, other.normals);
  for (std::size_t v = 0; v < output.positions.size(); ++v) {
    std::size_t nearest = 0;
    double best = 1e30;
    for (std::size_t w = 0; w < input.positions.size(); ++w) {
      const Vec3f &a = output.positions[v], &b = input.positions[w];
      const double d = double(a.x - b.x) * (a.x - b.x) + double(a.y - b.y) * (a.y - b.y) + double(a.z - b.z) * (a.z - b.z);
      if (d < best) best = d, nearest = w;
    }
    EXPECT_EQ(output.colors[v], input.colors[nearest]) << v;
    EXPECT_EQ(output.texcoords[v], input.texcoords[nearest]) << v;
  }
  ASSERT_TRUE(transfer_nearest_vertex(pass_in(64), {false, true, false}, other, NormalsMode::kNone).is_ok());
  EXPECT_TRUE(other.normals.empty());
  EXPECT_TRUE(other.texcoords.empty());
  EXPECT_EQ(other.colors, output.colors);
}


// The input as an out-of-core run streams it: its triangles in batches (several at once, from
// tbb's threads, in a shuffled order) with their input index, and its vertices in input order.
struct StreamedInput {
  const Mesh& input;
  std::vector<format::VertexAttributes> values;
  std::size_t batch = 37;

  explicit StreamedInput(const Mesh& m) : input(m), values(m.positions.size()) {
    for (std::size_t v = 0; v < values.size(); ++v) {
      if (!m.colors.empty()) values[v].color = m.colors[v];
      if (!m.normals.empty()) values[v].normal = m.normals[v];
      if (!m.texcoords.empty()) values[v].texcoord = m.texcoords[v];
    }
  }
  TrianglePassFn triangles() const {
    return [this](const TriangleBatchFn& fn) {
      std::vector<IndexedTriangle> all;
      for (std::size_t f = 0; f < input.triangles.size(); ++f) {
        const auto& t = input.triangles[f].v;
        all.push_back({{input.positions[t[0]], input.positions[t[1]], input.positions[t[2]]}, f});
      }
      for (std::size_t i = 0; i < all.size(); ++i) std::swap(all[i], all[(i * 7919) % all.size()]);
      std::atomic<bool> failed{false};
      tbb::parallel_for(std::size_t{0}, (all.size() + batch - 1) / batch, [&](std::size_t b) {
        const std::size_t first = b * batch, n = std::min(batch, all.size() - first);
        if (!fn(std::span<const IndexedTriangle>(all).subspan(first, n)).is_ok()) failed = true;
      });
      return failed ? format::Status::error(format::Code::kProcessing, "test", "batch") : format::Status();
    };
  }
  VertexPassFn vertices() const {
    return [this](const VertexBatchFn& fn) {
      for (std::size_t i = 0; i < input.positions.size(); i += batch) {
        const std::size_t n = std::min(batch, input.positions.size() - i);
        GM_RETURN_IF_ERROR(fn(std::span(input.positions).subspan(i, n), std::span<const format::VertexAttributes>(values).subspan(i, n)));
      }
      return format::Status();
    };
  }
};

// Streamed triangles and vertices give the values the held input gives, bit for bit: points off
// the input's vertices (a nearby torus) and on some of them, with 1 and 2 threads.
TEST(AttributeTransfer, StreamedTrianglesGiveTheHeldInputsValues) {
  const Mesh input = coloured_torus(6000);
  testing::ShapeOptions shape;
  shape.vertices = 2500;
  Mesh held = testing::make_torus(1.0, 0.41, shape);
  for (std::size_t v = 0; v < 60; ++v) held.positions[v] = input.positions[13 * v];
  transfer_attributes(input.view(), held, NormalsMode::kKeep);
  const StreamedInput streamed(input);
  for (int threads : {1, 2}) {
    format::Result<std::vector<format::VertexAttributes>> values = format::Status();
    tbb::task_arena(threads).execute([&] {
      values = surface_values(streamed.triangles(), streamed.vertices(), {true, true, true}, held.positions,
                              surface_area(held.positions, held.triangles));
    });
    ASSERT_TRUE(values.is_ok()) << values.status().message();
    ASSERT_EQ(values->size(), held.positions.size());
    for (std::size_t v = 0; v < held.positions.size(); ++v) {
      EXPECT_EQ((*values)[v].color, held.colors[v]) << v;
      EXPECT_EQ((*values)[v].normal, held.normals[v]) << v;
      EXPECT_EQ((*values)[v].texcoord, held.texcoords[v]) << v;
    }
  }
  for (std::size_t v = 0; v < 60; ++v) EXPECT_EQ(held.colors[v], input.colors[13 * v]) << v;
}

// Two input vertices at one place: a corner there takes the first one's values (input order),
// and a triangle whose corner is at no input vertex is an error, not a guess.
TEST(AttributeTransfer, StreamedCornersTakeTheFirstVertexAtTheirPlace) {
  Mesh input;
  input.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-0.0f, 0, 0}};
  input.triangles = {{{0, 1, 2}}};
  input.colors = {{0.25f, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {1, 1, 1, 1}};
  StreamedInput streamed(input);
  const std::vector<Vec3f> at = {{0, 0, 0.5f}, {0.5f, 0.5f, 0}};
  auto values = surface_values(streamed.triangles(), streamed.vertices(), {false, true, false}, at, 1.0);
  ASSERT_TRUE(values.is_ok()) << values.status().message();
  EXPECT_EQ((*values)[0].color, (Color{0.25f, 0, 0, 1}));  // above corner 0: vertex 0's, not vertex 3's
  EXPECT_FLOAT_EQ((*values)[1].color.g, 0.5f);
  EXPECT_FLOAT_EQ((*values)[1].color.b, 0.5f);
  input.positions[1].x = 2;  // the triangle's corner no longer at an input vertex's place
  const TrianglePassFn moved = [&](const TriangleBatchFn& fn) {
    const IndexedTriangle t{{Vec3f{0, 0, 0}, Vec3f{1, 0, 0}, Vec3f{0, 1, 0}}, 0};
    return fn(std::span<const IndexedTriangle>(&t, 1));
  };
  auto missing = surface_values(moved, streamed.vertices(), {false, true, false}, at, 1.0);
  ASSERT_FALSE(missing.is_ok());
  EXPECT_EQ(missing.status().code(), format::Code::kProcessing);
}


// Vertices far from the input (a few, and more than the last round at any distance takes) get
// their nearest triangle's values as a search over every triangle finds it: the rounds' radius
// does not change the answer, held or streamed.
TEST(AttributeTransfer, VerticesFarFromTheInputGetTheirNearestTrianglesValues) {
  const Mesh input = coloured_torus(3000);
  const StreamedInput streamed(input);
  for (std::size_t far : {1, 3, 20}) {
    SCOPED_TRACE(far);
    Mesh output;
    for (std::size_t v = 0; v < 200; ++v) output.positions.push_back(input.positions[5 * v]);
    for (std::size_t k = 0; k < far; ++k) output.positions.push_back({3.0f + 0.7f * k, -2.0f + 0.3f * k, 1.5f - 0.2f * k});
    output.triangles = {{{0, 1, 2}}};
    transfer_attributes(input.view(), output, NormalsMode::kKeep);
    auto values = surface_values(streamed.triangles(), streamed.vertices(), {true, true, true}, output.positions,
                                 surface_area(output.positions, output.triangles));
    ASSERT_TRUE(values.is_ok()) << values.status().message();
    for (std::size_t v = 0; v < output.positions.size(); ++v) {
      const Vec3d p = to_d(output.positions[v]);
      std::size_t nearest = 0;
      float best = std::numeric_limits<float>::infinity();
      for (std::size_t f = 0; f < input.triangles.size(); ++f) {
        const auto& t = input.triangles[f].v;
        const float d = float(point_triangle_distance_squared(p, to_d(input.positions[t[0]]), to_d(input.positions[t[1]]),
                                                              to_d(input.positions[t[2]])));
        if (d < best) best = d, nearest = f;
      }
      const format::VertexAttributes want = values_at(input.view(), input.triangles[nearest], output.positions[v], {true, true, true});
      EXPECT_EQ(output.colors[v], want.color) << v;
      EXPECT_EQ((*values)[v].color, want.color) << v;
      EXPECT_EQ((*values)[v].texcoord, want.texcoord) << v;
    }
  }
}

}  // namespace
}  // namespace gaussmesh::stream
