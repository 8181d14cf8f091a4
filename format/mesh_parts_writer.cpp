// PLY and OBJ output of a mesh delivered in parts (MeshParts): the header from the declared
// counts, then each batch as it comes, through one fixed buffer. See mesh_writer.h.
#include <algorithm>
#include <charconv>
#include <initializer_list>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

constexpr std::size_t kBufferBytes = std::size_t{256} << 10;
// One ascii vertex line (eight floats of at most 15 characters and four bytes, with separators)
// or face line, or one binary record.
constexpr std::size_t kMaxRecordBytes = 160;
constexpr const char* kColorNames[4] = {"red", "green", "blue", "alpha"};

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

// The attributes' values in vertex order, held or read (PartsAttributes), one at a time.
class Values {
 public:
  explicit Values(const PartsAttributes& a) : held_(a.values), reader_(a.reader) {}
  std::uint64_t count() const { return reader_ ? reader_->count() : held_.size(); }
  // From the first value again.
  Status restart() {
    at_ = 0, end_ = 0, read_ = 0;
    return reader_ ? reader_->rewind() : Status();
  }
  // The next value, valid until the next call.
  Result<const VertexAttributes*> next() {
    if (!reader_) return &held_[at_++];
    if (at_ == end_) {
      const std::uint64_t n = std::min<std::uint64_t>(kBatch, reader_->count() - read_);
      if (n == 0) return Status::error(Code::kProcessing, "vertex values", "read past the last vertex's");
      batch_.resize(kBatch);
      GM_RETURN_IF_ERROR(reader_->read(std::span<VertexAttributes>(batch_.data(), n)));
      read_ += n, at_ = 0, end_ = n;
    }
    return &batch_[at_++];
  }

 private:
  static constexpr std::size_t kBatch = 4096;
  std::span<const VertexAttributes> held_;
  VertexValuesReader* reader_;
  std::vector<VertexAttributes> batch_;
  std::size_t at_ = 0, end_ = 0;
  std::uint64_t read_ = 0;
};

// Attributes, when there are any, hold one value per vertex.
Status check_counts(const OutputFile& out, const PartsAttributes& a, std::uint64_t nv) {
  const std::uint64_t values = Values(a).count();
  if (a.kinds.any() && values != nv) return miscount(out, "vertex attributes", values, nv);
  return Status();
}

// Whether a colour of `values` is not opaque (one pass over them).
Result<bool> any_alpha(Values& values) {
  GM_RETURN_IF_ERROR(values.restart());
  for (std::uint64_t v = 0, n = values.count(); v < n; ++v) {
    auto a = values.next();
    if (!a) return a.status();
    if ((*a)->color.a != 1) return true;
  }
  return false;
}

// Checks one more face against the declared counts, and counts it.
Status count_face(const OutputFile& out, const Triangle& t, std::uint64_t& faces, std::uint64_t nv, std::uint64_t nf) {
  for (VertexIndex v : t.v)
    if (v >= nv) return index_past(out, faces, v, nv);
  if (++faces > nf) return miscount(out, "faces", faces, nf);
  return Status();
}

}  // namespace

Status write_ply_parts(OutputFile& out, MeshParts& mesh, bool binary, const std::vector<std::string>& comments,
                       const PartsAttributes& attributes) {
  const std::uint64_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv > kMaxVertices) return Status::error(Code::kProcessing, out.name(), "more than 2^32 - 1 vertices cannot be indexed");
  GM_RETURN_IF_ERROR(check_counts(out, attributes, nv));
  const bool normals = attributes.kinds.normals, texcoords = attributes.kinds.texcoords;
  Values values(attributes);
  bool alpha = false;
  if (attributes.kinds.colors) {
    auto any = any_alpha(values);
    if (!any) return any.status();
    alpha = *any;
  }
  const int channels = !attributes.kinds.colors ? 0 : alpha ? 4 : 3;
  GM_RETURN_IF_ERROR(values.restart());
  std::string header = "ply\n";
  header += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
  for (const std::string& comment : comments) {
    if (comment.find_first_of("\r\n") != std::string::npos)
      return Status::error(Code::kProcessing, out.name(), "PLY comment holds a line break");
    header += "comment " + comment + "\n";
  }
  header += "element vertex " + std::to_string(nv) + "\nproperty float x\nproperty float y\nproperty float z\n";
  // The same properties, in the same order, as write_ply.
  if (normals) header += "property float nx\nproperty float ny\nproperty float nz\n";
  for (int k = 0; k < channels; ++k) header += std::string("property uchar ") + kColorNames[k] + "\n";
  if (texcoords) header += "property float s\nproperty float t\n";
  header += "element face " + std::to_string(nf) + "\n";
  header += nv > 0x7FFFFFFFu ? "property list uchar uint vertex_indices\n" : "property list uchar int vertex_indices\n";
  header += "end_header\n";
  GM_RETURN_IF_ERROR(out.write(header));
  Buffer buffer(out);
  std::uint64_t vertices = 0, faces = 0;
  GM_RETURN_IF_ERROR(mesh.vertices([&](std::span<const Vec3f> batch) -> Status {
    vertices += batch.size();
    if (vertices > nv) return miscount(out, "vertices", vertices, nv);
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const Vec3f& p = batch[i];
      GM_RETURN_IF_ERROR(buffer.room());
      float fields[3 + 3 + 2];
      std::size_t n = 0;
      fields[n++] = p.x, fields[n++] = p.y, fields[n++] = p.z;
      static const VertexAttributes kNone{};
      const VertexAttributes* value = &kNone;
      if (channels > 0 || normals || texcoords) {
        auto next = values.next();
        if (!next) return next.status();
        value = *next;
      }
      const VertexAttributes& a = *value;
      if (normals) fields[n++] = a.normal.x, fields[n++] = a.normal.y, fields[n++] = a.normal.z;
      std::uint8_t bytes[4];
      for (int k = 0; k < channels; ++k) bytes[k] = color_byte((&a.color.r)[k]);
      if (binary) {
        for (std::size_t k = 0; k < n; ++k) buffer.put(fields[k]);
        for (int k = 0; k < channels; ++k) buffer.put(bytes[k]);
        if (texcoords) buffer.put(a.texcoord.u), buffer.put(a.texcoord.v);
      } else {
        const bool more = channels > 0 || texcoords;
        for (std::size_t k = 0; k < n; ++k) buffer.text(fields[k], k + 1 < n || more ? ' ' : '\n');
        for (int k = 0; k < channels; ++k) buffer.text(unsigned{bytes[k]}, k + 1 < channels || texcoords ? ' ' : '\n');
        if (texcoords) buffer.text(a.texcoord.u, ' '), buffer.text(a.texcoord.v, '\n');
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

Status write_obj_parts(OutputFile& out, MeshParts& mesh, const PartsAttributes& attributes) {
  const std::uint64_t nv = mesh.vertex_count(), nf = mesh.face_count();
  GM_RETURN_IF_ERROR(check_counts(out, attributes, nv));
  const bool colors = attributes.kinds.colors, normals = attributes.kinds.normals, texcoords = attributes.kinds.texcoords;
  Values values(attributes);
  GM_RETURN_IF_ERROR(values.restart());
  // One line of a keyword and floats, as write_obj writes it.
  auto line = [](Buffer& buffer, const char* keyword, std::initializer_list<float> values) {
    char* c = buffer.at();
    for (const char* k = keyword; *k != '\0'; ++k) *c++ = *k;
    for (float value : values) *c++ = ' ', c = std::to_chars(c, buffer.limit(), value).ptr;
    *c++ = '\n';
    buffer.advance(c);
  };
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
      if (colors) {
        auto value = values.next();
        if (!value) return value.status();
        const Color& k = (*value)->color;
        line(buffer, "v", {p.x, p.y, p.z, std::clamp(k.r, 0.0f, 1.0f), std::clamp(k.g, 0.0f, 1.0f), std::clamp(k.b, 0.0f, 1.0f)});
      } else {
        line(buffer, "v", {p.x, p.y, p.z});
      }
    }
    return Status();
  }));
  if (vertices != nv) return miscount(out, "vertices", vertices, nv);
  // Texture coordinates, then normals: a pass over the values each, a line a vertex.
  const auto lines = [&](auto&& write) -> Status {
    GM_RETURN_IF_ERROR(values.restart());
    for (std::uint64_t v = 0; v < nv; ++v) {
      auto value = values.next();
      if (!value) return value.status();
      GM_RETURN_IF_ERROR(buffer.room());
      write(**value);
    }
    return Status();
  };
  if (texcoords) GM_RETURN_IF_ERROR(lines([&](const VertexAttributes& a) { line(buffer, "vt", {a.texcoord.u, a.texcoord.v}); }));
  if (normals) GM_RETURN_IF_ERROR(lines([&](const VertexAttributes& a) { line(buffer, "vn", {a.normal.x, a.normal.y, a.normal.z}); }));
  GM_RETURN_IF_ERROR(mesh.faces([&](std::span<const Triangle> batch) -> Status {
    for (const Triangle& t : batch) {
      GM_RETURN_IF_ERROR(count_face(out, t, faces, nv, nf));
      GM_RETURN_IF_ERROR(buffer.room());
      char* c = buffer.at();
      *c++ = 'f';
      for (VertexIndex v : t.v) {
        *c++ = ' ';
        char* index = c;
        c = std::to_chars(c, buffer.limit(), std::uint64_t{v} + 1).ptr;
        const std::size_t digits = static_cast<std::size_t>(c - index);
        // a/a/a, a/a or a//a, as write_obj names a vertex's attributes.
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
      buffer.advance(c);
    }
    return Status();
  }));
  if (faces != nf) return miscount(out, "faces", faces, nf);
  return buffer.flush();
}

}  // namespace gaussmesh::format
