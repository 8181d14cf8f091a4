// glTF 2.0 output: the mesh encoded by write_draco's encoder, wrapped in a glTF asset whose one
// primitive names it through KHR_draco_mesh_compression. The container (JSON, the GLB chunks,
// the base64 buffer of a .gltf) is tinygltf's; the accessors describe the Draco data as a
// decoder gives it back, so they are decoded here once to be counted. docs/formats.md.
#include <algorithm>
#include <cstdint>
#include <exception>
#include <limits>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <tiny_gltf.h>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";

// glTF's accessor component types (the spec's numbers).
constexpr int kUnsignedByte = 5121;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kFloat = 5126;

// What a glTF accessor says of one decoded Draco attribute.
struct DecodedAttribute {
  std::string semantic;  // POSITION, NORMAL, COLOR_0, TEXCOORD_0
  std::uint32_t unique_id = 0;
  int components = 0;
  int component_type = kFloat;
  bool normalized = false;
  std::vector<double> min, max;  // POSITION only (the spec requires them there)
};

struct Decoded {
  std::uint32_t points = 0;
  std::uint32_t faces = 0;
  std::vector<DecodedAttribute> attributes;
};

Status decode(const OutputFile& out, const std::vector<char>& bytes, Decoded& decoded) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto mesh = decoder.DecodeMeshFromBuffer(&buffer);
  if (!mesh.ok()) {
    return Status::error(Code::kProcessing, out.name(), std::string("Draco cannot decode what it encoded: ") + mesh.status().error_msg());
  }
  const draco::Mesh& m = *mesh.value();
  decoded.points = m.num_points();
  decoded.faces = m.num_faces();
  for (int id = 0; id < m.num_attributes(); ++id) {
    const draco::PointAttribute& a = *m.attribute(id);
    DecodedAttribute d;
    d.unique_id = a.unique_id();
    d.components = a.num_components();
    switch (a.attribute_type()) {
      case draco::GeometryAttribute::POSITION: d.semantic = "POSITION"; break;
      case draco::GeometryAttribute::NORMAL: d.semantic = "NORMAL"; break;
      case draco::GeometryAttribute::COLOR:
        d.semantic = "COLOR_0";
        d.component_type = kUnsignedByte;
        d.normalized = true;
        break;
      case draco::GeometryAttribute::TEX_COORD: d.semantic = "TEXCOORD_0"; break;
      default: continue;
    }
    if (d.semantic == "POSITION") {
      d.min.assign(3, std::numeric_limits<double>::infinity());
      d.max.assign(3, -std::numeric_limits<double>::infinity());
      for (draco::PointIndex p(0); p < m.num_points(); ++p) {
        float value[3];
        a.ConvertValue<float, 3>(a.mapped_index(p), value);
        for (int k = 0; k < 3; ++k) {
          d.min[k] = std::min<double>(d.min[k], value[k]);
          d.max[k] = std::max<double>(d.max[k], value[k]);
        }
      }
    }
    decoded.attributes.push_back(std::move(d));
  }
  return {};
}

int add_accessor(tinygltf::Model& model, int component_type, int components, std::uint32_t count, bool normalized) {
  tinygltf::Accessor accessor;
  accessor.componentType = component_type;
  accessor.count = count;
  accessor.normalized = normalized;
  accessor.type = components == 1   ? TINYGLTF_TYPE_SCALAR
                  : components == 2 ? TINYGLTF_TYPE_VEC2
                  : components == 3 ? TINYGLTF_TYPE_VEC3
                                    : TINYGLTF_TYPE_VEC4;
  model.accessors.push_back(std::move(accessor));
  return static_cast<int>(model.accessors.size() - 1);
}

tinygltf::Model build_model(const std::vector<char>& bytes, const Decoded& decoded) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "gaussmesh";

  tinygltf::Buffer buffer;
  buffer.data.assign(bytes.begin(), bytes.end());
  model.buffers.push_back(std::move(buffer));
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = 0;
  view.byteLength = bytes.size();
  model.bufferViews.push_back(std::move(view));

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.indices = add_accessor(model, decoded.points > std::numeric_limits<std::uint16_t>::max() ? kUnsignedInt : kUnsignedShort, 1,
                                   decoded.faces * 3, false);
  tinygltf::Value::Object draco_attributes;
  for (const DecodedAttribute& a : decoded.attributes) {
    const int accessor = add_accessor(model, a.component_type, a.components, decoded.points, a.normalized);
    model.accessors[accessor].minValues = a.min;
    model.accessors[accessor].maxValues = a.max;
    primitive.attributes[a.semantic] = accessor;
    draco_attributes[a.semantic] = tinygltf::Value(static_cast<int>(a.unique_id));
  }
  tinygltf::Value::Object extension;
  extension["bufferView"] = tinygltf::Value(0);
  extension["attributes"] = tinygltf::Value(std::move(draco_attributes));
  primitive.extensions[kDracoExtension] = tinygltf::Value(std::move(extension));

  tinygltf::Mesh mesh;
  mesh.primitives.push_back(std::move(primitive));
  model.meshes.push_back(std::move(mesh));
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(std::move(node));
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(std::move(scene));
  model.defaultScene = 0;
  model.extensionsUsed.push_back(kDracoExtension);
  model.extensionsRequired.push_back(kDracoExtension);
  return model;
}

}  // namespace

Status write_gltf(OutputFile& out, MeshView mesh, const GltfWriteOptions& options) {
  std::vector<char> bytes;
  std::string text;
  try {
    // glTF's texture origin is the image's top-left corner, the readers' its bottom-left.
    std::vector<Vec2f> flipped;
    if (!mesh.texcoords.empty()) {
      flipped.reserve(mesh.texcoords.size());
      for (const Vec2f& t : mesh.texcoords) flipped.push_back({t.u, 1.0f - t.v});
      mesh.texcoords = flipped;
    }
    GM_RETURN_IF_ERROR(encode_draco(out, mesh, options.draco, bytes));
    Decoded decoded;
    GM_RETURN_IF_ERROR(decode(out, bytes, decoded));
    tinygltf::Model model = build_model(bytes, decoded);
    std::vector<char>().swap(bytes);
    std::ostringstream stream;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, stream, !options.binary, options.binary)) {
      return Status::error(Code::kProcessing, out.name(), "glTF writer failed");
    }
    text = std::move(stream).str();
  } catch (const std::bad_alloc&) {
    return Status::error(Code::kResources, out.name(), "out of memory while writing glTF");
  } catch (const std::exception& e) {
    return Status::error(Code::kProcessing, out.name(), std::string("glTF writer failed: ") + e.what());
  }
  return out.write(text);
}

}  // namespace gaussmesh::format
