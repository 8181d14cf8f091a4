// Streaming Wavefront OBJ reader: "v" positions, with colours when the first one has them
// ("v x y z r g b", as MeshLab and Blender write them), and "f" polygons (v, v/vt, v//vn,
// v/vt/vn, negative relative indices), fan-triangulated; vt and vn are named as not kept, every
// other statement is ignored. Vertices and faces may interleave: pending vertices are delivered
// before a triangle that uses them. docs/formats.md.
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
  ObjReader(ByteSource& source, const ReadOptions& options, MeshSink& sink, bool colors)
      : source_(source), batcher_(sink, options.batch_size, colors), sink_(sink), colors_(colors) {}

  Status run() {
    MeshHeader header;
    header.format = MeshFormat::kObj;
    header.attributes.colors = colors_;
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
    if (keyword == "vt" || keyword == "vn") return name_ignored(keyword == "vt" ? named_vt_ : named_vn_, keyword);
    if (keyword != "v" && keyword != "f") return {};  // vp, and anything else
    LineScanner data(text::strip_comment(scan.rest()));
    return keyword == "v" ? parse_vertex(data) : parse_face(data);
  }

  Status name_ignored(bool& named, std::string_view keyword) {
    if (named) return {};
    named = true;
    return sink_.on_ignored(keyword == "vt" ? "texture coordinates (vt)" : "normals (vn)");
  }

  Status parse_vertex(LineScanner& scan) {
    // Three coordinates, then a colour when the first vertex had one; a w (one number) or a
    // colour when the first vertex had none is ignored.
    float c[6];
    const int count = colors_ ? 6 : 3;
    for (int k = 0; k < count; ++k) {
      NumberError e = scan.read_float(c[k]);
      if (e != NumberError::kOk) {
        static constexpr const char* kValue[6] = {"x", "y", "z", "red", "green", "blue"};
        if (k >= 3 && e == NumberError::kMissing) {
          return bad("vertex has no colour, and the first vertex had one (v x y z r g b)");
        }
        return bad(text::number_problem(e, std::string("vertex ") + kValue[k], scan.last_token()));
      }
    }
    if (batcher_.vertex_count() >= kMaxVertices) {
      return bad("more than " + std::to_string(kMaxVertices) + " vertices are not supported");
    }
    if (!colors_) {
      float more[3];
      if (!named_colors_ && scan.read_float(more[0]) == NumberError::kOk && scan.read_float(more[1]) == NumberError::kOk &&
          scan.read_float(more[2]) == NumberError::kOk) {
        named_colors_ = true;
        GM_RETURN_IF_ERROR(sink_.on_ignored("vertex colours that start after the first vertex (v x y z r g b)"));
      }
      return batcher_.add_vertex(Vec3f{c[0], c[1], c[2]});
    }
    VertexAttributes attributes;
    attributes.color = {c[3], c[4], c[5], 1};
    return batcher_.add_vertex(Vec3f{c[0], c[1], c[2]}, attributes);
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
  const bool colors_;
  bool named_vt_ = false, named_vn_ = false, named_colors_ = false;
  uint64_t statement_line_ = 0;
  std::string joined_;
};

// Whether the first vertex statement within the first window holds six numbers (a position
// and a colour). A file whose first vertex lies further in is read without colours.
Result<bool> first_vertex_has_colour(ByteSource& source) {
  Result<size_t> got = source.ensure(ByteSource::kMaxWindow);
  GM_RETURN_IF_ERROR(got.status());
  std::string_view window(source.cursor(), *got);
  for (std::size_t at = 0; at < window.size();) {
    std::size_t end = window.find('\n', at);
    if (end == std::string_view::npos) return false;  // the line runs past the window
    LineScanner scan(window.substr(at, end - at));
    if (scan.token() == "v") {
      LineScanner data(text::strip_comment(scan.rest()));
      int numbers = 0;
      float value = 0;
      while (data.read_float(value) == NumberError::kOk) ++numbers;
      return numbers == 6 && data.at_end();
    }
    at = end + 1;
  }
  return false;
}

}  // namespace

Status read_obj(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  Result<bool> colors = first_vertex_has_colour(source);
  GM_RETURN_IF_ERROR(colors.status());
  ObjReader reader(source, options, sink, *colors);
  return reader.run();
}

}  // namespace gaussmesh::format
