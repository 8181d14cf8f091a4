// Streaming PLY reader (ascii 1.0, binary_little_endian 1.0, binary_big_endian 1.0): parses the
// header, then delivers vertex positions and fan-triangulated faces to a MeshSink in fixed-size
// batches. Memory never depends on the counts a header declares. docs/formats.md.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "format/mesh_reader.h"

namespace gaussmesh::format {
namespace {

// Bytes asked of the ByteSource per refill of the binary window.
constexpr size_t kBlock = size_t{1} << 20;
// A header with more elements + properties than this is refused (memory stays bounded even
// for a hostile header of millions of property lines).
constexpr size_t kMaxHeaderEntries = 4096;
// Largest batch we allocate, whatever ReadOptions::batch_size asks.
constexpr size_t kMaxBatch = size_t{1} << 22;

enum class Scalar : uint8_t { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

size_t scalar_size(Scalar type) {
  switch (type) {
    case Scalar::kInt8:
    case Scalar::kUint8: return 1;
    case Scalar::kInt16:
    case Scalar::kUint16: return 2;
    case Scalar::kInt32:
    case Scalar::kUint32:
    case Scalar::kFloat32: return 4;
    case Scalar::kFloat64: return 8;
  }
  return 0;
}

bool is_integer(Scalar type) { return type != Scalar::kFloat32 && type != Scalar::kFloat64; }

std::optional<Scalar> parse_scalar_name(std::string_view name) {
  struct Entry {
    std::string_view name;
    Scalar type;
  };
  static constexpr Entry kNames[] = {
      {"char", Scalar::kInt8},      {"int8", Scalar::kInt8},       {"uchar", Scalar::kUint8},
      {"uint8", Scalar::kUint8},    {"short", Scalar::kInt16},     {"int16", Scalar::kInt16},
      {"ushort", Scalar::kUint16},  {"uint16", Scalar::kUint16},   {"int", Scalar::kInt32},
      {"int32", Scalar::kInt32},    {"uint", Scalar::kUint32},     {"uint32", Scalar::kUint32},
      {"float", Scalar::kFloat32},  {"float32", Scalar::kFloat32}, {"double", Scalar::kFloat64},
      {"float64", Scalar::kFloat64},
  };
  for (const Entry& entry : kNames) {
    if (entry.name == name) return entry.type;
  }
  return std::nullopt;
}

enum class Encoding { kAscii, kBinaryLittle, kBinaryBig };

struct Property {
  std::string name;
  Scalar type = Scalar::kFloat32;  // the value type; for lists, the item type
  bool is_list = false;
  Scalar count_type = Scalar::kUint8;  // lists only
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
  // Bytes per record when every property is a scalar, else 0 (binary only).
  size_t fixed_size = 0;
};

struct Header {
  Encoding encoding = Encoding::kAscii;
  std::vector<Element> elements;
  size_t vertex_element = SIZE_MAX;
  size_t face_element = SIZE_MAX;
  size_t xyz[3] = {0, 0, 0};  // property indices of x, y, z in the vertex element
  size_t face_list = 0;       // property index of vertex_indices in the face element
  // Per vertex property: the attribute channel it fills (kChannel*, -1 for none) and what the
  // stored value is divided by for the channel's (an 8-bit colour channel c is c / 255).
  struct VertexChannel {
    int channel = -1;
    double divisor = 1;
  };
  std::vector<VertexChannel> vertex_channels;
  AttributeKinds attributes;
  std::vector<std::string> ignored;  // other vertex properties, by name
};

// The channels of VertexAttributes a PLY vertex property can fill.
enum Channel { kNormalX, kNormalY, kNormalZ, kRed, kGreen, kBlue, kAlpha, kTextureU, kTextureV, kChannels };

void set_channel(VertexAttributes& a, int channel, float value) {
  switch (channel) {
    case kNormalX: a.normal.x = value; break;
    case kNormalY: a.normal.y = value; break;
    case kNormalZ: a.normal.z = value; break;
    case kRed: a.color.r = value; break;
    case kGreen: a.color.g = value; break;
    case kBlue: a.color.b = value; break;
    case kAlpha: a.color.a = value; break;
    case kTextureU: a.texcoord.u = value; break;
    case kTextureV: a.texcoord.v = value; break;
    default: break;
  }
}

// The channel a vertex property's name gives, or -1. The names are those of the common
// exporters: nx ny nz; red green blue alpha (diffuse_red … as some scanners write them);
// u v, s t, texture_u texture_v, texture_s texture_t.
int channel_of(std::string_view name) {
  static constexpr std::pair<std::string_view, int> kNames[] = {
      {"nx", kNormalX},         {"ny", kNormalY},          {"nz", kNormalZ},         {"red", kRed},
      {"green", kGreen},        {"blue", kBlue},           {"alpha", kAlpha},        {"diffuse_red", kRed},
      {"diffuse_green", kGreen}, {"diffuse_blue", kBlue},  {"diffuse_alpha", kAlpha}, {"u", kTextureU},
      {"v", kTextureV},         {"s", kTextureU},          {"t", kTextureV},         {"texture_u", kTextureU},
      {"texture_v", kTextureV}, {"texture_s", kTextureU},  {"texture_t", kTextureV}};
  for (const auto& [text, channel] : kNames) {
    if (name == text) return channel;
  }
  return -1;
}

// Header text quoted for a message: at most 60 characters, non-printable bytes shown as '?'.
std::string quote(std::string_view text) {
  std::string out = "'";
  for (char c : text.substr(0, 60)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  if (text.size() > 60) out += "...";
  return out + "'";
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

// Splits off the next whitespace-separated token of text (empty when none is left).
std::string_view next_token(std::string_view& text) {
  size_t begin = 0;
  while (begin < text.size() && is_space(text[begin])) ++begin;
  size_t end = begin;
  while (end < text.size() && !is_space(text[end])) ++end;
  std::string_view token = text.substr(begin, end - begin);
  text.remove_prefix(end);
  return token;
}

template <class T>
bool parse_number(std::string_view token, T& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

std::string not_finite_message(uint64_t vertex) {
  return "vertex " + std::to_string(vertex) + " has a coordinate that is not a finite number";
}

// Loads a scalar of the given type from p (unaligned), swapping bytes when kSwap.
template <class T, bool kSwap>
T load(const char* p) {
  if constexpr (sizeof(T) == 1) {
    T v;
    std::memcpy(&v, p, 1);
    return v;
  } else {
    using U = std::conditional_t<sizeof(T) == 2, uint16_t, std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>;
    U bits;
    std::memcpy(&bits, p, sizeof bits);
    if constexpr (kSwap) {
      if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
      if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
      if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
    }
    return std::bit_cast<T>(bits);
  }
}

template <bool kSwap>
double load_real(const char* p, Scalar type) {
  switch (type) {
    case Scalar::kInt8: return load<int8_t, kSwap>(p);
    case Scalar::kUint8: return load<uint8_t, kSwap>(p);
    case Scalar::kInt16: return load<int16_t, kSwap>(p);
    case Scalar::kUint16: return load<uint16_t, kSwap>(p);
    case Scalar::kInt32: return load<int32_t, kSwap>(p);
    case Scalar::kUint32: return load<uint32_t, kSwap>(p);
    case Scalar::kFloat32: return load<float, kSwap>(p);
    case Scalar::kFloat64: return load<double, kSwap>(p);
  }
  return 0;
}

// Precondition: is_integer(type).
template <bool kSwap>
int64_t load_integer(const char* p, Scalar type) {
  switch (type) {
    case Scalar::kInt8: return load<int8_t, kSwap>(p);
    case Scalar::kUint8: return load<uint8_t, kSwap>(p);
    case Scalar::kInt16: return load<int16_t, kSwap>(p);
    case Scalar::kUint16: return load<uint16_t, kSwap>(p);
    case Scalar::kInt32: return load<int32_t, kSwap>(p);
    case Scalar::kUint32: return load<uint32_t, kSwap>(p);
    default: return 0;
  }
}

class PlyReader {
 public:
  PlyReader(ByteSource& source, const ReadOptions& options, MeshSink& sink)
      : source_(source), sink_(sink),
        batch_size_(std::clamp<size_t>(options.batch_size, 1, kMaxBatch)) {}

  Status run() {
    GM_RETURN_IF_ERROR(read_header());
    MeshHeader mesh_header;
    mesh_header.format = MeshFormat::kPly;
    mesh_header.declared_vertices = header_.elements[header_.vertex_element].count;
    mesh_header.declared_faces =
        header_.face_element == SIZE_MAX ? 0 : header_.elements[header_.face_element].count;
    mesh_header.raw_vertices = raw_vertices();
    mesh_header.attributes = header_.attributes;
    GM_RETURN_IF_ERROR(sink_.on_header(mesh_header));
    for (const std::string& name : header_.ignored) GM_RETURN_IF_ERROR(sink_.on_ignored(name));
    if (skipped_lines_ > 0) {
      std::string more = skipped_lines_ > 1 ? " (and " + std::to_string(skipped_lines_ - 1) + " more such lines)" : "";
      GM_RETURN_IF_ERROR(sink_.on_warning(first_skipped_ + more));
    }
    vertex_limit_ = header_.elements[header_.vertex_element].count;
    vertices_.resize(batch_size_);
    if (header_.attributes.any()) attributes_.resize(batch_size_);
    triangles_.resize(batch_size_);
    for (size_t e = 0; e < header_.elements.size(); ++e) {
      if (header_.elements[e].properties.empty()) continue;  // records of no bytes
      switch (header_.encoding) {
        case Encoding::kAscii: GM_RETURN_IF_ERROR(read_ascii_element(e)); break;
        case Encoding::kBinaryLittle:
          GM_RETURN_IF_ERROR(std::endian::native == std::endian::little ? read_binary_element<false>(e)
                                                                        : read_binary_element<true>(e));
          break;
        case Encoding::kBinaryBig:
          GM_RETURN_IF_ERROR(std::endian::native == std::endian::big ? read_binary_element<false>(e)
                                                                     : read_binary_element<true>(e));
          break;
      }
    }
    GM_RETURN_IF_ERROR(header_.encoding == Encoding::kAscii ? check_ascii_tail() : check_binary_tail());
    return sink_.on_end();
  }

 private:
  // ---- header ---------------------------------------------------------------------------

  Status read_header() {
    auto got = source_.ensure(4);
    if (!got) return got.status();
    std::string_view start(source_.cursor(), source_.available());
    if (!(start.starts_with("ply\n") || start.starts_with("ply\r"))) {
      return Status::error(Code::kBadInput, source_.at_byte(0), "not a PLY file (no 'ply' line at the start)");
    }
    bool have_format = false;
    size_t entries = 0;
    for (;;) {
      auto line = source_.next_line();
      if (!line) return line.status();
      if (!line->has_value()) return source_.bad_at_line("file ends before end_header");
      std::string_view rest = **line;
      if (source_.line_number() == 1) continue;  // "ply", checked above
      std::string_view keyword = next_token(rest);
      if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
      if (keyword == "end_header") break;
      if (++entries > kMaxHeaderEntries) {
        return source_.bad_at_line("header has more than " + std::to_string(kMaxHeaderEntries) +
                                   " elements and properties");
      }
      if (keyword == "format") {
        std::string_view name = next_token(rest), version = next_token(rest);
        if (have_format || !next_token(rest).empty() || version != "1.0") {
          return source_.bad_at_line("unsupported format line " + quote(**line));
        }
        if (name == "ascii") {
          header_.encoding = Encoding::kAscii;
        } else if (name == "binary_little_endian") {
          header_.encoding = Encoding::kBinaryLittle;
        } else if (name == "binary_big_endian") {
          header_.encoding = Encoding::kBinaryBig;
        } else {
          return source_.bad_at_line("unsupported format line " + quote(**line));
        }
        have_format = true;
      } else if (keyword == "element") {
        GM_RETURN_IF_ERROR(parse_element_line(rest, **line));
      } else if (keyword == "property") {
        GM_RETURN_IF_ERROR(parse_property_line(rest, **line));
      } else if (could_be_structure(**line)) {
        return source_.bad_at_line("unknown header line " + quote(**line));
      } else {
        // Free text without a keyword (Blender 2.4 writes "Created by Blender3D 247 - …"): the
        // header reads the same without it.
        if (skipped_lines_++ == 0) {
          first_skipped_ = "line " + std::to_string(source_.line_number()) + ": header line with no PLY keyword skipped: " + quote(**line);
        }
      }
    }
    if (!have_format) return source_.bad_at_line("header has no format line");
    return check_header();
  }

  // An unknown header line that has the shape of an element or a property line (a misspelled
  // keyword: "elemnt vertex 8", "propery float x") changes how the body reads, so it is refused;
  // any other is free text and skipped.
  static bool could_be_structure(std::string_view line) {
    std::string_view tokens[6];
    size_t n = 0;
    for (std::string_view t = next_token(line); !t.empty() && n < 6; t = next_token(line)) tokens[n++] = t;
    std::uint64_t count = 0;
    bool element_shape = n == 3 && parse_number(tokens[2], count);
    bool property_shape = n == 3 && parse_scalar_name(tokens[1]).has_value();
    bool list_shape = n == 5 && tokens[1] == "list";
    return element_shape || property_shape || list_shape;
  }

  Status parse_element_line(std::string_view rest, std::string_view line) {
    Element element;
    element.name = std::string(next_token(rest));
    std::string_view count = next_token(rest);
    if (element.name.empty() || count.empty() || !next_token(rest).empty()) {
      return source_.bad_at_line("malformed element line " + quote(line));
    }
    if (!parse_number(count, element.count)) {
      return source_.bad_at_line("element " + element.name + ": count " + quote(count) +
                                 " is not a number below 2^64");
    }
    for (const Element& other : header_.elements) {
      if (other.name == element.name && (element.name == "vertex" || element.name == "face")) {
        return source_.bad_at_line("element " + element.name + " declared twice");
      }
    }
    if (element.name == "vertex") {
      if (element.count > kMaxVertices) {
        return source_.bad_at_line("element vertex count " + std::to_string(element.count) +
                                   " is too large (at most " + std::to_string(kMaxVertices) + " vertices)");
      }
      header_.vertex_element = header_.elements.size();
    } else if (element.name == "face") {
      header_.face_element = header_.elements.size();
      face_line_ = source_.line_number();
    }
    header_.elements.push_back(std::move(element));
    return {};
  }

  Status parse_property_line(std::string_view rest, std::string_view line) {
    if (header_.elements.empty()) return source_.bad_at_line("property line before any element line");
    Property property;
    std::string_view type = next_token(rest);
    if (type == "list") {
      std::string_view count_type = next_token(rest), item_type = next_token(rest);
      auto count = parse_scalar_name(count_type);
      auto item = parse_scalar_name(item_type);
      if (!count || !item) return source_.bad_at_line("unknown property type in " + quote(line));
      if (!is_integer(*count)) return source_.bad_at_line("list count type must be an integer in " + quote(line));
      property.is_list = true;
      property.count_type = *count;
      property.type = *item;
    } else {
      auto scalar = parse_scalar_name(type);
      if (!scalar) return source_.bad_at_line("unknown property type in " + quote(line));
      property.type = *scalar;
    }
    property.name = std::string(next_token(rest));
    if (property.name.empty() || !next_token(rest).empty()) {
      return source_.bad_at_line("malformed property line " + quote(line));
    }
    header_.elements.back().properties.push_back(std::move(property));
    return {};
  }

  Status check_header() {
    if (header_.vertex_element == SIZE_MAX) return source_.bad_at_line("header declares no element vertex");
    for (Element& element : header_.elements) {
      element.fixed_size = 0;
      bool fixed = true;
      size_t size = 0;
      for (const Property& property : element.properties) {
        if (property.is_list) fixed = false;
        size += scalar_size(property.type);  // at most kMaxHeaderEntries * 8: no overflow
      }
      if (fixed) element.fixed_size = size;
    }
    if (header_.face_element != SIZE_MAX && header_.face_element < header_.vertex_element) {
      return Status::error(Code::kBadInput, source_.name() + ":" + std::to_string(face_line_),
                           "element face comes before element vertex; a streaming reader needs the "
                           "vertices first");
    }
    const Element& vertex = header_.elements[header_.vertex_element];
    static constexpr const char* kAxes[3] = {"x", "y", "z"};
    for (int axis = 0; axis < 3; ++axis) {
      auto it = std::find_if(vertex.properties.begin(), vertex.properties.end(),
                             [&](const Property& p) { return p.name == kAxes[axis]; });
      if (it == vertex.properties.end()) {
        return source_.bad_at_line(std::string("element vertex has no property ") + kAxes[axis]);
      }
      if (it->is_list) return source_.bad_at_line(std::string("vertex property ") + kAxes[axis] + " is a list");
      header_.xyz[axis] = static_cast<size_t>(it - vertex.properties.begin());
    }
    find_attributes(vertex);
    if (header_.face_element != SIZE_MAX) {
      const Element& face = header_.elements[header_.face_element];
      auto it = std::find_if(face.properties.begin(), face.properties.end(), [](const Property& p) {
        return p.name == "vertex_indices" || p.name == "vertex_index";
      });
      if (it == face.properties.end()) {
        return source_.bad_at_line("element face has no property vertex_indices (or vertex_index)");
      }
      if (!it->is_list || !is_integer(it->type)) {
        return source_.bad_at_line("face property " + it->name + " must be a list of integers");
      }
      header_.face_list = static_cast<size_t>(it - face.properties.begin());
    }
    return {};
  }

  // The vertex properties that are attributes: a kind counts when all its channels are there
  // (alpha is optional), as scalars of a type it can take — colours as uchar or ushort (scaled to
  // 0–1) or as floats, normals and texture coordinates as floats. Every other vertex property
  // is named in header_.ignored.
  void find_attributes(const Element& vertex) {
    size_t property_of[kChannels];
    std::fill(std::begin(property_of), std::end(property_of), SIZE_MAX);
    for (size_t p = 0; p < vertex.properties.size(); ++p) {
      const Property& property = vertex.properties[p];
      const int channel = channel_of(property.name);
      if (channel < 0 || property.is_list || property_of[channel] != SIZE_MAX) continue;
      const bool is_color = channel >= kRed && channel <= kAlpha;
      const bool real = property.type == Scalar::kFloat32 || property.type == Scalar::kFloat64;
      if (real || (is_color && (property.type == Scalar::kUint8 || property.type == Scalar::kUint16))) {
        property_of[channel] = p;
      }
    }
    auto all = [&](int first, int last) {
      for (int c = first; c <= last; ++c) {
        if (property_of[c] == SIZE_MAX) return false;
      }
      return true;
    };
    AttributeKinds& kinds = header_.attributes;
    kinds.normals = all(kNormalX, kNormalZ);
    kinds.colors = all(kRed, kBlue);
    kinds.texcoords = all(kTextureU, kTextureV);
    std::vector<Header::VertexChannel>& channels = header_.vertex_channels;
    channels.assign(vertex.properties.size(), {});
    auto take = [&](int first, int last) {
      for (int c = first; c <= last; ++c) {
        const size_t p = property_of[c];
        if (p == SIZE_MAX) continue;
        const Scalar type = vertex.properties[p].type;
        channels[p] = {c, type == Scalar::kUint8 ? 255.0 : type == Scalar::kUint16 ? 65535.0 : 1.0};
      }
    };
    if (kinds.normals) take(kNormalX, kNormalZ);
    if (kinds.colors) take(kRed, kAlpha);
    if (kinds.texcoords) take(kTextureU, kTextureV);
    for (size_t p = 0; p < vertex.properties.size(); ++p) {
      const bool position = p == header_.xyz[0] || p == header_.xyz[1] || p == header_.xyz[2];
      if (!position && channels[p].channel < 0) header_.ignored.push_back(vertex.properties[p].name);
    }
  }

  std::string bad_attribute_message(uint64_t vertex) const {
    return "vertex " + std::to_string(vertex) + " has a normal, colour or texture coordinate that is not a finite number";
  }

  // ---- batches --------------------------------------------------------------------------

  Status flush_vertices() {
    if (vertex_fill_ == 0) return {};
    size_t n = vertex_fill_;
    vertex_fill_ = 0;
    if (header_.attributes.any()) {
      GM_RETURN_IF_ERROR(sink_.on_vertex_attributes(std::span<const VertexAttributes>(attributes_.data(), n)));
    }
    return sink_.on_vertices(std::span<const Vec3f>(vertices_.data(), n));
  }

  Status flush_triangles() {
    if (triangle_fill_ == 0) return {};
    size_t n = triangle_fill_;
    triangle_fill_ = 0;
    return sink_.on_triangles(std::span<const Triangle>(triangles_.data(), n));
  }

  Status add_triangle(uint32_t a, uint32_t b, uint32_t c) {
    triangles_[triangle_fill_++] = Triangle{{a, b, c}};
    if (triangle_fill_ == batch_size_) return flush_triangles();
    return {};
  }

  std::string index_message(const Element& element, uint64_t record, int64_t index) const {
    return "element " + element.name + " #" + std::to_string(record) + ": vertex index " +
           std::to_string(index) + " out of range (" + std::to_string(vertex_limit_) + " vertices)";
  }

  std::string short_face_message(const Element& element, uint64_t record, int64_t count) const {
    return "element " + element.name + " #" + std::to_string(record) + " has " + std::to_string(count) +
           " vertices; a face needs at least 3";
  }

  // ---- binary ---------------------------------------------------------------------------

  Status truncated(const Element& element, uint64_t record) const {
    return Status::error(Code::kBadInput, source_.at_byte(source_.offset() + source_.available()),
                         "file ends inside element " + element.name + " #" + std::to_string(record) +
                             " (" + std::to_string(element.count) + " declared)");
  }

  // Makes n bytes available at source_.cursor(), or returns the truncation error.
  // Precondition: n <= ByteSource::kMaxWindow.
  Status need(size_t n, const Element& element, uint64_t record) {
    if (source_.available() >= n) return {};
    auto got = source_.ensure(std::max(n, kBlock));
    if (!got) return got.status();
    if (*got < n) return truncated(element, record);
    return {};
  }

  // Skips n bytes of record data, streaming.
  Status skip(uint64_t n, const Element& element, uint64_t record) {
    while (n > 0) {
      if (source_.available() == 0) GM_RETURN_IF_ERROR(need(1, element, record));
      size_t take = static_cast<size_t>(std::min<uint64_t>(n, source_.available()));
      source_.advance(take);
      n -= take;
    }
    return {};
  }

  template <bool kSwap>
  Status read_binary_element(size_t e) {
    const Element& element = header_.elements[e];
    if (e == header_.vertex_element) {
      GM_RETURN_IF_ERROR(element.fixed_size > 0 ? read_fixed_vertices<kSwap>(element)
                                                : read_general_records<kSwap>(element, e));
      return flush_vertices();
    }
    if (e == header_.face_element) {
      const Property& list = element.properties[header_.face_list];
      if (element.properties.size() == 1 && list.count_type == Scalar::kUint8 &&
          (list.type == Scalar::kInt32 || list.type == Scalar::kUint32)) {
        GM_RETURN_IF_ERROR(read_common_faces<kSwap>(element));
      } else {
        GM_RETURN_IF_ERROR(read_general_records<kSwap>(element, e));
      }
      return flush_triangles();
    }
    if (element.fixed_size > 0) {
      // Skipped element of fixed-size records: one bulk skip, with the product checked.
      if (element.count > std::numeric_limits<uint64_t>::max() / element.fixed_size) {
        return source_.bad_at_byte("element " + element.name + ": count " + std::to_string(element.count) +
                                   " x record size " + std::to_string(element.fixed_size) +
                                   " bytes overflows; the file cannot hold it");
      }
      const uint64_t total = element.count * element.fixed_size;
      uint64_t bytes = total;
      while (bytes > 0) {
        GM_RETURN_IF_ERROR(need(1, element, (total - bytes) / element.fixed_size));
        size_t take = static_cast<size_t>(std::min<uint64_t>(bytes, source_.available()));
        source_.advance(take);
        bytes -= take;
      }
      return {};
    }
    return read_general_records<kSwap>(element, e);
  }

  // MeshHeader::raw_vertices: float32 x, y, z in fixed-size little-endian records of the first
  // element, read as they are (read_fixed_vertices' all_float path on a little-endian machine).
  std::optional<MeshHeader::RawVertices> raw_vertices() const {
    const Element& element = header_.elements[header_.vertex_element];
    if (header_.encoding != Encoding::kBinaryLittle || std::endian::native != std::endian::little ||
        header_.vertex_element != 0 || element.fixed_size == 0 || element.fixed_size > UINT32_MAX) {
      return std::nullopt;
    }
    MeshHeader::RawVertices raw;
    raw.first_byte = source_.offset();
    raw.stride = static_cast<std::uint32_t>(element.fixed_size);
    for (int axis = 0; axis < 3; ++axis) {
      if (element.properties[header_.xyz[axis]].type != Scalar::kFloat32) return std::nullopt;
      std::size_t at = 0;
      for (std::size_t p = 0; p < header_.xyz[axis]; ++p) at += scalar_size(element.properties[p].type);
      raw.xyz[axis] = static_cast<std::uint32_t>(at);
    }
    return raw;
  }

  // Vertex element of scalar properties only: records parsed straight from the window.
  template <bool kSwap>
  Status read_fixed_vertices(const Element& element) {
    const size_t size = element.fixed_size;
    size_t offset[3];
    Scalar type[3];
    for (int axis = 0; axis < 3; ++axis) {
      size_t at = 0;
      for (size_t p = 0; p < header_.xyz[axis]; ++p) at += scalar_size(element.properties[p].type);
      offset[axis] = at;
      type[axis] = element.properties[header_.xyz[axis]].type;
    }
    const bool all_float = type[0] == Scalar::kFloat32 && type[1] == Scalar::kFloat32 && type[2] == Scalar::kFloat32;
    struct Slot {
      size_t offset;
      Scalar type;
      int channel;
      double divisor;
    };
    std::vector<Slot> slots;
    for (size_t p = 0, at = 0; p < element.properties.size(); at += scalar_size(element.properties[p].type), ++p) {
      const Header::VertexChannel& c = header_.vertex_channels[p];
      if (c.channel >= 0) slots.push_back({at, element.properties[p].type, c.channel, c.divisor});
    }
    uint64_t done = 0;
    while (done < element.count) {
      GM_RETURN_IF_ERROR(need(size, element, done));
      size_t n = std::min<uint64_t>({source_.available() / size, element.count - done, batch_size_ - vertex_fill_});
      const char* p = source_.cursor();
      Vec3f* out = vertices_.data() + vertex_fill_;
      if (all_float) {
        for (size_t i = 0; i < n; ++i, p += size) {
          out[i] = Vec3f{load<float, kSwap>(p + offset[0]), load<float, kSwap>(p + offset[1]),
                         load<float, kSwap>(p + offset[2])};
        }
      } else {
        for (size_t i = 0; i < n; ++i, p += size) {
          out[i] = Vec3f{static_cast<float>(load_real<kSwap>(p + offset[0], type[0])),
                         static_cast<float>(load_real<kSwap>(p + offset[1], type[1])),
                         static_cast<float>(load_real<kSwap>(p + offset[2], type[2]))};
        }
      }
      for (size_t i = 0; i < n; ++i) {
        if (!is_finite(out[i])) return Status::error(Code::kBadInput, source_.at_byte(source_.offset() + i * size), not_finite_message(done + i));
      }
      if (!slots.empty()) {
        const char* record = source_.cursor();
        for (size_t i = 0; i < n; ++i, record += size) {
          VertexAttributes a;
          for (const Slot& slot : slots) {
            set_channel(a, slot.channel, static_cast<float>(load_real<kSwap>(record + slot.offset, slot.type) / slot.divisor));
          }
          if (!is_finite(a)) {
            return Status::error(Code::kBadInput, source_.at_byte(source_.offset() + i * size), bad_attribute_message(done + i));
          }
          attributes_[vertex_fill_ + i] = a;
        }
      }
      source_.advance(n * size);
      vertex_fill_ += n;
      done += n;
      if (vertex_fill_ == batch_size_) GM_RETURN_IF_ERROR(flush_vertices());
    }
    return {};
  }

  // The common face layout "property list uchar int|uint vertex_indices" and nothing else:
  // triangles are parsed straight from the window; any other record goes one at a time.
  template <bool kSwap>
  Status read_common_faces(const Element& element) {
    const bool is_signed = element.properties[0].type == Scalar::kInt32;
    // Unsigned compare: a negative int32 becomes >= 2^31 and fails against this limit.
    const uint64_t limit = is_signed ? std::min<uint64_t>(vertex_limit_, uint64_t{1} << 31) : vertex_limit_;
    uint64_t done = 0;
    while (done < element.count) {
      if (source_.available() < 13) {
        auto got = source_.ensure(kBlock);
        if (!got) return got.status();
        if (*got == 0) return truncated(element, done);
      }
      const char* begin = source_.cursor();
      const char* p = begin;
      const char* end = begin + source_.available();
      size_t room = std::min<uint64_t>(batch_size_ - triangle_fill_, element.count - done);
      Triangle* out = triangles_.data() + triangle_fill_;
      size_t n = 0;
      while (n < room && end - p >= 13 && static_cast<uint8_t>(*p) == 3) {
        const uint32_t v[3] = {load<uint32_t, kSwap>(p + 1), load<uint32_t, kSwap>(p + 5), load<uint32_t, kSwap>(p + 9)};
        if (v[0] >= limit || v[1] >= limit || v[2] >= limit) break;
        out[n++] = Triangle{{v[0], v[1], v[2]}};
        p += 13;
      }
      source_.advance(static_cast<size_t>(p - begin));
      triangle_fill_ += n;
      done += n;
      if (triangle_fill_ == batch_size_) GM_RETURN_IF_ERROR(flush_triangles());
      if (n < room && done < element.count) {
        // Not a triangle, a bad index, or a record split by the window: the general path.
        GM_RETURN_IF_ERROR(read_record<kSwap>(element, header_.face_element, done));
        ++done;
      }
    }
    return {};
  }

  template <bool kSwap>
  Status read_general_records(const Element& element, size_t e) {
    for (uint64_t record = 0; record < element.count; ++record) {
      GM_RETURN_IF_ERROR(read_record<kSwap>(element, e, record));
    }
    return {};
  }

  // One record of any element, property by property.
  template <bool kSwap>
  Status read_record(const Element& element, size_t e, uint64_t record) {
    const bool is_vertex = e == header_.vertex_element;
    const bool is_face = e == header_.face_element;
    const uint64_t start = source_.offset();
    float xyz[3] = {0, 0, 0};
    VertexAttributes attributes;
    for (size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      const size_t item = scalar_size(property.type);
      if (!property.is_list) {
        GM_RETURN_IF_ERROR(need(item, element, record));
        if (is_vertex) {
          for (int axis = 0; axis < 3; ++axis) {
            if (header_.xyz[axis] == p) xyz[axis] = static_cast<float>(load_real<kSwap>(source_.cursor(), property.type));
          }
          if (const Header::VertexChannel& c = header_.vertex_channels[p]; c.channel >= 0) {
            set_channel(attributes, c.channel, static_cast<float>(load_real<kSwap>(source_.cursor(), property.type) / c.divisor));
          }
        }
        source_.advance(item);
        continue;
      }
      const size_t count_size = scalar_size(property.count_type);
      GM_RETURN_IF_ERROR(need(count_size, element, record));
      int64_t count = load_integer<kSwap>(source_.cursor(), property.count_type);
      if (count < 0) {
        return source_.bad_at_byte("element " + element.name + " #" + std::to_string(record) + ": list " +
                                   property.name + " has negative length " + std::to_string(count));
      }
      if (!(is_face && p == header_.face_list)) {
        source_.advance(count_size);
        GM_RETURN_IF_ERROR(skip(static_cast<uint64_t>(count) * item, element, record));  // count < 2^32
        continue;
      }
      if (count < 3) return source_.bad_at_byte(short_face_message(element, record, count));
      source_.advance(count_size);
      uint32_t first = 0, previous = 0;
      for (int64_t k = 0; k < count; ++k) {
        GM_RETURN_IF_ERROR(need(item, element, record));
        int64_t index = load_integer<kSwap>(source_.cursor(), property.type);
        if (index < 0 || static_cast<uint64_t>(index) >= vertex_limit_) {
          return source_.bad_at_byte(index_message(element, record, index));
        }
        source_.advance(item);
        uint32_t v = static_cast<uint32_t>(index);
        if (k == 0) {
          first = v;
        } else if (k >= 2) {
          GM_RETURN_IF_ERROR(add_triangle(first, previous, v));
        }
        previous = v;
      }
    }
    if (is_vertex) {
      const Vec3f position{xyz[0], xyz[1], xyz[2]};
      if (!is_finite(position)) return Status::error(Code::kBadInput, source_.at_byte(start), not_finite_message(record));
      if (!is_finite(attributes)) return Status::error(Code::kBadInput, source_.at_byte(start), bad_attribute_message(record));
      if (!attributes_.empty()) attributes_[vertex_fill_] = attributes;
      vertices_[vertex_fill_++] = position;
      if (vertex_fill_ == batch_size_) GM_RETURN_IF_ERROR(flush_vertices());
    }
    return {};
  }

  // Anything after the last element must be whitespace.
  Status check_binary_tail() {
    for (;;) {
      auto got = source_.ensure(kBlock);
      if (!got) return got.status();
      if (*got == 0) return {};
      const char* p = source_.cursor();
      for (size_t i = 0; i < *got; ++i) {
        if (!is_space(p[i])) {
          source_.advance(i);
          return source_.bad_at_byte("unexpected data after the last element");
        }
      }
      source_.advance(*got);
    }
  }

  // ---- ascii ----------------------------------------------------------------------------

  Status ascii_error(const Element& element, uint64_t record, const std::string& what) const {
    return source_.bad_at_line("element " + element.name + " #" + std::to_string(record) + ": " + what);
  }

  Status read_ascii_element(size_t e) {
    const Element& element = header_.elements[e];
    const bool is_vertex = e == header_.vertex_element;
    const bool is_face = e == header_.face_element;
    for (uint64_t record = 0; record < element.count; ++record) {
      std::string_view text;
      for (;;) {
        auto line = source_.next_line();
        if (!line) return line.status();
        if (!line->has_value()) {
          return Status::error(Code::kBadInput, source_.name() + ":" + std::to_string(source_.line_number() + 1),
                               "file ends inside element " + element.name + " #" + std::to_string(record) +
                                   " (" + std::to_string(element.count) + " declared)");
        }
        text = **line;
        if (text.find_first_not_of(" \t\r\v\f") != std::string_view::npos) break;  // skip blank lines
      }
      float xyz[3] = {0, 0, 0};
      VertexAttributes attributes;
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        std::string_view token = next_token(text);
        if (token.empty()) return ascii_error(element, record, "line ends before property " + property.name);
        if (!property.is_list) {
          if (is_vertex) {
            for (int axis = 0; axis < 3; ++axis) {
              if (header_.xyz[axis] != p) continue;
              if (!parse_number(token, xyz[axis])) {
                return ascii_error(element, record, "bad number " + quote(token) + " for " + property.name);
              }
            }
            if (const Header::VertexChannel& c = header_.vertex_channels[p]; c.channel >= 0) {
              double value = 0;
              if (!parse_number(token, value)) {
                return ascii_error(element, record, "bad number " + quote(token) + " for " + property.name);
              }
              set_channel(attributes, c.channel, static_cast<float>(value / c.divisor));
            }
          }
          continue;
        }
        int64_t count = 0;
        if (!parse_number(token, count) || count < 0) {
          return ascii_error(element, record, "bad list length " + quote(token) + " for " + property.name);
        }
        const bool is_indices = is_face && p == header_.face_list;
        if (is_indices && count < 3) return source_.bad_at_line(short_face_message(element, record, count));
        uint32_t first = 0, previous = 0;
        for (int64_t k = 0; k < count; ++k) {
          std::string_view item = next_token(text);
          if (item.empty()) return ascii_error(element, record, "line ends inside list " + property.name);
          if (!is_indices) continue;
          int64_t index = 0;
          if (!parse_number(item, index)) return ascii_error(element, record, "bad vertex index " + quote(item));
          if (index < 0 || static_cast<uint64_t>(index) >= vertex_limit_) {
            return source_.bad_at_line(index_message(element, record, index));
          }
          uint32_t v = static_cast<uint32_t>(index);
          if (k == 0) {
            first = v;
          } else if (k >= 2) {
            GM_RETURN_IF_ERROR(add_triangle(first, previous, v));
          }
          previous = v;
        }
      }
      if (!next_token(text).empty()) return ascii_error(element, record, "extra values at the end of the line");
      if (is_vertex) {
        const Vec3f position{xyz[0], xyz[1], xyz[2]};
        if (!is_finite(position)) return source_.bad_at_line(not_finite_message(record));
        if (!is_finite(attributes)) return source_.bad_at_line(bad_attribute_message(record));
        if (!attributes_.empty()) attributes_[vertex_fill_] = attributes;
        vertices_[vertex_fill_++] = position;
        if (vertex_fill_ == batch_size_) GM_RETURN_IF_ERROR(flush_vertices());
      }
    }
    if (is_vertex) return flush_vertices();
    if (is_face) return flush_triangles();
    return {};
  }

  Status check_ascii_tail() {
    for (;;) {
      auto line = source_.next_line();
      if (!line) return line.status();
      if (!line->has_value()) return {};
      if ((**line).find_first_not_of(" \t\r\v\f") != std::string_view::npos) {
        return source_.bad_at_line("unexpected data after the last element");
      }
    }
  }

  ByteSource& source_;
  MeshSink& sink_;
  const size_t batch_size_;
  Header header_;
  uint64_t vertex_limit_ = 0;
  uint64_t face_line_ = 0;  // header line of "element face"
  uint64_t skipped_lines_ = 0;  // header lines of free text, skipped
  std::string first_skipped_;   // the warning for the first of them
  std::vector<Vec3f> vertices_;
  std::vector<VertexAttributes> attributes_;  // beside vertices_, when the header has attributes
  std::vector<Triangle> triangles_;
  size_t vertex_fill_ = 0;
  size_t triangle_fill_ = 0;
};

}  // namespace

Status read_ply(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  PlyReader reader(source, options, sink);
  return reader.run();
}

}  // namespace gaussmesh::format
