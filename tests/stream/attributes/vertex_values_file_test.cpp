// The attributes of an output too large to hold: its values found in runs of vertices are those of
// one search over them all, whatever the run's length (vertices far from the input too, which a
// run leaves to a search of its own) and whether a run reads every frame of the input or those
// near it; the file gives back what was appended,
// from the first again after a rewind, and refuses to read past its end.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <functional>
#include <vector>

#include "stream/attributes/vertex_values_file.h"
#include "stream/core/process_memory.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

// A mesh in memory handed out in batches of `batch` vertices or faces, as an output's parts are.
class TestParts final : public format::MeshParts {
 public:
  TestParts(const Mesh& mesh, std::size_t batch) : mesh_(mesh), batch_(batch) {}
  std::uint64_t vertex_count() const override { return mesh_.positions.size(); }
  std::uint64_t face_count() const override { return mesh_.triangles.size(); }
  format::Status vertices(const std::function<format::Status(std::span<const Vec3f>)>& fn) override {
    for (std::size_t i = 0; i < mesh_.positions.size(); i += batch_)
      GM_RETURN_IF_ERROR(fn(std::span(mesh_.positions).subspan(i, std::min(batch_, mesh_.positions.size() - i))));
    return {};
  }
  format::Status faces(const std::function<format::Status(std::span<const Triangle>)>& fn) override {
    for (std::size_t i = 0; i < mesh_.triangles.size(); i += batch_)
      GM_RETURN_IF_ERROR(fn(std::span(mesh_.triangles).subspan(i, std::min(batch_, mesh_.triangles.size() - i))));
    return {};
  }

 private:
  const Mesh& mesh_;
  std::size_t batch_;
};

std::vector<format::VertexAttributes> read_all(VertexValuesFile& file) {
  std::vector<format::VertexAttributes> out(file.count());
  EXPECT_TRUE(file.rewind().is_ok());
  const format::Status read = file.read(out);
  EXPECT_TRUE(read.is_ok()) << read.to_string();
  return out;
}

bool same(const std::vector<format::VertexAttributes>& a, const std::vector<format::VertexAttributes>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(format::VertexAttributes)) == 0;
}

TEST(VertexValuesFile, RunsOfAnyLengthGiveTheValuesOfOneSearch) {
  testing::ShapeOptions shape;
  shape.vertices = 6000;
  const Mesh input = testing::make_torus(1.0, 0.4, shape);
  std::vector<format::VertexAttributes> values(input.positions.size());
  for (std::size_t v = 0; v < values.size(); ++v) {
    const Vec3f& p = input.positions[v];
    values[v].color = {0.5f + 0.3f * p.x, 0.5f + 0.3f * p.y, 0.5f + 0.8f * p.z, 1.0f};
    values[v].texcoord = {p.x, p.z};
    values[v].normal = {p.x, p.y, p.z};
  }
  // The input in frames of 101 vertices, as the spill gives it: all of them, or those whose box
  // meets a given one.
  std::size_t skipped = 0;
  const auto frames = [&](const PositionBox* near, const VertexBatchFn& fn) {
    for (std::size_t i = 0; i < input.positions.size(); i += 101) {
      const std::size_t n = std::min<std::size_t>(101, input.positions.size() - i);
      PositionBox box;
      for (std::size_t k = i; k < i + n; ++k) box.add(input.positions[k]);
      if (near && !box.meets(*near)) {
        ++skipped;
        continue;
      }
      GM_RETURN_IF_ERROR(fn(std::span(input.positions).subspan(i, n), std::span<const format::VertexAttributes>(values).subspan(i, n)));
    }
    return format::Status();
  };
  const VertexPassFn pass = [&](const VertexBatchFn& fn) { return frames(nullptr, fn); };
  const NearVertexPassFn near = [&](const PositionBox& box, const VertexBatchFn& fn) { return frames(&box, fn); };
  shape.vertices = 1500;
  Mesh output = testing::make_torus(1.0, 0.41, shape);  // off the input's vertices
  for (std::size_t v = 0; v < 40; ++v) output.positions[3 * v] = input.positions[11 * v];  // and on some
  for (std::size_t v = 0; v < 30; ++v) {  // and far from it: the first round of a run leaves these open
    Vec3f& p = output.positions[37 * v + 1];
    p = {1.5f * p.x, 1.5f * p.y, p.z + 0.5f};
  }
  auto whole = nearest_vertex_values(pass, output.positions, surface_area(output.positions, output.triangles));
  ASSERT_TRUE(whole.is_ok()) << whole.status().to_string();
  testing::ScratchDir dir;
  for (const std::size_t run : {std::size_t{1}, std::size_t{7}, std::size_t{500}, output.positions.size() - 1,
                                output.positions.size(), output.positions.size() + 5}) {
    for (const bool by_box : {false, true}) {
      SCOPED_TRACE("run " + std::to_string(run) + (by_box ? ", frames near the run" : ", every frame"));
      auto file = VertexValuesFile::create(dir.path().string());
      ASSERT_TRUE(file.is_ok()) << file.status().to_string();
      TestParts parts(output, 64);
      auto found = nearest_vertex_values_in_runs(pass, by_box ? near : NearVertexPassFn{}, parts, std::uint64_t{1} << 40,
                                                 dir.path().string(), **file, run);
      ASSERT_TRUE(found.is_ok()) << found.status().to_string();
      EXPECT_EQ(*found, (output.positions.size() + run - 1) / run);
      EXPECT_EQ((*file)->count(), output.positions.size());
      EXPECT_TRUE(same(read_all(**file), *whole));
    }
  }
  EXPECT_GT(skipped, 0u);  // the short runs' passes left frames out
}

// A budget the process already fills leaves no room for runs: nothing is searched or written.
TEST(VertexValuesFile, NoRunsWhenTheBudgetLeavesNoRoom) {
  testing::ShapeOptions shape;
  shape.vertices = 40000;
  const Mesh output = testing::make_torus(1.0, 0.4, shape);
  std::size_t passes = 0;
  const VertexPassFn pass = [&](const VertexBatchFn&) {
    ++passes;
    return format::Status();
  };
  testing::ScratchDir dir;
  auto file = VertexValuesFile::create(dir.path().string());
  ASSERT_TRUE(file.is_ok());
  TestParts parts(output, 1000);
  auto found = nearest_vertex_values_in_runs(pass, {}, parts, current_rss() / 2, dir.path().string(), **file);
  ASSERT_TRUE(found.is_ok()) << found.status().to_string();
  EXPECT_EQ(*found, 0u);
  EXPECT_EQ(passes, 0u);
  EXPECT_EQ((*file)->count(), 0u);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(VertexValuesFile, GivesBackWhatWasAppendedAndNoMore) {
  testing::ScratchDir dir;
  auto file = VertexValuesFile::create(dir.path().string());
  ASSERT_TRUE(file.is_ok()) << file.status().to_string();
  std::vector<format::VertexAttributes> values(1000);
  for (std::size_t v = 0; v < values.size(); ++v) values[v].texcoord = {float(v), -float(v)};
  ASSERT_TRUE((*file)->append(std::span(values).first(300)).is_ok());
  ASSERT_TRUE((*file)->append(std::span(values).subspan(300)).is_ok());
  EXPECT_TRUE(same(read_all(**file), values));
  EXPECT_TRUE(same(read_all(**file), values));  // again, from the first
  ASSERT_TRUE((*file)->rewind().is_ok());
  std::vector<format::VertexAttributes> part(600);
  ASSERT_TRUE((*file)->read(part).is_ok());
  EXPECT_EQ(part[599].texcoord.u, 599.0f);
  const format::Status past = (*file)->read(part);  // 400 left
  EXPECT_EQ(past.code(), format::Code::kProcessing) << past.to_string();
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));  // the file has no name
}

}  // namespace
}  // namespace gaussmesh::stream
