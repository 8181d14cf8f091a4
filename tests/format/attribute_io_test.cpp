// Vertex attributes through the writers and back through the readers: colours, normals and
// texture coordinates in binary and ascii PLY, Draco (decoded by our reader and by Google's
// decoder directly) and OBJ text; an attribute array of the wrong size is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "tests/format/attribute_sink.h"
#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

using testing::ScratchDir;

// A torus grid whose attributes are functions of the grid: unit normals, colours that vary
// around it (alpha when asked), texture coordinates from the grid's parameters.
Mesh attributed_torus(int nu, int nv, bool alpha) {
  Mesh m;
  const double pi = std::acos(-1.0);
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
      m.positions.push_back({float((1 + 0.3 * std::cos(v)) * std::cos(u)), float((1 + 0.3 * std::cos(v)) * std::sin(u)),
                             float(0.3 * std::sin(v))});
      m.normals.push_back({float(std::cos(v) * std::cos(u)), float(std::cos(v) * std::sin(u)), float(std::sin(v))});
      m.colors.push_back({float(i) / float(nu), float(j) / float(nv), 0.5f, alpha ? float(i + j) / float(nu + nv) : 1.0f});
      m.texcoords.push_back({float(i) / float(nu), float(j) / float(nv)});
    }
  }
  auto id = [&](int i, int j) { return VertexIndex((i % nu) * nv + j % nv); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      m.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  return m;
}

using Collect = AttributeSink;

Status write(const std::string& path, const std::function<Status(OutputFile&)>& writer) {
  auto out = OutputFile::create(path, true);
  if (!out) return out.status();
  GM_RETURN_IF_ERROR(writer(**out));
  return (*out)->commit();
}

Collect read(const std::string& path) {
  Collect sink;
  Status s = read_mesh_file(path, {}, sink);
  EXPECT_TRUE(s.is_ok()) << s.to_string();
  return sink;
}

float byte_value(float channel) { return float(color_byte(channel)) / 255.0f; }

TEST(AttributeIo, PlyKeepsEveryAttributeInBothEncodings) {
  ScratchDir dir;
  for (bool alpha : {false, true}) {
    for (bool binary : {true, false}) {
      SCOPED_TRACE(std::string(alpha ? "alpha " : "") + (binary ? "binary" : "ascii"));
      const Mesh mesh = attributed_torus(9, 5, alpha);
      PlyWriteOptions options;
      options.binary = binary;
      const std::string path = dir.file("t.ply");
      ASSERT_TRUE(write(path, [&](OutputFile& out) { return write_ply(out, mesh.view(), options); }).is_ok());
      const std::string text = testing::read_file(path);
      EXPECT_EQ(text.find("property uchar alpha") != std::string::npos, alpha);
      Collect back = read(path);
      EXPECT_EQ(back.header.attributes, (AttributeKinds{true, true, true}));
      EXPECT_TRUE(back.ignored.empty());
      ASSERT_EQ(back.attributes.size(), mesh.positions.size());
      EXPECT_EQ(back.positions, mesh.positions);
      for (size_t i = 0; i < mesh.positions.size(); ++i) {
        const VertexAttributes& a = back.attributes[i];
        EXPECT_EQ(a.normal, mesh.normals[i]) << i;
        EXPECT_EQ(a.texcoord, mesh.texcoords[i]) << i;
        const Color& c = mesh.colors[i];
        EXPECT_EQ(a.color, (Color{byte_value(c.r), byte_value(c.g), byte_value(c.b), alpha ? byte_value(c.a) : 1.0f})) << i;
      }
    }
  }
}

TEST(AttributeIo, DracoKeepsEveryAttributeWithinItsQuantization) {
  ScratchDir dir;
  for (bool alpha : {false, true}) {
    SCOPED_TRACE(alpha ? "alpha" : "opaque");
    const Mesh mesh = attributed_torus(16, 9, alpha);
    const std::string path = dir.file("t.drc");
    DracoWriteOptions options;
    ASSERT_TRUE(write(path, [&](OutputFile& out) { return write_draco(out, mesh.view(), options); }).is_ok());
    // Google's decoder: one attribute of each kind, colours as normalized bytes.
    const std::string bytes = testing::read_file(path);
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    auto decoded = draco::Decoder().DecodeMeshFromBuffer(&buffer);
    ASSERT_TRUE(decoded.ok());
    const draco::Mesh& dm = *decoded.value();
    const draco::PointAttribute* color = dm.GetNamedAttribute(draco::GeometryAttribute::COLOR);
    ASSERT_NE(color, nullptr);
    EXPECT_EQ(color->data_type(), draco::DT_UINT8);
    EXPECT_EQ(color->num_components(), alpha ? 4 : 3);
    EXPECT_NE(dm.GetNamedAttribute(draco::GeometryAttribute::NORMAL), nullptr);
    EXPECT_NE(dm.GetNamedAttribute(draco::GeometryAttribute::TEX_COORD), nullptr);
    // Our reader: every decoded point is an input vertex (within the position quantization), and
    // carries that vertex's colour exactly (in bytes), its normal within 1° and its texture
    // coordinate within the 12-bit step of their range.
    Collect back = read(path);
    EXPECT_EQ(back.header.attributes, (AttributeKinds{true, true, true}));
    ASSERT_EQ(back.positions.size(), mesh.positions.size());
    for (size_t i = 0; i < back.positions.size(); ++i) {
      size_t best = 0;
      double best_d = 1e9;
      for (size_t k = 0; k < mesh.positions.size(); ++k) {
        const Vec3f& p = mesh.positions[k];
        const double d = std::abs(p.x - back.positions[i].x) + std::abs(p.y - back.positions[i].y) + std::abs(p.z - back.positions[i].z);
        if (d < best_d) best_d = d, best = k;
      }
      ASSERT_LT(best_d, 1e-3);
      const VertexAttributes& a = back.attributes[i];
      const Color& c = mesh.colors[best];
      EXPECT_EQ(a.color, (Color{byte_value(c.r), byte_value(c.g), byte_value(c.b), alpha ? byte_value(c.a) : 1.0f}));
      const Vec3f& n = mesh.normals[best];
      EXPECT_GT(a.normal.x * n.x + a.normal.y * n.y + a.normal.z * n.z, std::cos(std::acos(-1.0) / 180));
      EXPECT_NEAR(a.texcoord.u, mesh.texcoords[best].u, 1.0 / 4095);
      EXPECT_NEAR(a.texcoord.v, mesh.texcoords[best].v, 1.0 / 4095);
    }
  }
}

TEST(AttributeIo, ObjWritesColoursTextureCoordinatesAndNormals) {
  ScratchDir dir;
  Mesh mesh = attributed_torus(4, 3, false);
  const std::string path = dir.file("t.obj");
  ASSERT_TRUE(write(path, [&](OutputFile& out) { return write_obj(out, mesh.view()); }).is_ok());
  const std::string text = testing::read_file(path);
  EXPECT_NE(text.find("\nv 1.3 0 0 0 0 0.5\n"), std::string::npos) << text.substr(0, 200);
  EXPECT_NE(text.find("\nvt 0 0\n"), std::string::npos);
  EXPECT_NE(text.find("\nvn 1 0 0\n"), std::string::npos);
  EXPECT_NE(text.find("\nf 1/1/1 4/4/4 5/5/5\n"), std::string::npos);
  mesh.normals.clear();
  mesh.colors.clear();
  ASSERT_TRUE(write(path, [&](OutputFile& out) { return write_obj(out, mesh.view()); }).is_ok());
  EXPECT_NE(testing::read_file(path).find("\nf 1/1 4/4 5/5\n"), std::string::npos);
  mesh.texcoords.clear();
  mesh.normals.assign(mesh.positions.size(), Vec3f{0, 0, 1});
  ASSERT_TRUE(write(path, [&](OutputFile& out) { return write_obj(out, mesh.view()); }).is_ok());
  EXPECT_NE(testing::read_file(path).find("\nf 1//1 4//4 5//5\n"), std::string::npos);
}

TEST(AttributeIo, AnAttributeOfTheWrongSizeIsRefused) {
  ScratchDir dir;
  Mesh mesh = attributed_torus(4, 3, false);
  mesh.colors.pop_back();
  for (const char* name : {"t.ply", "t.obj", "t.drc"}) {
    const std::string path = dir.file(name);
    Status s = write(path, [&](OutputFile& out) {
      const std::string n = name;
      return n == "t.ply" ? write_ply(out, mesh.view(), {}) : n == "t.obj" ? write_obj(out, mesh.view()) : write_draco(out, mesh.view(), {});
    });
    ASSERT_FALSE(s.is_ok()) << name;
    EXPECT_EQ(s.code(), Code::kProcessing);
    EXPECT_NE(s.message().find("11 colours for 12 vertices"), std::string::npos) << s.to_string();
  }
}

}  // namespace
}  // namespace gaussmesh::format
