// PLY and OBJ output of a mesh delivered in parts (MeshParts): the header from the declared
// counts, then each batch as it comes, through one fixed buffer. See mesh_writer.h.
#include <charconv>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

constexpr std::size_t kBufferBytes = std::size_t{256} << 10;
constexpr std::size_t kMaxRecordBytes = 96;  // one ascii vertex or face line, or one binary record

class Buffer {
 public:
  explicit Buffer(OutputFile& out) : out_(out), bytes_(new char[kBufferBytes]) {}
  Status room() { return used_ + kMaxRecordBytes > kBufferBytes ? flush() : Status(); }
  char* at() { return bytes_.get() + used_; }
  char* limit() { return bytes_.get() + kBufferBytes; }
  void advance(char* end) { used_ = std::size_t(end - bytes_.get()); }
  template <class T>
  void put(T value) {  // little-endian hosts only (the readers assume the same)
    std::memcpy(at(), &value, sizeof value);
    used_ += sizeof value;
  }
  template <class T>
  void text(T value, char separator) {
    char* end = std::to_chars(at(), limit(), value).ptr;
    *end++ = separator;
    advance(end);
  }
  Status flush() {
    Status s = out_.write(bytes_.get(), used_);
    used_ = 0;
    return s;
  }

 private:
  OutputFile& out_;
  std::unique_ptr<char[]> bytes_;
  std::size_t used_ = 0;
};

Status miscount(const OutputFile& out, const char* what, std::uint64_t got, std::uint64_t declared) {
  return Status::error(Code::kProcessing, out.name(),
                       std::string("the mesh delivered ") + std::to_string(got) + " " + what + " of " +
                           std::to_string(declared) + " declared");
}

Status index_past(const OutputFile& out, std::uint64_t face, VertexIndex v, std::uint64_t vertices) {
  return Status::error(Code::kProcessing, out.name(),
                       "triangle " + std::to_string(face) + " refers to vertex " + std::to_string(v) + " of " +
                           std::to_string(vertices));
}

// Checks one more face against the declared counts, and counts it.
Status count_face(const OutputFile& out, const Triangle& t, std::uint64_t& faces, std::uint64_t nv, std::uint64_t nf) {
  for (VertexIndex v : t.v)
    if (v >= nv) return index_past(out, faces, v, nv);
  if (++faces > nf) return miscount(out, "faces", faces, nf);
  return Status();
}

}  // namespace

Status write_ply_parts(OutputFile& out, MeshParts& mesh, bool binary, const std::vector<std::string>& comments) {
  const std::uint64_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv > kMaxVertices) return Status::error(Code::kProcessing, out.name(), "more than 2^32 - 1 vertices cannot be indexed");
  std::string header = "ply\n";
  header += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
  for (const std::string& comment : comments) {
    if (comment.find_first_of("\r\n") != std::string::npos)
      return Status::error(Code::kProcessing, out.name(), "PLY comment holds a line break");
    header += "comment " + comment + "\n";
  }
  header += "element vertex " + std::to_string(nv) + "\nproperty float x\nproperty float y\nproperty float z\n";
  header += "element face " + std::to_string(nf) + "\n";
  header += nv > 0x7FFFFFFFu ? "property list uchar uint vertex_indices\n" : "property list uchar int vertex_indices\n";
  header += "end_header\n";
  GM_RETURN_IF_ERROR(out.write(header));
  Buffer buffer(out);
  std::uint64_t vertices = 0, faces = 0;
  GM_RETURN_IF_ERROR(mesh.vertices([&](std::span<const Vec3f> batch) -> Status {
    vertices += batch.size();
    if (vertices > nv) return miscount(out, "vertices", vertices, nv);
    for (const Vec3f& p : batch) {
      GM_RETURN_IF_ERROR(buffer.room());
      if (binary) {
        buffer.put(p.x), buffer.put(p.y), buffer.put(p.z);
      } else {
        buffer.text(p.x, ' '), buffer.text(p.y, ' '), buffer.text(p.z, '\n');
      }
    }
    return Status();
  }));
  if (vertices != nv) return miscount(out, "vertices", vertices, nv);
  GM_RETURN_IF_ERROR(mesh.faces([&](std::span<const Triangle> batch) -> Status {
    for (const Triangle& t : batch) {
      GM_RETURN_IF_ERROR(count_face(out, t, faces, nv, nf));
      GM_RETURN_IF_ERROR(buffer.room());
      if (binary) {
        buffer.put(std::uint8_t{3});
        for (VertexIndex v : t.v) buffer.put(v);
      } else {
        buffer.text(3u, ' '), buffer.text(t.v[0], ' '), buffer.text(t.v[1], ' '), buffer.text(t.v[2], '\n');
      }
    }
    return Status();
  }));
  if (faces != nf) return miscount(out, "faces", faces, nf);
  return buffer.flush();
}

Status write_obj_parts(OutputFile& out, MeshParts& mesh) {
  const std::uint64_t nv = mesh.vertex_count(), nf = mesh.face_count();
  GM_RETURN_IF_ERROR(out.write("# gaussmesh: " + std::to_string(nv) + " vertices, " + std::to_string(nf) + " triangles\n"));
  Buffer buffer(out);
  std::uint64_t vertices = 0, faces = 0;
  GM_RETURN_IF_ERROR(mesh.vertices([&](std::span<const Vec3f> batch) -> Status {
    for (const Vec3f& p : batch) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return Status::error(Code::kProcessing, out.name(),
                             "vertex " + std::to_string(vertices) + " is not finite; cannot write OBJ");
      if (++vertices > nv) return miscount(out, "vertices", vertices, nv);
      GM_RETURN_IF_ERROR(buffer.room());
      char* c = buffer.at();
      *c++ = 'v';
      for (float value : {p.x, p.y, p.z}) *c++ = ' ', c = std::to_chars(c, buffer.limit(), value).ptr;
      *c++ = '\n';
      buffer.advance(c);
    }
    return Status();
  }));
  if (vertices != nv) return miscount(out, "vertices", vertices, nv);
  GM_RETURN_IF_ERROR(mesh.faces([&](std::span<const Triangle> batch) -> Status {
    for (const Triangle& t : batch) {
      GM_RETURN_IF_ERROR(count_face(out, t, faces, nv, nf));
      GM_RETURN_IF_ERROR(buffer.room());
      char* c = buffer.at();
      *c++ = 'f';
      for (VertexIndex v : t.v) *c++ = ' ', c = std::to_chars(c, buffer.limit(), std::uint64_t{v} + 1).ptr;
      *c++ = '\n';
      buffer.advance(c);
    }
    return Status();
  }));
  if (faces != nf) return miscount(out, "faces", faces, nf);
  return buffer.flush();
}

}  // namespace gaussmesh::format
