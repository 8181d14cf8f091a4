// Mesh input entry points: format detection from the first bytes (never consuming them, so
// it works on stdin), format names and extensions, and dispatch to the per-format readers.
#include "format/mesh_reader.h"

#include <algorithm>
#include <string>

#include "format/stl_reader.h"
#include "format/text_scan.h"

namespace gaussmesh::format {
namespace {

// How much of the input detection may look at. OBJ files can open with long comment
// blocks; a first statement further in than this needs an explicit format.
constexpr size_t kDetectBytes = 64u << 10;

bool starts_with(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && s.substr(0, prefix.size()) == prefix;
}

bool is_off_keyword(std::string_view token) {
  // [ST][C][N][4][n]OFF, as off_reader.cpp parses it.
  for (std::string_view prefix : {"ST", "C", "N", "4", "n"}) {
    if (starts_with(token, prefix)) token.remove_prefix(prefix.size());
  }
  return token == "OFF";
}

bool is_obj_statement(std::string_view keyword) {
  static constexpr std::string_view kStatements[] = {
      "v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "usemtl", "mtllib", "cstype",
      "deg", "curv", "curv2", "surf", "mg", "lod", "maplib", "usemap", "shadow_obj", "trace_obj"};
  for (std::string_view s : kStatements) {
    if (keyword == s) return true;
  }
  return false;
}

// The first token of the first line that is neither blank nor a '#' comment, within head;
// empty if there is none.
std::string_view first_keyword(std::string_view head) {
  while (!head.empty()) {
    size_t eol = head.find('\n');
    std::string_view line = head.substr(0, eol);
    text::LineScanner scan(text::strip_comment(line));
    std::string_view token = scan.token();
    if (!token.empty()) return token;
    if (eol == std::string_view::npos) break;
    head.remove_prefix(eol + 1);
  }
  return {};
}

// A text encoding the readers do not take: UTF-32 or UTF-16 by their byte-order marks, or UTF-16
// without one (every other byte zero, the others ASCII text, over the first bytes). Empty when
// the head is none of these.
std::string unread_text_encoding(std::string_view head) {
  using namespace std::string_view_literals;
  if (starts_with(head, "\x00\x00\xFE\xFF"sv)) return "UTF-32 (big-endian byte-order mark)";
  if (starts_with(head, "\xFF\xFE\x00\x00"sv)) return "UTF-32 (little-endian byte-order mark)";
  if (starts_with(head, "\xFE\xFF"sv)) return "UTF-16 (big-endian byte-order mark)";
  if (starts_with(head, "\xFF\xFE"sv)) return "UTF-16 (little-endian byte-order mark)";
  constexpr size_t kLook = 512;
  size_t n = std::min(head.size(), kLook) & ~size_t{1};
  if (n < 16) return {};
  auto is_text = [](unsigned char c) { return (c >= 0x20 && c < 0x7f) || c == '\t' || c == '\n' || c == '\r'; };
  for (size_t zero : {size_t{0}, size_t{1}}) {
    bool pattern = true;
    for (size_t i = 0; i < n && pattern; i += 2) {
      pattern = head[i + zero] == '\0' && is_text(static_cast<unsigned char>(head[i + 1 - zero]));
    }
    if (pattern) return zero == 0 ? "UTF-16 (big-endian, no byte-order mark)" : "UTF-16 (little-endian, no byte-order mark)";
  }
  return {};
}

// Refuses a text encoding the readers do not take, naming it; steps over a UTF-8 byte-order mark
// in front of text (the rest reads the same). Binary formats are not looked at.
Status check_text_encoding(ByteSource& source, MeshFormat format) {
  if (format == MeshFormat::kStl || format == MeshFormat::kDraco) return {};
  Result<size_t> got = source.ensure(kDetectBytes);
  GM_RETURN_IF_ERROR(got.status());
  std::string_view head(source.cursor(), std::min(*got, kDetectBytes));
  std::string encoding = unread_text_encoding(head);
  if (!encoding.empty()) {
    return Status::error(Code::kBadInput, source.at_byte(0),
                         "text encoded as " + encoding +
                             ", which gaussmesh does not read: convert it to UTF-8 or ASCII first (iconv -f " +
                             encoding.substr(0, 6) + " -t UTF-8)");
  }
  constexpr std::string_view kUtf8Mark = "\xEF\xBB\xBF";
  if (starts_with(head, kUtf8Mark) && !looks_binary(head.substr(kUtf8Mark.size(), 4096))) source.advance(kUtf8Mark.size());
  return {};
}

Status unknown_format(const ByteSource& source) {
  return Status::error(Code::kBadInput, source.name(),
                       "unrecognised mesh format (not PLY, OFF, OBJ, STL or Draco); name it explicitly "
                       "if the content is one of these");
}

}  // namespace

Result<MeshFormat> detect_format(ByteSource& source) {
  Result<size_t> got = source.ensure(kDetectBytes);
  GM_RETURN_IF_ERROR(got.status());
  // Only the first kDetectBytes count, however much is buffered: the answer must not depend
  // on how the input arrives (file, pipe).
  std::string_view head(source.cursor(), std::min(*got, kDetectBytes));
  if (head.empty()) return MeshFormat::kUnknown;
  if (starts_with(head, "DRACO")) return MeshFormat::kDraco;
  if (starts_with(head, "ply") && head.size() > 3 && (head[3] == '\n' || head[3] == '\r')) {
    return MeshFormat::kPly;
  }
  // Text formats first: a text file's bytes 80..83 could, by a freak chance, read as a
  // binary STL count that matches its size.
  bool binary = looks_binary(head.substr(0, 4096));
  if (!binary) {
    std::string_view keyword = first_keyword(head);
    if (is_off_keyword(keyword)) return MeshFormat::kOff;
    if (is_obj_statement(keyword)) return MeshFormat::kObj;
  }
  Result<StlEncoding> stl = sniff_stl(source);
  GM_RETURN_IF_ERROR(stl.status());
  if (*stl != StlEncoding::kNotStl) return MeshFormat::kStl;
  // Binary STL with neither "solid" nor a size to check (a pipe, or a truncated file): the
  // only binary format without a magic number, so binary bytes past a full header mean STL.
  if (binary && head.size() >= 84) return MeshFormat::kStl;
  return MeshFormat::kUnknown;
}

MeshFormat parse_format_name(std::string_view name) {
  using text::equals_nocase;
  if (equals_nocase(name, "ply")) return MeshFormat::kPly;
  if (equals_nocase(name, "off")) return MeshFormat::kOff;
  if (equals_nocase(name, "obj")) return MeshFormat::kObj;
  if (equals_nocase(name, "stl")) return MeshFormat::kStl;
  if (equals_nocase(name, "drc") || equals_nocase(name, "draco")) return MeshFormat::kDraco;
  return MeshFormat::kUnknown;
}

MeshFormat format_from_extension(std::string_view path) {
  size_t slash = path.find_last_of('/');
  std::string_view base = slash == std::string_view::npos ? path : path.substr(slash + 1);
  size_t dot = base.find_last_of('.');
  if (dot == std::string_view::npos || dot == 0) return MeshFormat::kUnknown;
  return parse_format_name(base.substr(dot + 1));
}

Status read_mesh(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  MeshFormat format = options.format;
  GM_RETURN_IF_ERROR(check_text_encoding(source, format));
  if (format == MeshFormat::kUnknown) {
    Result<MeshFormat> detected = detect_format(source);
    GM_RETURN_IF_ERROR(detected.status());
    format = *detected;
    if (format == MeshFormat::kUnknown) {
      if (source.at_end()) {
        return Status::error(Code::kBadInput, source.name(), "input is empty: no mesh data");
      }
      // Content did not tell (e.g. an OBJ opening with a very long comment): trust the name.
      format = format_from_extension(source.name());
      if (format == MeshFormat::kUnknown) return unknown_format(source);
    }
  }
  switch (format) {
    case MeshFormat::kPly: return read_ply(source, options, sink);
    case MeshFormat::kOff: return read_off(source, options, sink);
    case MeshFormat::kObj: return read_obj(source, options, sink);
    case MeshFormat::kStl: return read_stl(source, options, sink);
    case MeshFormat::kDraco: return read_draco(source, options, sink);
    case MeshFormat::kUnknown: break;
  }
  return unknown_format(source);
}

Status read_mesh_file(const std::string& path, const ReadOptions& options, MeshSink& sink) {
  Result<std::unique_ptr<ByteSource>> source = ByteSource::open(path);
  GM_RETURN_IF_ERROR(source.status());
  return read_mesh(**source, options, sink);
}

}  // namespace gaussmesh::format
