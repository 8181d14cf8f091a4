// Draco input: the whole file is decoded in memory by Google's decoder (Draco has no streaming
// decode), then delivered to the sink in batches like every other reader. Memory is the file
// plus the decoded mesh; Draco files are compressed outputs, so this is the one reader whose
// memory follows the input (docs/formats.md). Size is taken from the bytes actually read,
// never from a header.
#include <exception>
#include <new>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/mesh_batcher.h"
#include "format/mesh_reader.h"

namespace gaussmesh::format {
namespace {

// Files larger than this are refused rather than read whole (a decoded mesh is ~20x larger).
constexpr size_t kMaxDracoBytes = size_t{1} << 30;

Status decode_into(const std::vector<char>& bytes, ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    return Status::error(Code::kBadInput, source.name(), "Draco: " + decoded.status().error_msg_string());
  }
  const std::unique_ptr<draco::Mesh>& mesh = decoded.value();
  const draco::PointAttribute* position = mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (position == nullptr || position->num_components() < 3) {
    return Status::error(Code::kBadInput, source.name(), "Draco: the mesh has no 3-component POSITION attribute");
  }
  const uint64_t points = mesh->num_points();
  if (points > kMaxVertices) {
    return Status::error(Code::kBadInput, source.name(), "Draco: more than 2^32 - 1 points");
  }
  MeshHeader header;
  header.format = MeshFormat::kDraco;
  header.declared_vertices = points;
  header.declared_faces = mesh->num_faces();
  GM_RETURN_IF_ERROR(sink.on_header(header));
  MeshBatcher batcher(sink, options.batch_size);
  for (draco::PointIndex::ValueType i = 0; i < points; ++i) {
    float xyz[3] = {0, 0, 0};
    if (!position->ConvertValue<float, 3>(position->mapped_index(draco::PointIndex(i)), xyz)) {
      return Status::error(Code::kBadInput, source.name(), "Draco: point " + std::to_string(i) + " has no position");
    }
    GM_RETURN_IF_ERROR(batcher.add_vertex({xyz[0], xyz[1], xyz[2]}));
  }
  for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f) {
    const auto& face = mesh->face(f);
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

}  // namespace

Status read_draco(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  std::vector<char> bytes;
  for (;;) {
    auto got = source.ensure(ByteSource::kMaxWindow);
    if (!got) return got.status();
    if (*got == 0) break;
    if (bytes.size() + *got > kMaxDracoBytes) {
      return Status::error(Code::kResources, source.at_byte(), "Draco input larger than 1 GiB is not supported");
    }
    bytes.insert(bytes.end(), source.cursor(), source.cursor() + *got);
    source.advance(*got);
  }
  try {
    return decode_into(bytes, source, options, sink);
  } catch (const std::bad_alloc&) {
    return Status::error(Code::kResources, source.name(), "out of memory decoding Draco");
  } catch (const std::exception& e) {
    return Status::error(Code::kBadInput, source.name(), std::string("Draco: ") + e.what());
  }
}

}  // namespace gaussmesh::format
