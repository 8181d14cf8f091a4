// Streaming Wavefront OBJ reader: "v" positions, with colours when the first one has them
// ("v x y z r g b", as MeshLab and Blender write them), and "f" polygons (v, v/vt, v//vn,
// v/vt/vn, negative relative indices), fan-triangulated; every other statement is ignored.
// Vertices and faces may interleave: pending vertices are delivered before a triangle that uses
// them. vt and vn are named as not kept, unless the caller asks for corner values
// (ReadOptions::corner_values): the file is then held, and each distinct (v, vt, vn) triple its
// faces use becomes a vertex. docs/formats.md.
#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

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
      : source_(source), batcher_(sink, options.batch_size, colors), sink_(sink), colors_(colors),
        held_(options.corner_values), memory_limit_(options.memory_limit), batch_size_(options.batch_size) {}

  Status run() {
    if (!held_) {
      MeshHeader header;
      header.format = MeshFormat::kObj;
      header.attributes.colors = colors_;
      GM_RETURN_IF_ERROR(sink_.on_header(header));
    }
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
    if (vertex_count() == 0) {
      if (source_.line_number() == 0) {
        return Status::error(Code::kBadInput, source_.name(), "input is empty: no OBJ data");
      }
      return Status::error(Code::kBadInput, source_.name(), "no vertices ('v' statements) found");
    }
    if (held_) return deliver_held();
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
    if (keyword == "vt" || keyword == "vn") {
      if (!held_) return name_ignored(keyword == "vt" ? named_vt_ : named_vn_, keyword);
      LineScanner data(text::strip_comment(scan.rest()));
      return keyword == "vt" ? parse_texcoord(data) : parse_normal(data);
    }
    if (keyword != "v" && keyword != "f") return {};  // vp, and anything else
    LineScanner data(text::strip_comment(scan.rest()));
    return keyword == "v" ? parse_vertex(data) : parse_face(data);
  }

  Status name_ignored(bool& named, std::string_view keyword) {
    if (named) return {};
    named = true;
    return ignored(keyword == "vt" ? "texture coordinates (vt; simplify keeps them in core: --engine in-core)" : "normals (vn; simplify keeps them in core: --engine in-core)");
  }

  // MeshSink::on_ignored, kept until the header when the file is held.
  Status ignored(std::string what) {
    if (!held_) return sink_.on_ignored(what);
    pending_ignored_.push_back(std::move(what));
    return {};
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
    if (vertex_count() >= kMaxVertices) {
      return bad("more than " + std::to_string(kMaxVertices) + " vertices are not supported");
    }
    if (!colors_) {
      float more[3];
      if (!named_colors_ && scan.read_float(more[0]) == NumberError::kOk && scan.read_float(more[1]) == NumberError::kOk &&
          scan.read_float(more[2]) == NumberError::kOk) {
        named_colors_ = true;
        GM_RETURN_IF_ERROR(ignored("vertex colours that start after the first vertex (v x y z r g b)"));
      }
      return add_vertex(Vec3f{c[0], c[1], c[2]}, nullptr);
    }
    VertexAttributes attributes;
    attributes.color = {c[3], c[4], c[5], 1};
    return add_vertex(Vec3f{c[0], c[1], c[2]}, &attributes);
  }

  uint64_t vertex_count() const { return held_ ? positions_.size() : batcher_.vertex_count(); }

  Status add_vertex(const Vec3f& p, const VertexAttributes* attributes) {
    if (!held_) return attributes ? batcher_.add_vertex(p, *attributes) : batcher_.add_vertex(p);
    positions_.push_back(p);
    if (attributes) colors_held_.push_back(attributes->color);
    return check_held();
  }

  // "vt u [v [w]]": v defaults to 0, w is ignored.
  Status parse_texcoord(LineScanner& scan) {
    float u = 0, v = 0;
    NumberError e = scan.read_float(u);
    if (e != NumberError::kOk) return bad(text::number_problem(e, "texture coordinate u", scan.last_token()));
    e = scan.read_float(v);
    if (e != NumberError::kOk && e != NumberError::kMissing) {
      return bad(text::number_problem(e, "texture coordinate v", scan.last_token()));
    }
    texcoords_.push_back({u, v});
    return check_held();
  }

  Status parse_normal(LineScanner& scan) {
    float n[3];
    for (int k = 0; k < 3; ++k) {
      NumberError e = scan.read_float(n[k]);
      if (e != NumberError::kOk) {
        static constexpr const char* kValue[3] = {"normal x", "normal y", "normal z"};
        return bad(text::number_problem(e, kValue[k], scan.last_token()));
      }
    }
    normals_.push_back({n[0], n[1], n[2]});
    return check_held();
  }

  // What the held lists take; over memory_limit the read stops (kResources, one line).
  Status check_held() const {
    if (memory_limit_ == 0) return {};
    const uint64_t bytes = positions_.capacity() * sizeof(Vec3f) + colors_held_.capacity() * sizeof(Color) +
                           texcoords_.capacity() * sizeof(Vec2f) + normals_.capacity() * sizeof(Vec3f) +
                           corners_.capacity() * sizeof(Corner);
    if (bytes <= memory_limit_) return {};
    return Status::error(Code::kResources, source_.name() + ":" + std::to_string(statement_line_),
                         "holding this OBJ's vertices, texture coordinates, normals and faces needs more than the --memory "
                         "budget of " + std::to_string(memory_limit_ >> 20) + " MiB");
  }

  static constexpr uint32_t kNoValue = UINT32_MAX;

  // A face corner: its v, and its vt and vn (kNoValue when the corner has none), 0-based.
  struct Corner {
    VertexIndex v = 0;
    uint32_t t = kNoValue, n = kNoValue;
  };

  // The distinct corners, numbered in the order they first appear. Most positions have one
  // (vt, vn): each position's first corner is found through a table by position; the others (at
  // seams) through an open-addressing table of ids, at most half full, over the distinct corners
  // themselves. No allocation per entry, and faces in file order read the first table nearly in
  // order.
  class CornerIds {
   public:
    explicit CornerIds(std::size_t positions) : first_(positions, kEmpty) {}
    // c's number, and whether c is new.
    std::pair<VertexIndex, bool> insert(const Corner& c) {
      uint32_t& first = first_[c.v];
      if (first == kEmpty) {
        first = add(c);
        return {first, true};
      }
      if (same(distinct_[first], c)) return {first, false};
      if (2 * (others_ + 1) > slots_.size()) grow();
      for (std::size_t i = slot_of(c);; i = (i + 1) & (slots_.size() - 1)) {
        const uint32_t id = slots_[i];
        if (id == kEmpty) {
          ++others_;
          slots_[i] = add(c);
          return {slots_[i], true};
        }
        if (same(distinct_[id], c)) return {id, false};
      }
    }
    std::size_t size() const { return distinct_.size(); }

   private:
    static constexpr uint32_t kEmpty = UINT32_MAX;
    static bool same(const Corner& a, const Corner& b) { return a.v == b.v && a.t == b.t && a.n == b.n; }
    uint32_t add(const Corner& c) {
      distinct_.push_back(c);
      return static_cast<uint32_t>(distinct_.size() - 1);
    }
    std::size_t slot_of(const Corner& c) const {
      uint64_t h = (uint64_t(c.v) << 32 | c.t) ^ (uint64_t(c.n) * 0x9E3779B97F4A7C15ull);
      h ^= h >> 31, h *= 0xBF58476D1CE4E5B9ull, h ^= h >> 29, h *= 0x94D049BB133111EBull, h ^= h >> 32;
      return static_cast<std::size_t>(h) & (slots_.size() - 1);
    }
    // Twice the slots, the others (not first at their position) placed again.
    void grow() {
      slots_.assign(std::max<std::size_t>(2 * slots_.size(), 1024), kEmpty);
      for (uint32_t id = 0; id < distinct_.size(); ++id) {
        if (first_[distinct_[id].v] == id) continue;
        std::size_t i = slot_of(distinct_[id]);
        while (slots_[i] != kEmpty) i = (i + 1) & (slots_.size() - 1);
        slots_[i] = id;
      }
    }
    std::vector<uint32_t> first_, slots_;
    std::vector<Corner> distinct_;
    std::size_t others_ = 0;
  };

  // Resolves a 1-based or negative (relative) OBJ index into a list of `count` entries.
  Status resolve(int64_t index, uint64_t count, const char* what, const char* whats, uint32_t& out) const {
    if (index > 0) {
      if (static_cast<uint64_t>(index) > count) {
        return bad(std::string("face refers to ") + what + " " + std::to_string(index) + " but only " +
                   std::to_string(count) + " " + whats + " are defined so far");
      }
      out = static_cast<uint32_t>(index - 1);
      return {};
    }
    if (index == 0) return bad(std::string("face ") + what + " index 0 is invalid (OBJ indices start at 1)");
    uint64_t back = static_cast<uint64_t>(-(index + 1)) + 1;  // |index| without overflow
    if (back > count) {
      return bad(std::string("face refers to relative ") + what + " " + std::to_string(index) + " but only " +
                 std::to_string(count) + " " + whats + " are defined so far");
    }
    out = static_cast<uint32_t>(count - back);
    return {};
  }

  // One face corner "i", "i/t", "i//n" or "i/t/n". The texture and normal indices are read only
  // when the file is held (corner values); otherwise they are skipped.
  Status parse_corner(LineScanner& scan, Corner& out) {
    int64_t index = 0;
    NumberError e = scan.read_int_prefix(index);
    if (e != NumberError::kOk) return bad(text::number_problem(e, "face vertex index", scan.last_token()));
    GM_RETURN_IF_ERROR(resolve(index, vertex_count(), "vertex", "vertices", out.v));
    if (scan.at_token_end()) return {};
    if (scan.peek() != '/') {
      return bad("face vertex index: " + text::quote(scan.last_token()) + " is followed by an unexpected character");
    }
    if (!held_) {
      scan.skip_token();
      return {};
    }
    scan.advance();
    if (scan.peek() != '/' && !scan.at_token_end()) {
      e = scan.read_int_prefix(index);
      if (e != NumberError::kOk) return bad(text::number_problem(e, "face texture coordinate index", scan.last_token()));
      GM_RETURN_IF_ERROR(resolve(index, texcoords_.size(), "texture coordinate", "texture coordinates", out.t));
    }
    if (scan.at_token_end()) return {};
    if (scan.peek() != '/') return bad("face corner: a texture coordinate index is followed by an unexpected character");
    scan.advance();
    if (scan.at_token_end()) return {};
    e = scan.read_int_prefix(index);
    if (e != NumberError::kOk) return bad(text::number_problem(e, "face normal index", scan.last_token()));
    GM_RETURN_IF_ERROR(resolve(index, normals_.size(), "normal", "normals", out.n));
    if (!scan.at_token_end()) return bad("face corner: a normal index is followed by an unexpected character");
    return {};
  }

  Status parse_face(LineScanner& scan) {
    Corner first, previous;
    size_t corners = 0;
    for (;;) {
      scan.skip_space();
      if (scan.at_end()) break;
      Corner c;
      GM_RETURN_IF_ERROR(parse_corner(scan, c));
      if (corners == 0) {
        first = c;
      } else if (corners >= 2) {
        if (held_) {
          corners_.insert(corners_.end(), {first, previous, c});
          GM_RETURN_IF_ERROR(check_held());
        } else {
          GM_RETURN_IF_ERROR(batcher_.add_triangle(first.v, previous.v, c.v));
        }
      }
      previous = c;
      ++corners;
    }
    if (corners < 3) {
      return bad("face has " + std::to_string(corners) + " vertices; a face needs at least 3");
    }
    return {};
  }

  // The held file's delivery: one vertex per distinct (v, vt, vn) triple, in the order the faces
  // first use them, then the faces over them. Without any vt or vn in a face, the vertices as the
  // file lists them (the streamed reading's result). A corner without a vt or vn in a file whose
  // other corners have them takes (0, 0) or (0, 0, 0).
  Status deliver_held() {
    bool with_t = false, with_n = false;
    for (const Corner& c : corners_) with_t |= c.t != kNoValue, with_n |= c.n != kNoValue;
    if (!texcoords_.empty() && !with_t) pending_ignored_.push_back("texture coordinates (vt) no face uses");
    if (!normals_.empty() && !with_n) pending_ignored_.push_back("normals (vn) no face uses");
    MeshHeader header;
    header.format = MeshFormat::kObj;
    header.attributes = {with_n, colors_, with_t};
    GM_RETURN_IF_ERROR(sink_.on_header(header));
    for (const std::string& what : pending_ignored_) GM_RETURN_IF_ERROR(sink_.on_ignored(what));
    MeshBatcher batcher(sink_, batch_size_, header.attributes.any());
    auto attributes_of = [&](const Corner& c) {
      VertexAttributes a;
      if (colors_) a.color = colors_held_[c.v];
      if (c.t != kNoValue) a.texcoord = texcoords_[c.t];
      if (c.n != kNoValue) a.normal = normals_[c.n];
      return a;
    };
    if (!with_t && !with_n) {
      for (std::size_t v = 0; v < positions_.size(); ++v)
        GM_RETURN_IF_ERROR(batcher.add_vertex(positions_[v], attributes_of(Corner{VertexIndex(v)})));
      for (std::size_t i = 0; i < corners_.size(); i += 3)
        GM_RETURN_IF_ERROR(batcher.add_triangle(corners_[i].v, corners_[i + 1].v, corners_[i + 2].v));
    } else {
      CornerIds ids(positions_.size());
      VertexIndex t[3];
      for (std::size_t i = 0; i < corners_.size(); ++i) {
        const auto [id, added] = ids.insert(corners_[i]);
        if (added) {
          if (ids.size() > kMaxVertices) {
            return Status::error(Code::kBadInput, source_.name(),
                                 "more than " + std::to_string(kMaxVertices) + " distinct face corners are not supported");
          }
          GM_RETURN_IF_ERROR(batcher.add_vertex(positions_[corners_[i].v], attributes_of(corners_[i])));
        }
        t[i % 3] = id;
        if (i % 3 == 2) GM_RETURN_IF_ERROR(batcher.add_triangle(t[0], t[1], t[2]));
      }
    }
    GM_RETURN_IF_ERROR(batcher.finish());
    return sink_.on_end();
  }

  ByteSource& source_;
  MeshBatcher batcher_;
  MeshSink& sink_;
  const bool colors_;
  const bool held_;  // ReadOptions::corner_values: the file is held, then delivered
  const uint64_t memory_limit_;
  const size_t batch_size_;
  std::vector<Vec3f> positions_;
  std::vector<Color> colors_held_;
  std::vector<Vec2f> texcoords_;
  std::vector<Vec3f> normals_;
  std::vector<Corner> corners_;  // three per triangle
  std::vector<std::string> pending_ignored_;
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
