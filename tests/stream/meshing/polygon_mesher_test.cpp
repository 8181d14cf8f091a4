// Tests of the polygon-first mesher fed from records (mesh_patch_loops): positions in memory or
// from a VertexPositionSource give the same mesh, and the source is read in batches; loops in
// memory or from a LoopVertexSource give the same mesh, and the source's errors end the run.
#include "stream/meshing/polygon_mesher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace gaussmesh::stream {
namespace {

// The octahedron, one patch per face: every vertex has feature degree 4 and is a sample, so
// each patch is its own triangle and phase 2 removes nothing.
PolygonGraphInput octahedron_graph() {
  PolygonGraphInput g;
  g.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const std::vector<std::array<std::uint32_t, 3>> faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                           {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  g.patches = faces.size();
  for (std::uint32_t p = 0; p < faces.size(); ++p) {
    g.loops.push_back({p, {faces[p][0], faces[p][1], faces[p][2]}, {}});
    const auto& a = g.positions[faces[p][0]];
    const auto& b = g.positions[faces[p][1]];
    const auto& c = g.positions[faces[p][2]];
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    g.patch_area.push_back({uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx});
    g.plane_normal.push_back({float(g.patch_area.back()[0]), float(g.patch_area.back()[1]), float(g.patch_area.back()[2])});
  }
  g.degree.assign(g.positions.size(), 4);
  g.role.assign(g.positions.size(), VertexRole::kSample);
  g.interior_samples.assign(g.patches, {});
  g.patch_has_faces.assign(g.patches, 1);
  return g;
}

// Serves positions from a copy and records how it was asked.
class RecordingSource final : public VertexPositionSource {
 public:
  explicit RecordingSource(std::vector<format::Vec3f> positions) : positions_(std::move(positions)) {}
  format::Vec3f position(std::uint32_t v) override {
    ++single_reads;
    return v < positions_.size() ? positions_[v] : format::Vec3f{};
  }
  void positions(std::span<const std::uint32_t> ids, std::span<format::Vec3f> out) override {
    batches.emplace_back(ids.begin(), ids.end());
    for (std::size_t i = 0; i < ids.size(); ++i) out[i] = positions_[ids[i]];
  }
  format::Status status() const override { return {}; }

  std::size_t single_reads = 0;
  std::vector<std::vector<std::uint32_t>> batches;

 private:
  std::vector<format::Vec3f> positions_;
};

// The same triangles, vertex for vertex, and the same birth indices.
void expect_same_mesh(const PolygonMesherResult& a, const PolygonMesherResult& b) {
  ASSERT_EQ(a.mesh.mesh.triangles.size(), b.mesh.mesh.triangles.size());
  for (std::size_t t = 0; t < a.mesh.mesh.triangles.size(); ++t) {
    for (int i = 0; i < 3; ++i) EXPECT_EQ(a.mesh.mesh.triangles[t].v[i], b.mesh.mesh.triangles[t].v[i]) << "triangle " << t;
  }
  EXPECT_EQ(a.mesh.birth, b.mesh.birth);
}

TEST(PolygonMesher, PositionSourceGivesTheSameMeshAndIsReadInAscendingBatches) {
  auto in_memory = mesh_patch_loops(octahedron_graph());
  ASSERT_TRUE(in_memory.is_ok()) << in_memory.status().to_string();
  EXPECT_EQ(in_memory->mesh.mesh.triangles.size(), 8u);

  PolygonGraphInput g = octahedron_graph();
  auto source = std::make_shared<RecordingSource>(g.positions);
  g.vertex_count = g.positions.size();
  g.positions.clear();
  g.position_source = source;
  auto from_source = mesh_patch_loops(std::move(g));
  ASSERT_TRUE(from_source.is_ok()) << from_source.status().to_string();
  expect_same_mesh(*in_memory, *from_source);
  EXPECT_EQ(source->single_reads, 0u);
  ASSERT_FALSE(source->batches.empty());
  std::vector<std::uint32_t> all;
  for (const auto& batch : source->batches) {
    EXPECT_TRUE(std::is_sorted(batch.begin(), batch.end()));
    EXPECT_EQ(std::adjacent_find(batch.begin(), batch.end()), batch.end());
    all.insert(all.end(), batch.begin(), batch.end());
  }
  std::sort(all.begin(), all.end());
  EXPECT_EQ(std::adjacent_find(all.begin(), all.end()), all.end()) << "a vertex was read twice";
  EXPECT_EQ(all.size(), 6u);
}

// Serves loop vertices from a copy of a graph's loops (as the loop stitch's file), and can be
// told to fail from some read on.
class MemoryLoops final : public LoopVertexSource {
 public:
  bool read(std::uint64_t first, std::span<std::uint32_t> out) override {
    ++reads;
    if (reads > fail_after || first + out.size() > entries.size()) {
      failed = format::Status::error(format::Code::kOutput, "loops.bin", "cannot read");
      return false;
    }
    std::copy_n(entries.begin() + static_cast<std::ptrdiff_t>(first), out.size(), out.begin());
    return true;
  }
  format::Status status() const override { return failed; }

  std::vector<std::uint32_t> entries;
  std::size_t reads = 0, fail_after = SIZE_MAX;
  format::Status failed;
};

// g with its loops moved into a MemoryLoops source.
std::shared_ptr<MemoryLoops> move_loops_to_source(PolygonGraphInput& g) {
  auto source = std::make_shared<MemoryLoops>();
  g.loop_offset = {0};
  for (const PatchLoop& l : g.loops) {
    g.loop_patch.push_back(l.patch);
    source->entries.insert(source->entries.end(), l.vertices.begin(), l.vertices.end());
    g.loop_offset.push_back(source->entries.size());
  }
  g.loops.clear();
  g.loop_source = source;
  return source;
}

TEST(PolygonMesher, LoopSourceGivesTheSameMeshAndItsErrorsEndTheRun) {
  auto in_memory = mesh_patch_loops(octahedron_graph());
  ASSERT_TRUE(in_memory.is_ok()) << in_memory.status().to_string();

  PolygonGraphInput g = octahedron_graph();
  auto source = move_loops_to_source(g);
  auto from_source = mesh_patch_loops(std::move(g));
  ASSERT_TRUE(from_source.is_ok()) << from_source.status().to_string();
  expect_same_mesh(*in_memory, *from_source);
  EXPECT_EQ(in_memory->mesh.graph.chains, from_source->mesh.graph.chains);
  EXPECT_GE(source->reads, 16u);  // every loop for the guards, and again for the round

  // A read that fails, in the guards' pass or in a round, ends the run with the source's error.
  for (std::size_t fail_after : {3u, 10u}) {
    PolygonGraphInput f = octahedron_graph();
    move_loops_to_source(f)->fail_after = fail_after;
    auto failed = mesh_patch_loops(std::move(f));
    ASSERT_FALSE(failed.is_ok()) << "failing from read " << fail_after;
    EXPECT_EQ(failed.status().code(), format::Code::kOutput);
    EXPECT_NE(failed.status().to_string().find("loops.bin"), std::string::npos) << failed.status().to_string();
  }
  // A vertex out of range, and loops out of patch order, are refused.
  PolygonGraphInput bad = octahedron_graph();
  move_loops_to_source(bad)->entries[4] = 6;
  auto out_of_range = mesh_patch_loops(std::move(bad));
  ASSERT_FALSE(out_of_range.is_ok());
  EXPECT_EQ(out_of_range.status().code(), format::Code::kProcessing);
  PolygonGraphInput unordered = octahedron_graph();
  move_loops_to_source(unordered);
  std::swap(unordered.loop_patch[0], unordered.loop_patch[1]);
  EXPECT_FALSE(mesh_patch_loops(std::move(unordered)).is_ok());
}

}  // namespace
}  // namespace gaussmesh::stream
