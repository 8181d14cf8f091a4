// Draco input: the whole file is decoded in memory by Google's decoder (Draco has no streaming
// decode), then delivered to the sink in batches like every other reader. Memory is the file
// plus the decode, which follows the mesh, not the file: a few MB of Draco can decode to a GB.
// So the counts are read from the header first (format/draco_header.h), and a decode whose
// estimated peak passes ReadOptions::memory_limit is refused before it starts (docs/formats.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/draco_header.h"
#include "format/mesh_batcher.h"
#include "format/mesh_reader.h"

namespace gaussmesh::format {
namespace {

// Files larger than this are refused rather than read whole (a decoded mesh is ~20x larger).
constexpr size_t kMaxDracoBytes = size_t{1} << 30;

// The read's peak beyond the file's own bytes, from the counts: Draco's mesh, its decoder's
// tables (edgebreaker's corner table) and attribute buffers, then the delivery. Per method, a
// rate per face and one per point fitted to the largest peaks measured on closed meshes (half a
// point a face) and on soups (three), at every encoding speed, and rounded up (docs/formats.md,
// "Draco input").
struct DecodeRates {
  std::uint64_t per_face, per_point;
};
constexpr DecodeRates kSequentialRates{20, 30};
constexpr DecodeRates kEdgebreakerRates{44, 64};
// The process around the read: the binary, its threads, a pipeline's ingest buffers (docs/formats.md).
constexpr std::uint64_t kProcessBytes = std::uint64_t{20} << 20;

std::uint64_t decode_bytes(const DracoCounts& counts) {
  const DecodeRates& r = counts.method == DracoMethod::kSequential ? kSequentialRates : kEdgebreakerRates;
  return counts.faces * r.per_face + counts.points * r.per_point;
}

std::uint64_t to_mib(std::uint64_t bytes) { return (bytes + (std::uint64_t{1} << 20) - 1) >> 20; }

// kResources, one line, when the process, the file's bytes and the decode's estimated peak pass
// the limit.
Status check_budget(const ByteSource& source, const DracoCounts* counts, std::uint64_t file_bytes,
                    std::uint64_t limit) {
  const std::uint64_t need = kProcessBytes + file_bytes + (counts != nullptr ? decode_bytes(*counts) : 0);
  if (limit == 0 || need <= limit) return {};
  const std::string what = counts != nullptr ? "decoding this Draco mesh (" + std::to_string(counts->faces) +
                                                   " faces, " + std::to_string(counts->points) + " points)"
                                             : "holding this Draco file";
  return Status::error(Code::kResources, source.name(),
                       what + " needs about " + std::to_string(to_mib(need)) + " MiB, over the --memory budget of " +
                           std::to_string(limit >> 20) + " MiB");
}

Result<std::unique_ptr<draco::Mesh>> decode(const std::vector<char>& bytes, const ByteSource& source) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    return Status::error(Code::kBadInput, source.name(), "Draco: " + decoded.status().error_msg_string());
  }
  return std::move(decoded).value();
}

// Components of a point's attribute value as floats: float types as they are, integer types as
// their value, or as value / the type's maximum when `unit` (colours, which Draco and glTF hold
// as 0..max of their type). Missing components stay as they were. Draco's own ConvertValue is
// not used: it reads the attribute's `normalized` flag, a bool that a file can set to a byte
// that is neither 0 nor 1, and loading that is undefined behaviour (fuzz_draco_reader's
// normalized-flag-128.drc).
bool read_components(const draco::PointAttribute& attribute, draco::PointIndex point, int count, bool unit, float* out) {
  const std::uint8_t* address = attribute.GetAddress(attribute.mapped_index(point));
  if (address == nullptr) return false;
  const int components = std::min<int>(count, attribute.num_components());
  for (int k = 0; k < components; ++k) {
    double value = 0, max = 1;
    auto take = [&](auto sample) {
      std::memcpy(&sample, address + k * sizeof(sample), sizeof(sample));
      value = static_cast<double>(sample);
      if constexpr (std::is_integral_v<decltype(sample)>) max = static_cast<double>(std::numeric_limits<decltype(sample)>::max());
    };
    switch (attribute.data_type()) {
      case draco::DT_INT8: take(std::int8_t{}); break;
      case draco::DT_UINT8: take(std::uint8_t{}); break;
      case draco::DT_INT16: take(std::int16_t{}); break;
      case draco::DT_UINT16: take(std::uint16_t{}); break;
      case draco::DT_INT32: take(std::int32_t{}); break;
      case draco::DT_UINT32: take(std::uint32_t{}); break;
      case draco::DT_INT64: take(std::int64_t{}); break;
      case draco::DT_UINT64: take(std::uint64_t{}); break;
      case draco::DT_FLOAT32: take(float{}); break;
      case draco::DT_FLOAT64: take(double{}); break;
      default: return false;  // DT_BOOL and unknown types carry no geometry
    }
    out[k] = static_cast<float>(unit ? value / max : value);
  }
  return true;
}

Status deliver(const draco::Mesh& mesh, const ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  const draco::PointAttribute* position = mesh.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (position == nullptr || position->num_components() < 3) {
    return Status::error(Code::kBadInput, source.name(), "Draco: the mesh has no 3-component POSITION attribute");
  }
  const uint64_t points = mesh.num_points();
  if (points > kMaxVertices) {
    return Status::error(Code::kBadInput, source.name(), "Draco: more than 2^32 - 1 points");
  }
  MeshHeader header;
  header.format = MeshFormat::kDraco;
  header.declared_vertices = points;
  header.declared_faces = mesh.num_faces();
  const draco::PointAttribute* normal = mesh.GetNamedAttribute(draco::GeometryAttribute::NORMAL);
  const draco::PointAttribute* color = mesh.GetNamedAttribute(draco::GeometryAttribute::COLOR);
  const draco::PointAttribute* texcoord = mesh.GetNamedAttribute(draco::GeometryAttribute::TEX_COORD);
  if (normal != nullptr && normal->num_components() != 3) normal = nullptr;
  if (color != nullptr && (color->num_components() < 3 || color->num_components() > 4)) color = nullptr;
  if (texcoord != nullptr && texcoord->num_components() != 2) texcoord = nullptr;
  header.attributes = {normal != nullptr, color != nullptr, texcoord != nullptr};
  GM_RETURN_IF_ERROR(sink.on_header(header));
  for (int a = 0; a < mesh.num_attributes(); ++a) {
    const draco::PointAttribute* attribute = mesh.attribute(a);
    if (attribute != position && attribute != normal && attribute != color && attribute != texcoord) {
      GM_RETURN_IF_ERROR(sink.on_ignored(draco::GeometryAttribute::TypeToString(attribute->attribute_type())));
    }
  }
  MeshBatcher batcher(sink, options.batch_size, header.attributes.any());
  for (draco::PointIndex::ValueType i = 0; i < points; ++i) {
    const draco::PointIndex point(i);
    float xyz[3] = {0, 0, 0};
    if (!read_components(*position, point, 3, false, xyz)) {
      return Status::error(Code::kBadInput, source.name(), "Draco: point " + std::to_string(i) + " has no position");
    }
    if (!is_finite(Vec3f{xyz[0], xyz[1], xyz[2]})) {
      return Status::error(Code::kBadInput, source.name(), "Draco: point " + std::to_string(i) + " has a coordinate that is not a finite number");
    }
    VertexAttributes attributes;
    bool converted = true;
    if (normal != nullptr) converted &= read_components(*normal, point, 3, false, &attributes.normal.x);
    if (color != nullptr) {
      float rgba[4] = {0, 0, 0, 1};
      converted &= read_components(*color, point, 4, true, rgba);
      attributes.color = {rgba[0], rgba[1], rgba[2], rgba[3]};
    }
    if (texcoord != nullptr) converted &= read_components(*texcoord, point, 2, false, &attributes.texcoord.u);
    if (!converted || !is_finite(attributes)) {
      return Status::error(Code::kBadInput, source.name(),
                           "Draco: point " + std::to_string(i) + " has a normal, colour or texture coordinate it cannot convert to finite numbers");
    }
    GM_RETURN_IF_ERROR(batcher.add_vertex({xyz[0], xyz[1], xyz[2]}, attributes));
  }
  for (draco::FaceIndex f(0); f < mesh.num_faces(); ++f) {
    const auto& face = mesh.face(f);
    for (int k = 0; k < 3; ++k) {
      if (face[k].value() >= points) {
        return Status::error(Code::kBadInput, source.name(), "Draco: face " + std::to_string(f.value()) + " refers to point " +
                                                                 std::to_string(face[k].value()) + " of " + std::to_string(points));
      }
    }
    GM_RETURN_IF_ERROR(batcher.add_triangle(face[0].value(), face[1].value(), face[2].value()));
  }
  GM_RETURN_IF_ERROR(batcher.finish());
  return sink.on_end();
}

// Reads the whole file into `bytes`, refusing it as soon as the file plus the decode of `counts`
// (when known) passes the limit.
Status read_whole(ByteSource& source, const DracoCounts* counts, std::uint64_t limit, std::vector<char>& bytes) {
  for (;;) {
    auto got = source.ensure(ByteSource::kMaxWindow);
    if (!got) return got.status();
    if (*got == 0) return {};
    if (bytes.size() + *got > kMaxDracoBytes) {
      return Status::error(Code::kResources, source.at_byte(), "Draco input larger than 1 GiB is not supported");
    }
    GM_RETURN_IF_ERROR(check_budget(source, counts, bytes.size() + *got, limit));
    bytes.insert(bytes.end(), source.cursor(), source.cursor() + *got);
    source.advance(*got);
  }
}

Status read_checked(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  // The counts, from the first window when the header lies within it (it always does unless
  // its metadata is megabytes long): a file whose decode cannot fit is refused unread.
  auto got = source.ensure(ByteSource::kMaxWindow);
  if (!got) return got.status();
  const bool whole_in_window = *got < ByteSource::kMaxWindow;
  auto counts = read_draco_counts({source.cursor(), *got}, source.name(), source.total_size().value_or(0));
  if (!counts && whole_in_window) return counts.status();
  if (counts) {
    GM_RETURN_IF_ERROR(check_budget(source, &*counts, source.total_size().value_or(*got), options.memory_limit));
  }
  std::vector<char> bytes;
  GM_RETURN_IF_ERROR(read_whole(source, counts ? &*counts : nullptr, options.memory_limit, bytes));
  if (!counts) {  // the header runs past the first window, or a count needed the rest of the file
    counts = read_draco_counts(bytes, source.name());
    if (!counts) return counts.status();
    GM_RETURN_IF_ERROR(check_budget(source, &*counts, bytes.size(), options.memory_limit));
  }
  auto mesh = decode(bytes, source);
  if (!mesh) return mesh.status();
  std::vector<char>().swap(bytes);  // the decoded mesh needs the file no more
  return deliver(**mesh, source, options, sink);
}

}  // namespace

Status read_draco(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  try {
    return read_checked(source, options, sink);
  } catch (const std::bad_alloc&) {
    return Status::error(Code::kResources, source.name(), "out of memory decoding Draco");
  } catch (const std::exception& e) {
    return Status::error(Code::kBadInput, source.name(), std::string("Draco: ") + e.what());
  }
}

}  // namespace gaussmesh::format
