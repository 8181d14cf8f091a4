// Reads the counts at the start of a Draco mesh bitstream (format/draco_header.h). The layout
// follows Draco 1.5's decoders: point_cloud_decoder.cc (header), metadata_decoder.cc,
// mesh_sequential_decoder.cc and mesh_edgebreaker_decoder{,_impl}.cc (DecodeConnectivity).
#include "format/draco_header.h"

#include <algorithm>
#include <cstring>

#include <draco/compression/config/compression_shared.h>

namespace gaussmesh::format {
namespace {

// The newest mesh bitstream read here. A newer Draco may write newer versions, whose counts this
// reader would not know where to find: the build stops until someone teaches it.
constexpr std::uint8_t kNewestMajor = 2;
constexpr std::uint8_t kNewestMinor = 2;
static_assert(draco::kDracoMeshBitstreamVersionMajor == kNewestMajor &&
                  draco::kDracoMeshBitstreamVersionMinor == kNewestMinor,
              "Draco reads a mesh bitstream version that read_draco_counts does not know");

constexpr std::uint8_t kTriangularMesh = 1;       // draco::TRIANGULAR_MESH
constexpr std::uint16_t kMetadataFlag = 0x8000;   // draco's METADATA_FLAG_MASK
constexpr int kMaxMetadataDepth = 64;             // nested sub-metadata; Draco's own recursion has no limit
constexpr int kMaxVarintBytes = 5;                // Draco's limit for a 32-bit varint

constexpr std::uint32_t version(std::uint32_t major, std::uint32_t minor) { return (major << 8) | minor; }

// A forward cursor over the header bytes; every read is bounds-checked.
class Cursor {
 public:
  Cursor(std::span<const char> bytes, const std::string& name, std::uint64_t file_size)
      : bytes_(bytes), name_(name), file_size_(std::max<std::uint64_t>(file_size, bytes.size())) {}

  size_t remaining() const { return bytes_.size() - pos_; }
  // What the whole file holds after the cursor, of which remaining() is at hand.
  std::uint64_t remaining_in_file() const { return file_size_ - pos_; }
  Status bad(const std::string& message) const {
    return Status::error(Code::kBadInput, name_ + ": byte " + std::to_string(pos_), "Draco: " + message);
  }
  Status ended() const { return bad("the file ends inside the mesh header"); }

  bool skip(size_t n) {
    if (n > remaining()) return false;
    pos_ += n;
    return true;
  }
  bool u8(std::uint8_t& out) {
    if (remaining() < 1) return false;
    out = static_cast<std::uint8_t>(bytes_[pos_++]);
    return true;
  }
  bool u16(std::uint16_t& out) {  // little-endian, as Draco writes it
    std::uint8_t lo = 0, hi = 0;
    if (!u8(lo) || !u8(hi)) return false;
    out = static_cast<std::uint16_t>(lo | (hi << 8));
    return true;
  }
  bool u32(std::uint32_t& out) {
    std::uint8_t b[4];
    for (auto& x : b) {
      if (!u8(x)) return false;
    }
    out = std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
    return true;
  }
  // Draco's unsigned varint: 7 bits a byte, low bits first, at most 5 bytes; bits past 32 are
  // dropped, as Draco drops them.
  bool varint(std::uint32_t& out) {
    std::uint64_t value = 0;
    for (int i = 0; i < kMaxVarintBytes; ++i) {
      std::uint8_t b = 0;
      if (!u8(b)) return false;
      value |= std::uint64_t{b & 0x7fu} << (7 * i);
      if ((b & 0x80) == 0) {
        out = static_cast<std::uint32_t>(value);
        return true;
      }
    }
    return false;
  }
  // A count in the connectivity header: a uint32 before `varint_since`, a varint from it on.
  bool count(std::uint32_t bitstream, std::uint32_t varint_since, std::uint32_t& out) {
    return bitstream < varint_since ? u32(out) : varint(out);
  }

 private:
  std::span<const char> bytes_;
  const std::string& name_;
  std::uint64_t file_size_;
  size_t pos_ = 0;
};

// A metadata name: one length byte, then the bytes.
bool skip_name(Cursor& in) {
  std::uint8_t length = 0;
  return in.u8(length) && in.skip(length);
}

// Metadata: entries (name, varint size > 0, bytes), then named sub-metadata, recursively. Draco
// reads the two counts without checking that they decoded (a bad count counts as 0); so does
// this, so that both stop at the same byte.
Status skip_metadata(Cursor& in, int depth) {
  if (depth > kMaxMetadataDepth) return in.bad("metadata nested deeper than " + std::to_string(kMaxMetadataDepth));
  std::uint32_t entries = 0;
  if (!in.varint(entries)) entries = 0;
  for (std::uint32_t i = 0; i < entries; ++i) {
    std::uint32_t size = 0;
    if (!skip_name(in) || !in.varint(size)) return in.ended();
    if (size == 0) return in.bad("a metadata entry without a value");
    if (!in.skip(size)) return in.ended();
  }
  std::uint32_t children = 0;
  if (!in.varint(children)) children = 0;
  for (std::uint32_t i = 0; i < children; ++i) {
    if (!skip_name(in)) return in.ended();
    GM_RETURN_IF_ERROR(skip_metadata(in, depth + 1));
  }
  return {};
}

// Geometry metadata: per-attribute metadata (varint attribute id, metadata), then the mesh's own.
// An id that does not decode ends the header, as in Draco: every entry then takes at least a
// byte, so a count of a billion in a short file stops at its end instead of looping on nothing.
Status skip_geometry_metadata(Cursor& in) {
  std::uint32_t attributes = 0;
  if (!in.varint(attributes)) attributes = 0;
  for (std::uint32_t i = 0; i < attributes; ++i) {
    std::uint32_t id = 0;
    if (!in.varint(id)) return in.ended();
    GM_RETURN_IF_ERROR(skip_metadata(in, 1));
  }
  return skip_metadata(in, 1);
}

// Sequential connectivity: faces and points, uint32 before 2.2, varints from 2.2.
Status read_sequential(Cursor& in, std::uint32_t bitstream, DracoCounts& counts) {
  std::uint32_t faces = 0, points = 0;
  if (!in.count(bitstream, version(2, 2), faces) || !in.count(bitstream, version(2, 2), points)) return in.ended();
  // Draco's own checks: 32-bit indices, and at least one byte a face index left in the file.
  if (faces > 0xffffffffu / 3 || faces > in.remaining_in_file() / 3) {
    return in.bad(std::to_string(faces) + " faces do not fit the rest of the file");
  }
  counts.faces = faces;
  counts.points = points;
  return {};
}

// Edgebreaker: the traversal type (InitializeDecoder), then [new vertices, before 2.2], encoded
// vertices and faces; uint32 before 2.0, varints from 2.0.
Status read_edgebreaker(Cursor& in, std::uint32_t bitstream, DracoCounts& counts) {
  std::uint8_t traversal = 0;
  if (!in.u8(traversal)) return in.ended();
  if (traversal > 2) return in.bad("unknown edgebreaker traversal " + std::to_string(traversal));
  std::uint32_t new_vertices = 0, vertices = 0, faces = 0;
  if (bitstream < version(2, 2) && !in.count(bitstream, version(2, 0), new_vertices)) return in.ended();
  if (!in.count(bitstream, version(2, 0), vertices) || !in.count(bitstream, version(2, 0), faces)) return in.ended();
  if (faces > 0xffffffffu / 3) return in.bad(std::to_string(faces) + " faces, more than Draco's corner indices hold");
  counts.faces = faces;
  counts.points = vertices;
  return {};
}

}  // namespace

Result<DracoCounts> read_draco_counts(std::span<const char> bytes, const std::string& name,
                                      std::uint64_t file_size) {
  Cursor in(bytes, name, file_size);
  if (bytes.size() < 5 || std::memcmp(bytes.data(), "DRACO", 5) != 0) return in.bad("no \"DRACO\" magic");
  in.skip(5);
  DracoCounts counts;
  std::uint8_t type = 0, method = 0;
  std::uint16_t flags = 0;
  if (!in.u8(counts.version_major) || !in.u8(counts.version_minor) || !in.u8(type) || !in.u8(method) ||
      !in.u16(flags)) {
    return in.ended();
  }
  const std::uint32_t bitstream = version(counts.version_major, counts.version_minor);
  if (counts.version_major < 1 || bitstream > version(kNewestMajor, kNewestMinor)) {
    return in.bad("unknown bitstream version " + std::to_string(counts.version_major) + "." +
                  std::to_string(counts.version_minor));
  }
  if (type != kTriangularMesh) return in.bad("not a triangle mesh (geometry type " + std::to_string(type) + ")");
  if (method > 1) return in.bad("unknown mesh encoding method " + std::to_string(method));
  if (bitstream >= version(1, 3) && (flags & kMetadataFlag) != 0) GM_RETURN_IF_ERROR(skip_geometry_metadata(in));
  counts.method = static_cast<DracoMethod>(method);
  if (counts.method == DracoMethod::kSequential) {
    GM_RETURN_IF_ERROR(read_sequential(in, bitstream, counts));
  } else {
    GM_RETURN_IF_ERROR(read_edgebreaker(in, bitstream, counts));
  }
  return counts;
}

}  // namespace gaussmesh::format
