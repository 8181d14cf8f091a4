// Draco output: builds a draco::Mesh (float32 POSITION attribute, the mesh's NORMAL, COLOR and
// TEX_COORD when it has them, and the faces), encodes it with
// edgebreaker and quantized positions (unquantized when Draco's float quantizer cannot hold the
// box), and writes the bytes through OutputFile. docs/formats.md.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f is copied as three packed floats");
static_assert(sizeof(Vec2f) == 2 * sizeof(float), "Vec2f is copied as two packed floats");

constexpr int kMinQuantizationBits = 1;
constexpr int kMaxQuantizationBits = 30;  // Draco's own limit for position quantization
constexpr int kMaxCompressionLevel = 10;

Status validate(const OutputFile& out, MeshView mesh, const DracoWriteOptions& options) {
  if (options.quantization_bits < kMinQuantizationBits ||
      options.quantization_bits > kMaxQuantizationBits) {
    return Status::error(Code::kUsage, "--qp",
                         "position quantization must be 1..30 bits, got " +
                             std::to_string(options.quantization_bits));
  }
  if (options.normal_bits < kMinQuantizationBits || options.normal_bits > kMaxQuantizationBits) {
    return Status::error(Code::kUsage, "--qn", "normal quantization must be 1..30 bits, got " + std::to_string(options.normal_bits));
  }
  if (options.texcoord_bits < kMinQuantizationBits || options.texcoord_bits > kMaxQuantizationBits) {
    return Status::error(Code::kUsage, "--qt",
                         "texture coordinate quantization must be 1..30 bits, got " + std::to_string(options.texcoord_bits));
  }
  if (options.compression_level < 0 || options.compression_level > kMaxCompressionLevel) {
    return Status::error(Code::kUsage, "--cl",
                         "compression level must be 0..10, got " +
                             std::to_string(options.compression_level));
  }
  if (mesh.triangles.empty()) {
    // Draco's edgebreaker refuses a mesh without faces, and a point cloud is not what a
    // simplifier should silently produce.
    return Status::error(Code::kProcessing, out.name(),
                         "cannot write an empty mesh (no faces) as Draco");
  }
  const size_t n = mesh.positions.size();
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (VertexIndex v : mesh.triangles[f].v) {
      if (v >= n) {
        return Status::error(Code::kProcessing, out.name(),
                             "face " + std::to_string(f) + " refers to vertex " +
                                 std::to_string(v) + " of " + std::to_string(n));
      }
    }
  }
  return check_vertex_attributes(out, mesh);
}

// Adds an identity-mapped attribute of `components` values of `type` per point.
void add_attribute(draco::Mesh& out, draco::GeometryAttribute::Type kind, int components, draco::DataType type,
                   bool normalized, const void* values, std::size_t bytes) {
  const auto num_points = static_cast<std::uint32_t>(out.num_points());
  draco::GeometryAttribute attribute;
  const std::size_t stride = bytes / num_points;
  attribute.Init(kind, nullptr, static_cast<std::int8_t>(components), type, normalized, static_cast<std::int64_t>(stride), 0);
  const int id = out.AddAttribute(attribute, true, num_points);
  out.attribute(id)->buffer()->Write(0, values, bytes);
}

// The mesh as Draco holds it: one point per input vertex, identity-mapped positions, and the
// mesh's normals, colours (8 bits a channel, alpha when a colour is not opaque) and texture
// coordinates.
void build_draco_mesh(MeshView mesh, draco::Mesh& out) {
  const auto num_points = static_cast<draco::PointIndex::ValueType>(mesh.positions.size());
  out.set_num_points(num_points);
  add_attribute(out, draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32, false, mesh.positions.data(),
                mesh.positions.size_bytes());
  if (!mesh.normals.empty()) {
    add_attribute(out, draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32, false, mesh.normals.data(),
                  mesh.normals.size_bytes());
  }
  if (!mesh.colors.empty()) {
    const int channels = has_alpha(mesh.colors) ? 4 : 3;
    std::vector<std::uint8_t> bytes;
    bytes.reserve(mesh.colors.size() * channels);
    for (const Color& c : mesh.colors) {
      for (int k = 0; k < channels; ++k) bytes.push_back(color_byte((&c.r)[k]));
    }
    add_attribute(out, draco::GeometryAttribute::COLOR, channels, draco::DT_UINT8, true, bytes.data(), bytes.size());
  }
  if (!mesh.texcoords.empty()) {
    add_attribute(out, draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32, false, mesh.texcoords.data(),
                  mesh.texcoords.size_bytes());
  }
  out.SetNumFaces(mesh.triangles.size());
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    out.SetFace(draco::FaceIndex(static_cast<uint32_t>(f)),
                {draco::PointIndex(t.v[0]), draco::PointIndex(t.v[1]), draco::PointIndex(t.v[2])});
  }
}

// Draco's quantizer works in float: it divides 2^bits - 1 by the box's largest extent and
// quantizes (p - min) times that. A box so small that the factor overflows, or so large that
// the extent or a difference does, turns every position into the same garbage; such a mesh
// keeps its float positions unquantized (lossless, larger) instead. The quantization step must
// also be a normal float, so that dequantized positions keep their relative precision.
bool quantizable(MeshView mesh, int bits) {
  if (mesh.positions.empty()) return true;
  double lo[3], hi[3];
  for (int axis = 0; axis < 3; ++axis) lo[axis] = hi[axis] = (&mesh.positions[0].x)[axis];
  for (const Vec3f& p : mesh.positions) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min<double>(lo[axis], (&p.x)[axis]);
      hi[axis] = std::max<double>(hi[axis], (&p.x)[axis]);
    }
  }
  const double range = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  if (range == 0) return true;  // Draco quantizes a point with a range of 1
  const double levels = double((std::uint64_t{1} << bits) - 1);
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  return range <= kFloatMax && levels / range <= kFloatMax && range / levels >= std::numeric_limits<float>::min();
}

}  // namespace

Status encode_draco(const OutputFile& out, MeshView mesh, const DracoWriteOptions& options, std::vector<char>& bytes) {
  GM_RETURN_IF_ERROR(validate(out, mesh, options));
  draco::EncoderBuffer buffer;
  try {
    draco::Mesh draco_mesh;
    build_draco_mesh(mesh, draco_mesh);
    draco::Encoder encoder;
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    if (quantizable(mesh, options.quantization_bits)) {
      encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.quantization_bits);
    }
    encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
    encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, options.texcoord_bits);
    const int speed = kMaxCompressionLevel - options.compression_level;
    encoder.SetSpeedOptions(speed, speed);
    const draco::Status encoded = encoder.EncodeMeshToBuffer(draco_mesh, &buffer);
    if (!encoded.ok()) {
      return Status::error(Code::kProcessing, out.name(),
                           std::string("Draco encoder failed: ") + encoded.error_msg());
    }
  } catch (const std::bad_alloc&) {
    return Status::error(Code::kResources, out.name(), "out of memory while encoding Draco");
  } catch (const std::exception& e) {
    return Status::error(Code::kProcessing, out.name(),
                         std::string("Draco encoder failed: ") + e.what());
  }
  bytes.swap(*buffer.buffer());
  return {};
}

Status write_draco(OutputFile& out, MeshView mesh, const DracoWriteOptions& options) {
  std::vector<char> bytes;
  GM_RETURN_IF_ERROR(encode_draco(out, mesh, options, bytes));
  return out.write(bytes.data(), bytes.size());
}

}  // namespace gaussmesh::format
