// Wavefront OBJ output: "v x y z" with the shortest text that reads back to the same float
// (std::to_chars), then "f a b c" with 1-based indices. Validates the mesh before writing.
#include <charconv>
#include <cmath>
#include <memory>
#include <string>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

// Lines are assembled here and handed to OutputFile in large pieces.
constexpr size_t kChunkBytes = 64u << 10;
// Longest line: "v " + 3 * (shortest float text, at most 15 chars, + separator) + "\n".
constexpr size_t kMaxLineBytes = 64;

class LineBuffer {
 public:
  explicit LineBuffer(OutputFile& out) : out_(out), buffer_(new char[kChunkBytes]) {}

  // Room for one more line, flushing first when needed.
  Status reserve_line() {
    if (used_ + kMaxLineBytes > kChunkBytes) return flush();
    return {};
  }
  char* end() { return buffer_.get() + used_; }
  char* limit() { return buffer_.get() + kChunkBytes; }
  void commit(char* new_end) { used_ = static_cast<size_t>(new_end - buffer_.get()); }

  Status flush() {
    Status s = out_.write(buffer_.get(), used_);
    used_ = 0;
    return s;
  }

 private:
  OutputFile& out_;
  std::unique_ptr<char[]> buffer_;
  size_t used_ = 0;
};

}  // namespace

Status write_obj(OutputFile& out, MeshView mesh) {
  const size_t n = mesh.positions.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3f& p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return Status::error(Code::kProcessing, out.name(),
                           "vertex " + std::to_string(i) + " is not finite; cannot write OBJ");
    }
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (VertexIndex v : mesh.triangles[t].v) {
      if (v >= n) {
        return Status::error(Code::kProcessing, out.name(),
                             "triangle " + std::to_string(t) + " refers to vertex " + std::to_string(v) +
                                 " but the mesh has " + std::to_string(n) + " vertices");
      }
    }
  }

  LineBuffer lines(out);
  GM_RETURN_IF_ERROR(out.write("# gaussmesh: " + std::to_string(n) + " vertices, " +
                               std::to_string(mesh.triangles.size()) + " triangles\n"));
  for (const Vec3f& p : mesh.positions) {
    GM_RETURN_IF_ERROR(lines.reserve_line());
    char* c = lines.end();
    *c++ = 'v';
    for (float value : {p.x, p.y, p.z}) {
      *c++ = ' ';
      c = std::to_chars(c, lines.limit(), value).ptr;
    }
    *c++ = '\n';
    lines.commit(c);
  }
  for (const Triangle& t : mesh.triangles) {
    GM_RETURN_IF_ERROR(lines.reserve_line());
    char* c = lines.end();
    *c++ = 'f';
    for (VertexIndex v : t.v) {
      *c++ = ' ';
      c = std::to_chars(c, lines.limit(), uint64_t{v} + 1).ptr;
    }
    *c++ = '\n';
    lines.commit(c);
  }
  return lines.flush();
}

}  // namespace gaussmesh::format
