// Tests for format/gltf_writer: the GLB's chunks and JSON read by hand (nlohmann, not the
// library that wrote them), the Draco bytes it holds decoded by the Draco library, and the
// accessors checked against them; .gltf holds the same bytes as a data URI.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <nlohmann/json.hpp>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

using gaussmesh::Mesh;
using nlohmann::json;
using testing::ScratchDir;

// A closed n x m torus grid with a colour and texture coordinates per vertex.
Mesh torus(int n, int m, bool attributes) {
  Mesh mesh;
  const double kPi = 3.14159265358979;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      const double u = 2 * kPi * i / n, v = 2 * kPi * j / m;
      mesh.positions.push_back({float((3 + std::cos(v)) * std::cos(u)), float((3 + std::cos(v)) * std::sin(u)), float(std::sin(v))});
      if (attributes) {
        mesh.colors.push_back({float(i) / float(n), float(j) / float(m), 0.5f, 1.0f});
        mesh.texcoords.push_back({float(i) / float(n), 0.25f * float(j) / float(m)});
      }
    }
  }
  auto id = [&](int i, int j) { return static_cast<VertexIndex>((i % n) * m + (j % m)); };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      mesh.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      mesh.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  return mesh;
}

std::uint32_t u32(const std::string& bytes, std::size_t at) {
  std::uint32_t value;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

// A GLB split into its JSON and its binary chunk, with the container's own checks.
struct Glb {
  json document;
  std::string bin;
};

Glb split_glb(const std::string& bytes) {
  Glb glb;
  EXPECT_GE(bytes.size(), 28u);
  if (bytes.size() < 28) return glb;
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(u32(bytes, 4), 2u);
  EXPECT_EQ(u32(bytes, 8), bytes.size());
  const std::uint32_t json_length = u32(bytes, 12);
  EXPECT_EQ(u32(bytes, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  glb.document = json::parse(bytes.substr(20, json_length));
  const std::size_t bin_at = 20 + json_length;
  EXPECT_LE(bin_at + 8, bytes.size());
  if (bin_at + 8 > bytes.size()) return glb;
  const std::uint32_t bin_length = u32(bytes, bin_at);
  EXPECT_EQ(u32(bytes, bin_at + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_length % 4, 0u);
  EXPECT_EQ(bin_at + 8 + bin_length, bytes.size());
  glb.bin = bytes.substr(bin_at + 8, bin_length);
  return glb;
}

Status write_with(const std::string& path, MeshView mesh, bool binary) {
  auto out = OutputFile::create(path, binary);
  if (!out) return out.status();
  GltfWriteOptions options;
  options.binary = binary;
  GM_RETURN_IF_ERROR(write_gltf(**out, mesh, options));
  return (*out)->commit();
}

std::string draco_bytes(MeshView mesh) {
  ScratchDir dir;
  auto out = OutputFile::create(dir.file("m.drc"), true);
  EXPECT_TRUE(out.is_ok());
  EXPECT_TRUE(write_draco(**out, mesh, DracoWriteOptions{}).is_ok());
  EXPECT_TRUE((*out)->commit().is_ok());
  return testing::read_file(dir.file("m.drc"));
}

// The primitive's Draco bytes, from its extension's buffer view.
std::string primitive_draco(const json& document, const std::string& bin) {
  const json& extension = document["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"];
  const json& view = document["bufferViews"][extension["bufferView"].get<int>()];
  EXPECT_EQ(view["buffer"], 0);
  const std::size_t offset = view.value("byteOffset", 0);
  const std::size_t length = view["byteLength"];
  EXPECT_LE(offset + length, bin.size());
  return bin.substr(offset, length);
}

std::unique_ptr<draco::Mesh> decode(const std::string& bytes) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  EXPECT_TRUE(decoded.ok()) << decoded.status().error_msg();
  return decoded.ok() ? std::move(decoded).value() : nullptr;
}

TEST(GltfWriter, AGlbHoldsTheDracoMeshAndDescribesIt) {
  ScratchDir dir;
  // More than 65,535 vertices: the indices accessor is then 32-bit.
  const Mesh mesh = torus(300, 240, false);
  ASSERT_TRUE(write_with(dir.file("t.glb"), mesh.view(), true).is_ok());
  const Glb glb = split_glb(testing::read_file(dir.file("t.glb")));
  const json& d = glb.document;
  EXPECT_EQ(d["asset"]["version"], "2.0");
  EXPECT_EQ(d["extensionsUsed"], json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(d["extensionsRequired"], json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(d["scenes"][d["scene"].get<int>()]["nodes"], json::array({0}));
  EXPECT_EQ(d["nodes"][0]["mesh"], 0);
  ASSERT_EQ(d["meshes"].size(), 1u);
  ASSERT_EQ(d["meshes"][0]["primitives"].size(), 1u);
  const json& primitive = d["meshes"][0]["primitives"][0];
  EXPECT_EQ(primitive.value("mode", 4), 4);
  ASSERT_EQ(primitive["attributes"].size(), 1u);

  // The bytes are exactly what the .drc writer writes.
  const std::string draco = primitive_draco(d, glb.bin);
  EXPECT_EQ(draco, draco_bytes(mesh.view()));
  EXPECT_EQ(d["buffers"][0]["byteLength"].get<std::size_t>(), draco.size());
  EXPECT_FALSE(d["buffers"][0].contains("uri"));

  auto decoded = decode(draco);
  ASSERT_NE(decoded, nullptr);
  const json& indices = d["accessors"][primitive["indices"].get<int>()];
  EXPECT_EQ(indices["count"].get<std::size_t>(), 3 * decoded->num_faces());
  EXPECT_EQ(decoded->num_faces(), mesh.triangles.size());
  EXPECT_EQ(indices["componentType"], 5125);
  EXPECT_EQ(indices["type"], "SCALAR");
  EXPECT_FALSE(indices.contains("bufferView"));

  const json& position = d["accessors"][primitive["attributes"]["POSITION"].get<int>()];
  EXPECT_EQ(position["count"].get<std::size_t>(), decoded->num_points());
  EXPECT_EQ(position["componentType"], 5126);
  EXPECT_EQ(position["type"], "VEC3");
  const draco::PointAttribute* p = decoded->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(primitive["extensions"]["KHR_draco_mesh_compression"]["attributes"]["POSITION"].get<int>(), p->unique_id());
  // min/max are the decoded positions' own, and the positions are the input's up to quantization.
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (draco::PointIndex i(0); i < decoded->num_points(); ++i) {
    float value[3];
    p->ConvertValue<float, 3>(p->mapped_index(i), value);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], value[k]);
      hi[k] = std::max(hi[k], value[k]);
    }
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(position["min"][k].get<float>(), lo[k]) << k;
    EXPECT_EQ(position["max"][k].get<float>(), hi[k]) << k;
  }
  EXPECT_NEAR(position["max"][0].get<double>(), 4.0, 1e-3);
  EXPECT_NEAR(position["min"][2].get<double>(), -1.0, 1e-3);
}

TEST(GltfWriter, SmallMeshesHave16BitIndicesAndAttributesAreNamedByTheirSemantics) {
  ScratchDir dir;
  const Mesh mesh = torus(24, 16, true);
  ASSERT_TRUE(write_with(dir.file("t.glb"), mesh.view(), true).is_ok());
  const Glb glb = split_glb(testing::read_file(dir.file("t.glb")));
  const json& d = glb.document;
  const json& primitive = d["meshes"][0]["primitives"][0];
  EXPECT_EQ(d["accessors"][primitive["indices"].get<int>()]["componentType"], 5123);
  const json& color = d["accessors"][primitive["attributes"]["COLOR_0"].get<int>()];
  EXPECT_EQ(color["componentType"], 5121);
  EXPECT_EQ(color["normalized"], true);
  EXPECT_EQ(color["type"], "VEC3");  // every colour opaque
  const json& uv = d["accessors"][primitive["attributes"]["TEXCOORD_0"].get<int>()];
  EXPECT_EQ(uv["componentType"], 5126);
  EXPECT_EQ(uv["type"], "VEC2");

  auto decoded = decode(primitive_draco(d, glb.bin));
  ASSERT_NE(decoded, nullptr);
  const json& ids = primitive["extensions"]["KHR_draco_mesh_compression"]["attributes"];
  for (const auto& [semantic, accessor] : primitive["attributes"].items()) {
    EXPECT_EQ(d["accessors"][accessor.get<int>()]["count"].get<std::size_t>(), decoded->num_points()) << semantic;
    EXPECT_NE(decoded->GetAttributeByUniqueId(ids[semantic].get<std::uint32_t>()), nullptr) << semantic;
  }
  // Texture coordinates with glTF's origin: v is 1 - v. The torus's points are its vertices
  // (no seam), so each decoded point has a position that names its input vertex.
  const draco::PointAttribute* p = decoded->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  const draco::PointAttribute* t = decoded->GetAttributeByUniqueId(ids["TEXCOORD_0"].get<std::uint32_t>());
  ASSERT_NE(t, nullptr);
  int checked = 0;
  for (draco::PointIndex i(0); i < decoded->num_points(); ++i) {
    float position[3], uv_value[2];
    p->ConvertValue<float, 3>(p->mapped_index(i), position);
    t->ConvertValue<float, 2>(t->mapped_index(i), uv_value);
    double best = 1e30;
    std::size_t nearest = 0;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      const double dx = mesh.positions[v].x - position[0], dy = mesh.positions[v].y - position[1], dz = mesh.positions[v].z - position[2];
      const double d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < best) best = d2, nearest = v;
    }
    EXPECT_NEAR(uv_value[0], mesh.texcoords[nearest].u, 1e-3);
    EXPECT_NEAR(uv_value[1], 1.0f - mesh.texcoords[nearest].v, 1e-3);
    ++checked;
  }
  EXPECT_EQ(checked, 24 * 16);
}

TEST(GltfWriter, AGltfHoldsTheSameBytesAsADataUri) {
  ScratchDir dir;
  const Mesh mesh = torus(24, 16, false);
  ASSERT_TRUE(write_with(dir.file("t.glb"), mesh.view(), true).is_ok());
  ASSERT_TRUE(write_with(dir.file("t.gltf"), mesh.view(), false).is_ok());
  const Glb glb = split_glb(testing::read_file(dir.file("t.glb")));
  const json text = json::parse(testing::read_file(dir.file("t.gltf")));
  EXPECT_EQ(text["extensionsRequired"], json::array({"KHR_draco_mesh_compression"}));
  const std::string uri = text["buffers"][0]["uri"];
  const std::string prefix = "data:application/octet-stream;base64,";
  ASSERT_EQ(uri.substr(0, prefix.size()), prefix);
  // Decode the base64 by hand.
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string bytes;
  std::uint32_t bits = 0;
  int held = 0;
  for (char c : uri.substr(prefix.size())) {
    if (c == '=') break;
    const auto at = alphabet.find(c);
    ASSERT_NE(at, std::string::npos);
    bits = (bits << 6) | static_cast<std::uint32_t>(at);
    held += 6;
    if (held >= 8) {
      held -= 8;
      bytes.push_back(static_cast<char>((bits >> held) & 0xFF));
    }
  }
  EXPECT_EQ(primitive_draco(text, bytes), primitive_draco(glb.document, glb.bin));
  EXPECT_EQ(text["accessors"], glb.document["accessors"]);
}

TEST(GltfWriter, AMeshWithoutFacesIsRefusedAndNothingIsWritten) {
  ScratchDir dir;
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Status status = write_with(dir.file("empty.glb"), mesh.view(), true);
  EXPECT_EQ(status.code(), Code::kProcessing);
  EXPECT_NE(status.to_string().find("no faces"), std::string::npos) << status.to_string();
  EXPECT_FALSE(std::filesystem::exists(dir.file("empty.glb")));
}

}  // namespace
}  // namespace gaussmesh::format
