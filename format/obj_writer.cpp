// Wavefront OBJ output: "v x y z [r g b]" with the shortest text that reads back to the same
// float (std::to_chars), "vt u v" and "vn x y z" when the mesh has them, then "f a b c" with
// 1-based indices (a/a/a, a/a or a//a with attributes). Validates the mesh before writing.
#include <algorithm>
#include <charconv>
#include <initializer_list>
#include <cmath>
#include <memory>
#include <string>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

// Lines are assembled here and handed to OutputFile in large pieces.
constexpr size_t kChunkBytes = 64u << 10;
// Longest line: "v" + 6 * (separator + shortest float text, at most 15 chars) + "\n", or
// "f" + 3 * (separator + three indices of at most 10 digits and two slashes) + "\n".
constexpr size_t kMaxLineBytes = 128;

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
  GM_RETURN_IF_ERROR(check_vertex_attributes(out, mesh));
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
  // One line of a keyword and floats.
  auto line = [&](const char* keyword, std::initializer_list<float> values) -> Status {
    GM_RETURN_IF_ERROR(lines.reserve_line());
    char* c = lines.end();
    for (const char* k = keyword; *k != '\0'; ++k) *c++ = *k;
    for (float value : values) {
      *c++ = ' ';
      c = std::to_chars(c, lines.limit(), value).ptr;
    }
    *c++ = '\n';
    lines.commit(c);
    return {};
  };
  const bool colors = !mesh.colors.empty();
  for (size_t i = 0; i < n; ++i) {
    const Vec3f& p = mesh.positions[i];
    if (colors) {
      const Color& k = mesh.colors[i];
      GM_RETURN_IF_ERROR(line("v", {p.x, p.y, p.z, std::clamp(k.r, 0.0f, 1.0f), std::clamp(k.g, 0.0f, 1.0f),
                                    std::clamp(k.b, 0.0f, 1.0f)}));
    } else {
      GM_RETURN_IF_ERROR(line("v", {p.x, p.y, p.z}));
    }
  }
  for (const Vec2f& t : mesh.texcoords) GM_RETURN_IF_ERROR(line("vt", {t.u, t.v}));
  for (const Vec3f& v : mesh.normals) GM_RETURN_IF_ERROR(line("vn", {v.x, v.y, v.z}));
  const bool texcoords = !mesh.texcoords.empty(), normals = !mesh.normals.empty();
  for (const Triangle& t : mesh.triangles) {
    GM_RETURN_IF_ERROR(lines.reserve_line());
    char* c = lines.end();
    *c++ = 'f';
    for (VertexIndex v : t.v) {
      *c++ = ' ';
      char* index = c;
      c = std::to_chars(c, lines.limit(), uint64_t{v} + 1).ptr;
      const size_t digits = static_cast<size_t>(c - index);
      if (texcoords || normals) {
        *c++ = '/';
        if (texcoords) c = std::copy(index, index + digits, c);
      }
      if (normals) {
        *c++ = '/';
        c = std::copy(index, index + digits, c);
      }
    }
    *c++ = '\n';
    lines.commit(c);
  }
  return lines.flush();
}

}  // namespace gaussmesh::format
