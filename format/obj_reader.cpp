// Streaming Wavefront OBJ reader: "v" positions and "f" polygons (v, v/vt, v//vn, v/vt/vn,
// negative relative indices), fan-triangulated; every other statement is ignored. Vertices and
// faces may interleave: pending vertices are delivered before a triangle that uses them.
// docs/formats.md.
#include <string>
#include <string_view>

#include "format/mesh_batcher.h"
#include "format/mesh_reader.h"
#include "format/text_scan.h"

namespace gaussmesh::format {
namespace {

using text::LineScanner;
using text::NumberError;

class ObjReader {
 public:
  ObjReader(ByteSource& source, const ReadOptions& options, MeshSink& sink)
      : source_(source), batcher_(sink, options.batch_size), sink_(sink) {}

  Status run() {
    MeshHeader header;
    header.format = MeshFormat::kObj;
    GM_RETURN_IF_ERROR(sink_.on_header(header));
    for (;;) {
      Result<std::optional<std::string_view>> line = source_.next_line();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) break;
      statement_line_ = source_.line_number();
      std::string_view statement = **line;
      if (!statement.empty() && statement.back() == '\\') {
        Result<std::string_view> joined = join_continued(statement);
        GM_RETURN_IF_ERROR(joined.status());
        statement = *joined;
      }
      GM_RETURN_IF_ERROR(parse_statement(statement));
    }
    if (batcher_.vertex_count() == 0) {
      if (source_.line_number() == 0) {
        return Status::error(Code::kBadInput, source_.name(), "input is empty: no OBJ data");
      }
      return Status::error(Code::kBadInput, source_.name(), "no vertices ('v' statements) found");
    }
    GM_RETURN_IF_ERROR(batcher_.finish());
    return sink_.on_end();
  }

 private:
  // "a \" newline "b" is one statement "a  b". Rare, so it may allocate (once, then reuse).
  Result<std::string_view> join_continued(std::string_view first) {
    joined_.assign(first.substr(0, first.size() - 1));
    for (;;) {
      Result<std::optional<std::string_view>> line = source_.next_line();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) break;  // a final backslash continues nothing
      std::string_view more = **line;
      if (joined_.size() + more.size() > ByteSource::kMaxWindow) {
        return bad("statement continued with '\\' over more than " +
                   std::to_string(ByteSource::kMaxWindow >> 20) + " MiB");
      }
      joined_ += ' ';
      if (!more.empty() && more.back() == '\\') {
        joined_.append(more.substr(0, more.size() - 1));
        continue;
      }
      joined_.append(more);
      break;
    }
    return std::string_view(joined_);
  }

  Status bad(std::string message) const {
    return Status::error(Code::kBadInput, source_.name() + ":" + std::to_string(statement_line_),
                         std::move(message));
  }

  Status parse_statement(std::string_view statement) {
    LineScanner scan(statement);
    scan.skip_space();
    char c = scan.peek();
    if (c != 'v' && c != 'f') return {};  // comments, blank lines, o, g, s, usemtl, l, p, ...
    std::string_view keyword = scan.token();
    if (keyword != "v" && keyword != "f") return {};  // vt, vn, vp, and anything else
    LineScanner data(text::strip_comment(scan.rest()));
    return keyword == "v" ? parse_vertex(data) : parse_face(data);
  }

  Status parse_vertex(LineScanner& scan) {
    // Only the three coordinates are read; w or vertex colours after them are ignored.
    float c[3];
    for (int k = 0; k < 3; ++k) {
      NumberError e = scan.read_float(c[k]);
      if (e != NumberError::kOk) {
        static constexpr const char* kAxis[3] = {"x", "y", "z"};
        return bad(text::number_problem(e, std::string("vertex ") + kAxis[k], scan.last_token()));
      }
    }
    if (batcher_.vertex_count() >= kMaxVertices) {
      return bad("more than " + std::to_string(kMaxVertices) + " vertices are not supported");
    }
    return batcher_.add_vertex(Vec3f{c[0], c[1], c[2]});
  }

  // Resolves one face corner "i", "i/t", "i//n" or "i/t/n" to a 0-based vertex index.
  Status parse_corner(LineScanner& scan, VertexIndex& out) {
    int64_t index = 0;
    NumberError e = scan.read_int_prefix(index);
    if (e != NumberError::kOk) return bad(text::number_problem(e, "face vertex index", scan.last_token()));
    if (!scan.at_token_end()) {
      if (scan.peek() != '/') {
        return bad("face vertex index: " + text::quote(scan.last_token()) +
                   " is followed by an unexpected character");
      }
      scan.skip_token();  // texture and normal indices are not used
    }
    uint64_t count = batcher_.vertex_count();
    if (index > 0) {
      if (static_cast<uint64_t>(index) > count) {
        return bad("face refers to vertex " + std::to_string(index) + " but only " +
                   std::to_string(count) + " vertices are defined so far");
      }
      out = static_cast<VertexIndex>(index - 1);
      return {};
    }
    if (index == 0) return bad("face vertex index 0 is invalid (OBJ indices start at 1)");
    uint64_t back = static_cast<uint64_t>(-(index + 1)) + 1;  // |index| without overflow
    if (back > count) {
      return bad("face refers to relative vertex " + std::to_string(index) + " but only " +
                 std::to_string(count) + " vertices are defined so far");
    }
    out = static_cast<VertexIndex>(count - back);
    return {};
  }

  Status parse_face(LineScanner& scan) {
    VertexIndex first = 0, previous = 0;
    size_t corners = 0;
    for (;;) {
      scan.skip_space();
      if (scan.at_end()) break;
      VertexIndex v = 0;
      GM_RETURN_IF_ERROR(parse_corner(scan, v));
      if (corners == 0) {
        first = v;
      } else if (corners >= 2) {
        GM_RETURN_IF_ERROR(batcher_.add_triangle(first, previous, v));
      }
      previous = v;
      ++corners;
    }
    if (corners < 3) {
      return bad("face has " + std::to_string(corners) + " vertices; a face needs at least 3");
    }
    return {};
  }

  ByteSource& source_;
  MeshBatcher batcher_;
  MeshSink& sink_;
  uint64_t statement_line_ = 0;
  std::string joined_;
};

}  // namespace

Status read_obj(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  ObjReader reader(source, options, sink);
  return reader.run();
}

}  // namespace gaussmesh::format
