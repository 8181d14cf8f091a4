// PLY writer: binary_little_endian 1.0 (default) or ascii 1.0; triangles as
// "property list uchar int vertex_indices"; extra per-vertex and per-face scalar properties.
// Everything is validated before the first byte is written. docs/formats.md.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "format/mesh_writer.h"

namespace gaussmesh::format {
namespace {

// Records are assembled here and handed to OutputFile in large writes.
constexpr size_t kChunk = size_t{64} << 10;
// Longest record we produce: ascii numbers are at most ~16 characters each.
constexpr size_t kMaxScalarText = 32;

const char* type_name(const PlyAttribute& attribute) {
  switch (attribute.values.index()) {
    case 0: return "uchar";
    case 1: return "int";
    case 2: return "uint";
    default: return "float";
  }
}

size_t attribute_size(const PlyAttribute& attribute) {
  return std::visit([](auto span) { return span.size(); }, attribute.values);
}

bool is_valid_word(std::string_view word) {
  if (word.empty()) return false;
  for (char c : word) {
    if (c <= 0x20 || c >= 0x7f) return false;
  }
  return true;
}

Status check_attributes(const OutputFile& out, const std::vector<PlyAttribute>& attributes, size_t count,
                        const char* element) {
  for (const PlyAttribute& attribute : attributes) {
    if (!is_valid_word(attribute.name)) {
      return Status::error(Code::kProcessing, out.name(),
                           std::string("PLY ") + element + " attribute name '" + attribute.name +
                               "' is empty or holds spaces or control characters");
    }
    if (attribute_size(attribute) != count) {
      return Status::error(Code::kProcessing, out.name(),
                           std::string("PLY ") + element + " attribute " + attribute.name + " has " +
                               std::to_string(attribute_size(attribute)) + " values for " + std::to_string(count) +
                               " " + element + "s");
    }
  }
  return {};
}

// Appends records to a fixed buffer, flushing to the file as it fills.
class RecordBuffer {
 public:
  explicit RecordBuffer(OutputFile& out) : out_(out), buffer_(new char[kChunk]) {}

  // Makes room for n more bytes. Precondition: n <= kChunk.
  Status reserve(size_t n) {
    if (used_ + n > kChunk) return flush();
    return {};
  }
  Status flush() {
    Status status = out_.write(buffer_.get(), used_);
    used_ = 0;
    return status;
  }

  template <class T>
  void put_binary(T value) {  // little-endian whatever the host
    if constexpr (std::endian::native == std::endian::big && sizeof(T) > 1) {
      using U = std::conditional_t<sizeof(T) == 2, uint16_t, uint32_t>;
      U bits = std::bit_cast<U>(value);
      if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
      if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
      std::memcpy(buffer_.get() + used_, &bits, sizeof bits);
    } else {
      std::memcpy(buffer_.get() + used_, &value, sizeof value);
    }
    used_ += sizeof(T);
  }

  // Shortest text that reads back to the same value, then a separator.
  template <class T>
  void put_text(T value, char separator) {
    char* at = buffer_.get() + used_;
    auto [end, ec] = std::to_chars(at, buffer_.get() + kChunk, value);
    (void)ec;  // reserve() left room for any scalar
    *end = separator;
    used_ = static_cast<size_t>(end + 1 - buffer_.get());
  }

 private:
  OutputFile& out_;
  std::unique_ptr<char[]> buffer_;
  size_t used_ = 0;
};

void put_attribute(RecordBuffer& buffer, const PlyAttribute& attribute, size_t i, bool binary, char separator) {
  std::visit(
      [&](auto span) {
        using T = typename decltype(span)::value_type;
        using Text = std::conditional_t<std::is_same_v<T, uint8_t>, unsigned, T>;
        if (binary) {
          buffer.put_binary(span[i]);
        } else {
          buffer.put_text(static_cast<Text>(span[i]), separator);
        }
      },
      attribute.values);
}

// The mesh's attributes as PLY vertex properties, in arrays that live as long as this.
struct MeshProperties {
  std::vector<float> normal[3], texcoord[2];
  std::vector<std::uint8_t> color[4];
  std::vector<PlyAttribute> properties;

  explicit MeshProperties(MeshView mesh) {
    static constexpr const char* kNormal[3] = {"nx", "ny", "nz"};
    static constexpr const char* kColor[4] = {"red", "green", "blue", "alpha"};
    static constexpr const char* kTexcoord[2] = {"s", "t"};
    for (int k = 0; k < 3 && !mesh.normals.empty(); ++k) {
      for (const Vec3f& n : mesh.normals) normal[k].push_back((&n.x)[k]);
      properties.push_back({kNormal[k], std::span<const float>(normal[k])});
    }
    const int channels = mesh.colors.empty() ? 0 : has_alpha(mesh.colors) ? 4 : 3;
    for (int k = 0; k < channels; ++k) {
      for (const Color& c : mesh.colors) color[k].push_back(color_byte((&c.r)[k]));
      properties.push_back({kColor[k], std::span<const std::uint8_t>(color[k])});
    }
    for (int k = 0; k < 2 && !mesh.texcoords.empty(); ++k) {
      for (const Vec2f& t : mesh.texcoords) texcoord[k].push_back((&t.u)[k]);
      properties.push_back({kTexcoord[k], std::span<const float>(texcoord[k])});
    }
  }
};

}  // namespace

std::uint8_t color_byte(float channel) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(channel, 0.0f, 1.0f) * 255.0f));
}

bool has_alpha(std::span<const Color> colors) {
  return std::any_of(colors.begin(), colors.end(), [](const Color& c) { return c.a != 1; });
}

Status check_vertex_attributes(const OutputFile& out, MeshView mesh) {
  const size_t n = mesh.positions.size();
  const std::pair<const char*, size_t> sizes[] = {
      {"normals", mesh.normals.size()}, {"colours", mesh.colors.size()}, {"texture coordinates", mesh.texcoords.size()}};
  for (const auto& [what, size] : sizes) {
    if (size != 0 && size != n) {
      return Status::error(Code::kProcessing, out.name(),
                           std::string("the mesh has ") + std::to_string(size) + " " + what + " for " + std::to_string(n) +
                               " vertices");
    }
  }
  return {};
}

Status write_ply(OutputFile& out, MeshView mesh, const PlyWriteOptions& given) {
  GM_RETURN_IF_ERROR(check_vertex_attributes(out, mesh));
  const MeshProperties own(mesh);
  PlyWriteOptions options = given;
  options.vertex_attributes.insert(options.vertex_attributes.begin(), own.properties.begin(), own.properties.end());
  const size_t vertex_count = mesh.positions.size();
  const size_t face_count = options.write_faces ? mesh.triangles.size() : 0;
  if (vertex_count > kMaxVertices) {
    return Status::error(Code::kProcessing, out.name(), "more than 2^32 - 1 vertices cannot be indexed");
  }
  for (const std::string& comment : options.comments) {
    if (comment.find_first_of("\r\n") != std::string::npos) {
      return Status::error(Code::kProcessing, out.name(), "PLY comment holds a line break");
    }
  }
  if (!options.write_faces && !options.face_attributes.empty()) {
    return Status::error(Code::kProcessing, out.name(), "face attributes given for a point cloud (write_faces is false)");
  }
  GM_RETURN_IF_ERROR(check_attributes(out, options.vertex_attributes, vertex_count, "vertex"));
  GM_RETURN_IF_ERROR(check_attributes(out, options.face_attributes, face_count, "face"));
  if (options.write_faces) {
    for (size_t f = 0; f < mesh.triangles.size(); ++f) {
      for (VertexIndex v : mesh.triangles[f].v) {
        if (v >= vertex_count) {
          return Status::error(Code::kProcessing, out.name(),
                               "triangle " + std::to_string(f) + " refers to vertex " + std::to_string(v) + " of " +
                                   std::to_string(vertex_count));
        }
      }
    }
  }

  // Indices fit "int" unless the mesh has 2^31 vertices or more.
  const bool unsigned_indices = vertex_count > 0x7FFFFFFFu;
  std::string header = "ply\n";
  header += options.binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
  for (const std::string& comment : options.comments) header += "comment " + comment + "\n";
  header += "element vertex " + std::to_string(vertex_count) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  for (const PlyAttribute& a : options.vertex_attributes) header += std::string("property ") + type_name(a) + " " + a.name + "\n";
  if (options.write_faces) {
    header += "element face " + std::to_string(face_count) + "\n";
    header += unsigned_indices ? "property list uchar uint vertex_indices\n" : "property list uchar int vertex_indices\n";
    for (const PlyAttribute& a : options.face_attributes) header += std::string("property ") + type_name(a) + " " + a.name + "\n";
  }
  header += "end_header\n";
  GM_RETURN_IF_ERROR(out.write(header));

  RecordBuffer buffer(out);
  const bool binary = options.binary;
  const size_t vertex_extra = options.vertex_attributes.size();
  const size_t face_extra = options.face_attributes.size();
  if ((4 + vertex_extra) * kMaxScalarText > kChunk || (4 + face_extra) * kMaxScalarText > kChunk) {
    return Status::error(Code::kProcessing, out.name(), "too many PLY attributes");
  }
  const size_t vertex_room = (3 + vertex_extra) * kMaxScalarText;
  for (size_t i = 0; i < vertex_count; ++i) {
    GM_RETURN_IF_ERROR(buffer.reserve(vertex_room));
    const Vec3f& p = mesh.positions[i];
    if (binary) {
      buffer.put_binary(p.x);
      buffer.put_binary(p.y);
      buffer.put_binary(p.z);
    } else {
      buffer.put_text(p.x, ' ');
      buffer.put_text(p.y, ' ');
      buffer.put_text(p.z, vertex_extra == 0 ? '\n' : ' ');
    }
    for (size_t a = 0; a < vertex_extra; ++a) {
      put_attribute(buffer, options.vertex_attributes[a], i, binary, a + 1 == vertex_extra ? '\n' : ' ');
    }
  }
  const size_t face_room = (4 + face_extra) * kMaxScalarText;
  for (size_t f = 0; f < face_count; ++f) {
    GM_RETURN_IF_ERROR(buffer.reserve(face_room));
    const Triangle& t = mesh.triangles[f];
    if (binary) {
      buffer.put_binary(uint8_t{3});
      for (VertexIndex v : t.v) buffer.put_binary(v);  // "int" and "uint" share the bytes below 2^31
    } else {
      buffer.put_text(3u, ' ');
      buffer.put_text(t.v[0], ' ');
      buffer.put_text(t.v[1], ' ');
      buffer.put_text(t.v[2], face_extra == 0 ? '\n' : ' ');
    }
    for (size_t a = 0; a < face_extra; ++a) {
      put_attribute(buffer, options.face_attributes[a], f, binary, a + 1 == face_extra ? '\n' : ' ');
    }
  }
  return buffer.flush();
}

}  // namespace gaussmesh::format
