// Streaming OFF reader (Geomview Object File Format, ascii): [ST][C][N][4][n]OFF header,
// "V F [E]" counts, one vertex per line (its normal, colour and texture coordinate when the
// header announces them), one polygon per line, fan-triangulated. Declared
// counts are checked against the file size and never used to size memory. docs/formats.md.
#include <string>
#include <string_view>

#include "format/mesh_batcher.h"
#include "format/mesh_reader.h"
#include "format/text_scan.h"

namespace gaussmesh::format {
namespace {

using text::LineScanner;
using text::NumberError;

// What the header keyword says about each vertex line: the position, then (Geomview's order)
// a normal for "N", a colour for "C", a texture coordinate for "ST".
struct OffHeader {
  bool homogeneous = false;  // "4OFF": x y z w, position = (x, y, z) / w
  bool dimension_line = false;  // "nOFF": a dimension follows the keyword
  AttributeKinds attributes;
};

// Parses "[ST][C][N][4][n]OFF" (ASCII case as Geomview writes it); false if it is not one.
bool parse_keyword(std::string_view keyword, OffHeader& header) {
  size_t i = 0;
  auto take = [&](std::string_view prefix) {
    if (keyword.substr(i, prefix.size()) == prefix) {
      i += prefix.size();
      return true;
    }
    return false;
  };
  header.attributes.texcoords = take("ST");
  header.attributes.colors = take("C");
  header.attributes.normals = take("N");
  header.homogeneous = take("4");
  header.dimension_line = take("n");
  return keyword.substr(i) == "OFF";
}

// Smallest number of bytes V vertex lines and F face lines can take ("0 0 0\n", "3 0 0 0\n"),
// saturating instead of overflowing.
uint64_t min_body_bytes(uint64_t vertices, uint64_t faces) {
  constexpr uint64_t kMax = ~uint64_t{0};
  uint64_t v = vertices > kMax / 6 ? kMax : vertices * 6;
  uint64_t f = faces > kMax / 8 ? kMax : faces * 8;
  return v > kMax - f ? kMax : v + f;
}

class OffReader {
 public:
  OffReader(ByteSource& source, const ReadOptions& options, MeshSink& sink)
      : source_(source), batcher_(sink, options.batch_size), sink_(sink) {}

  Status run() {
    GM_RETURN_IF_ERROR(read_header());
    GM_RETURN_IF_ERROR(read_vertices());
    GM_RETURN_IF_ERROR(read_faces());
    GM_RETURN_IF_ERROR(check_trailer());
    GM_RETURN_IF_ERROR(batcher_.finish());
    return sink_.on_end();
  }

 private:
  Result<std::optional<std::string_view>> next() { return text::next_data_line(source_); }

  Status read_header() {
    Result<std::optional<std::string_view>> line = next();
    GM_RETURN_IF_ERROR(line.status());
    if (!line->has_value()) {
      return Status::error(Code::kBadInput, source_.name(), "input is empty: no OFF header");
    }
    LineScanner scan(**line);
    std::string_view keyword = scan.token();
    if (!parse_keyword(keyword, header_)) {
      return source_.bad_at_line("expected an OFF header ([ST][C][N][4][n]OFF), found " +
                                 text::quote(keyword));
    }
    // "nOFF" puts the vertex dimension next, on this line or the following one.
    if (header_.dimension_line) {
      if (scan.at_end()) {
        line = next();
        GM_RETURN_IF_ERROR(line.status());
        if (!line->has_value()) return source_.bad_at_line("file ends before the nOFF dimension");
        scan = LineScanner(**line);
      }
      uint64_t dimension = 0;
      NumberError e = scan.read_uint(dimension);
      if (e != NumberError::kOk) {
        return source_.bad_at_line(text::number_problem(e, "nOFF dimension", scan.last_token()));
      }
      if (dimension != 3) {
        return source_.bad_at_line("nOFF dimension " + std::to_string(dimension) +
                                   " is not supported (only 3)");
      }
    }
    if (text::equals_nocase(scan.peek_token(), "BINARY")) {
      return source_.bad_at_line("binary OFF is not supported (convert it to ascii OFF or PLY)");
    }
    // Counts follow on the same line ("OFF 8 6 0") or on the next data line.
    if (scan.at_end()) {
      line = next();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) {
        return source_.bad_at_line("file ends before the vertex and face counts");
      }
      scan = LineScanner(**line);
    }
    uint64_t edges = 0;
    NumberError e = scan.read_uint(vertices_);
    if (e != NumberError::kOk) {
      return source_.bad_at_line(text::number_problem(e, "vertex count", scan.last_token()));
    }
    e = scan.read_uint(faces_);
    if (e != NumberError::kOk) {
      return source_.bad_at_line(text::number_problem(e, "face count", scan.last_token()));
    }
    e = scan.read_uint(edges);  // optional and unused
    if (e != NumberError::kOk && e != NumberError::kMissing) {
      return source_.bad_at_line(text::number_problem(e, "edge count", scan.last_token()));
    }
    if (!scan.at_end()) {
      return source_.bad_at_line("unexpected " + text::quote(scan.token()) +
                                 " after the counts (expected V F [E])");
    }
    // Hostile or broken headers fail here, before any work sized by them.
    if (std::optional<uint64_t> size = source_.total_size()) {
      uint64_t left = *size >= source_.offset() ? *size - source_.offset() : 0;
      uint64_t need = min_body_bytes(vertices_, faces_);
      if (need > left + 1) {  // + 1: the last line may lack its newline
        return source_.bad_at_line("declares " + std::to_string(vertices_) + " vertices and " +
                                   std::to_string(faces_) + " faces, which need at least " +
                                   std::to_string(need) + " bytes, but only " +
                                   std::to_string(left) + " bytes follow (truncated file or wrong counts)");
      }
    }
    if (vertices_ > kMaxVertices) {
      return source_.bad_at_line("declares " + std::to_string(vertices_) +
                                 " vertices; at most " + std::to_string(kMaxVertices) +
                                 " are supported");
    }
    MeshHeader header;
    header.format = MeshFormat::kOff;
    header.declared_vertices = vertices_;
    header.declared_faces = faces_;
    header.attributes = header_.attributes;
    batcher_.set_with_attributes(header.attributes.any());
    return sink_.on_header(header);
  }

  Status read_vertices() {
    const size_t coordinates = header_.homogeneous ? 4 : 3;
    for (uint64_t i = 0; i < vertices_; ++i) {
      Result<std::optional<std::string_view>> line = next();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) {
        return source_.bad_at_line("file ends after " + std::to_string(i) + " of " +
                                   std::to_string(vertices_) + " vertices");
      }
      LineScanner scan(**line);
      float c[4] = {0, 0, 0, 1};
      for (size_t k = 0; k < coordinates; ++k) {
        NumberError e = scan.read_float(c[k]);
        if (e != NumberError::kOk) {
          return source_.bad_at_line(text::number_problem(
              e, "vertex " + std::to_string(i) + " coordinate " + std::to_string(k + 1),
              scan.last_token()));
        }
      }
      VertexAttributes attributes;
      GM_RETURN_IF_ERROR(read_attributes(scan, i, attributes));
      Vec3f p{c[0], c[1], c[2]};
      if (header_.homogeneous) {
        if (c[3] == 0) {
          return source_.bad_at_line("vertex " + std::to_string(i) + " has w = 0 (a point at infinity)");
        }
        p = Vec3f{c[0] / c[3], c[1] / c[3], c[2] / c[3]};
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
          return source_.bad_at_line("vertex " + std::to_string(i) + ": x/w, y/w, z/w overflow");
        }
      }
      GM_RETURN_IF_ERROR(batcher_.add_vertex(p, attributes));
    }
    return {};
  }

  // The values after the position that the header announces: a normal (3 numbers), a colour
  // (3 or 4: the numbers left before a texture coordinate; integers are 0..255, numbers with a
  // point or an exponent 0..1), a texture coordinate (2). Anything after them is ignored.
  Status read_attributes(LineScanner& scan, uint64_t vertex, VertexAttributes& out) {
    const AttributeKinds& kinds = header_.attributes;
    auto number = [&](const char* what, float& value) -> Status {
      NumberError e = scan.read_float(value);
      if (e == NumberError::kOk) return {};
      return source_.bad_at_line(text::number_problem(e, "vertex " + std::to_string(vertex) + " " + what, scan.last_token()));
    };
    if (kinds.normals) {
      for (float* n : {&out.normal.x, &out.normal.y, &out.normal.z}) GM_RETURN_IF_ERROR(number("normal", *n));
    }
    if (kinds.colors) {
      std::string_view tokens[8];
      size_t count = 0;
      for (LineScanner ahead = scan; count < 8;) {
        std::string_view t = ahead.token();
        if (t.empty()) break;
        tokens[count++] = t;
      }
      const size_t channels = count >= (kinds.texcoords ? 6u : 4u) ? 4 : 3;
      bool bytes = true;
      for (size_t k = 0; k < channels && k < count; ++k) {
        if (tokens[k].find_first_of(".eEnN") != std::string_view::npos) bytes = false;
      }
      float rgba[4] = {0, 0, 0, 1};
      for (size_t k = 0; k < channels; ++k) GM_RETURN_IF_ERROR(number("colour", rgba[k]));
      const float divisor = bytes ? 255.0f : 1.0f;
      out.color = {rgba[0] / divisor, rgba[1] / divisor, rgba[2] / divisor, channels == 4 ? rgba[3] / divisor : 1.0f};
    }
    if (kinds.texcoords) {
      GM_RETURN_IF_ERROR(number("texture coordinate", out.texcoord.u));
      GM_RETURN_IF_ERROR(number("texture coordinate", out.texcoord.v));
    }
    return {};
  }

  Status read_faces() {
    for (uint64_t f = 0; f < faces_; ++f) {
      Result<std::optional<std::string_view>> line = next();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) {
        return source_.bad_at_line("file ends after " + std::to_string(f) + " of " +
                                   std::to_string(faces_) + " faces");
      }
      LineScanner scan(**line);
      uint64_t n = 0;
      NumberError e = scan.read_uint(n);
      if (e != NumberError::kOk) {
        return source_.bad_at_line(
            text::number_problem(e, "face " + std::to_string(f) + " vertex count", scan.last_token()));
      }
      if (n < 3) {
        return source_.bad_at_line("face " + std::to_string(f) + " has " + std::to_string(n) +
                                   " vertices; a face needs at least 3");
      }
      VertexIndex first = 0, previous = 0;
      for (uint64_t k = 0; k < n; ++k) {
        uint64_t index = 0;
        e = scan.read_uint(index);
        if (e == NumberError::kMissing) {
          return source_.bad_at_line("face " + std::to_string(f) + " declares " + std::to_string(n) +
                                     " vertices but lists " + std::to_string(k));
        }
        if (e != NumberError::kOk) {
          return source_.bad_at_line(
              text::number_problem(e, "face " + std::to_string(f) + " vertex index", scan.last_token()));
        }
        if (index >= vertices_) {
          return source_.bad_at_line("face " + std::to_string(f) + " refers to vertex " +
                                     std::to_string(index) + " but the file has " +
                                     std::to_string(vertices_) + " vertices (indices start at 0)");
        }
        VertexIndex v = static_cast<VertexIndex>(index);
        if (k == 0) {
          first = v;
        } else if (k >= 2) {
          GM_RETURN_IF_ERROR(batcher_.add_triangle(first, previous, v));
        }
        previous = v;
      }
      // Anything after the indices is a face colour: ignored.
    }
    return {};
  }

  // Data after the last declared face means the counts do not describe the file.
  Status check_trailer() {
    Result<std::optional<std::string_view>> line = next();
    GM_RETURN_IF_ERROR(line.status());
    if (line->has_value()) {
      return source_.bad_at_line("unexpected data after the " + std::to_string(faces_) +
                                 " declared faces (wrong counts in the header?)");
    }
    return {};
  }

  ByteSource& source_;
  MeshBatcher batcher_;
  MeshSink& sink_;
  OffHeader header_;
  uint64_t vertices_ = 0;
  uint64_t faces_ = 0;
};

}  // namespace

Status read_off(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  OffReader reader(source, options, sink);
  return reader.run();
}

}  // namespace gaussmesh::format
