// Tests for the parts writers (mesh_parts_writer.cpp): a mesh delivered in small batches, with
// and without per-vertex attributes (held, or read as they stream), gives the bytes the whole-mesh
// writers give; attributes of the wrong count and lying parts are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

using testing::ScratchDir;

// A mesh in memory handed out two vertices or faces at a time; `extra_vertices` lies about the count.
class TestParts final : public MeshParts {
 public:
  TestParts(MeshView mesh, std::uint64_t extra_vertices = 0) : mesh_(mesh), extra_(extra_vertices) {}
  std::uint64_t vertex_count() const override { return mesh_.positions.size() + extra_; }
  std::uint64_t face_count() const override { return mesh_.triangles.size(); }
  Status vertices(const std::function<Status(std::span<const Vec3f>)>& batch) override {
    for (std::size_t i = 0; i < mesh_.positions.size(); i += 2)
      GM_RETURN_IF_ERROR(batch(mesh_.positions.subspan(i, std::min<std::size_t>(2, mesh_.positions.size() - i))));
    return Status();
  }
  Status faces(const std::function<Status(std::span<const Triangle>)>& batch) override {
    for (std::size_t i = 0; i < mesh_.triangles.size(); i += 2)
      GM_RETURN_IF_ERROR(batch(mesh_.triangles.subspan(i, std::min<std::size_t>(2, mesh_.triangles.size() - i))));
    return Status();
  }

 private:
  MeshView mesh_;
  std::uint64_t extra_;
};

// Values read as they stream (VertexValuesReader), from a vector.
class TestValues final : public VertexValuesReader {
 public:
  explicit TestValues(std::vector<VertexAttributes> values) : values_(std::move(values)) {}
  std::uint64_t count() const override { return values_.size(); }
  Status rewind() override {
    at_ = 0;
    return Status();
  }
  Status read(std::span<VertexAttributes> out) override {
    if (out.size() > values_.size() - at_) return Status::error(Code::kProcessing, "values", "read past the end");
    std::copy_n(values_.begin() + static_cast<std::ptrdiff_t>(at_), out.size(), out.begin());
    at_ += out.size();
    return Status();
  }

 private:
  std::vector<VertexAttributes> values_;
  std::size_t at_ = 0;
};

struct TestMesh {
  std::vector<Vec3f> positions{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5f, 0.25f, -1e-7f}};
  std::vector<Triangle> triangles{{{0, 1, 2}}, {{0, 3, 1}}, {{1, 3, 2}}, {{2, 3, 0}}, {{4, 1, 2}}};
  std::vector<Vec3f> normals{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0.6f, 0.8f, 0}, {0, 0, -1}};
  std::vector<Color> colors{{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {0.5f, 0.5f, 0.5f, 1}, {0.2f, 0.4f, 0.6f, 1}};
  std::vector<Vec2f> texcoords{{0, 0}, {1, 0}, {0, 1}, {0.25f, 0.75f}, {0.5f, 0.125f}};
};

std::string written(const ScratchDir& dir, const std::function<Status(OutputFile&)>& write) {
  const std::string path = dir.file("out");
  auto out = OutputFile::create(path, true);
  EXPECT_TRUE(out.is_ok());
  const Status s = write(**out);
  EXPECT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_TRUE((*out)->commit().is_ok());
  return testing::read_file(path);
}

TEST(MeshPartsWriter, GivesTheWholeMeshWritersBytesWithAndWithoutAttributes) {
  ScratchDir dir;
  TestMesh m;
  for (int kinds = 0; kinds < 8; ++kinds) {
    for (bool alpha : {false, true}) {
      SCOPED_TRACE("kinds " + std::to_string(kinds) + (alpha ? " alpha" : ""));
      std::vector<Color> colors = m.colors;
      if (alpha) colors[3].a = 0.5f;
      MeshView view{m.positions, m.triangles};
      if (kinds & 1) view.normals = m.normals;
      if (kinds & 2) view.colors = colors;
      if (kinds & 4) view.texcoords = m.texcoords;
      PartsAttributes attributes;
      attributes.kinds = {!view.normals.empty(), !view.colors.empty(), !view.texcoords.empty()};
      std::vector<VertexAttributes> values(attributes.kinds.any() ? m.positions.size() : 0);
      for (std::size_t v = 0; v < values.size(); ++v) {
        if (attributes.kinds.normals) values[v].normal = m.normals[v];
        if (attributes.kinds.colors) values[v].color = colors[v];
        if (attributes.kinds.texcoords) values[v].texcoord = m.texcoords[v];
      }
      attributes.values = values;
      TestValues reader(values);
      PartsAttributes read_attributes;
      read_attributes.kinds = attributes.kinds;
      read_attributes.reader = &reader;
      for (bool binary : {true, false}) {
        PlyWriteOptions options;
        options.binary = binary;
        options.comments = {"c"};
        const std::string whole = written(dir, [&](OutputFile& out) { return write_ply(out, view, options); });
        for (const PartsAttributes* given : {&attributes, &read_attributes}) {
          TestParts parts(view);
          const std::string streamed =
              written(dir, [&](OutputFile& out) { return write_ply_parts(out, parts, binary, {"c"}, *given); });
          EXPECT_EQ(streamed, whole) << (binary ? "binary" : "ascii") << (given->reader ? ", values read" : "");
        }
      }
      const std::string whole = written(dir, [&](OutputFile& out) { return write_obj(out, view); });
      for (const PartsAttributes* given : {&attributes, &read_attributes}) {
        TestParts parts(view);
        EXPECT_EQ(written(dir, [&](OutputFile& out) { return write_obj_parts(out, parts, *given); }), whole)
            << (given->reader ? "values read" : "");
      }
    }
  }
}

TEST(MeshPartsWriter, AttributesOfAnotherCountAndLyingPartsAreRefused) {
  ScratchDir dir;
  TestMesh m;
  const MeshView view{m.positions, m.triangles};
  const std::vector<VertexAttributes> short_values(m.positions.size() - 1);
  TestValues short_reader(short_values);
  PartsAttributes wrong_read{{false, true, false}, {}};
  wrong_read.reader = &short_reader;
  for (const PartsAttributes& wrong : {PartsAttributes{{false, true, false}, short_values}, wrong_read}) {
    for (int format = 0; format < 2; ++format) {
      auto out = OutputFile::create(dir.file("o"), true);
      ASSERT_TRUE(out.is_ok());
      TestParts parts(view);
      const Status s = format == 0 ? write_ply_parts(**out, parts, true, {}, wrong) : write_obj_parts(**out, parts, wrong);
      EXPECT_EQ(s.code(), Code::kProcessing);
      EXPECT_NE(s.message().find("vertex attributes"), std::string::npos) << s.to_string();
    }
  }
  auto out = OutputFile::create(dir.file("o"), true);
  ASSERT_TRUE(out.is_ok());
  TestParts lying(view, 1);
  const Status s = write_ply_parts(**out, lying, true, {}, {});
  EXPECT_EQ(s.code(), Code::kProcessing);
  EXPECT_NE(s.message().find("vertices"), std::string::npos) << s.to_string();
}

}  // namespace
}  // namespace gaussmesh::format
