// The viewer's files and its self-contained page: index.html with viewer.js inlined as a module
// script, and window.gaussmeshEmbedded holding the model's bytes and Draco's decoder (wrapper
// and WebAssembly) as base64, which viewer/main.js reads instead of fetching. docs/viewer.md.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <vector>

#include "format/output_file.h"
#include "gaussmesh/gaussmesh.h"

namespace gaussmesh {
namespace {

namespace fs = std::filesystem;

constexpr const char* kEmbedMarker = "<!-- gaussmesh:embedded -->";
constexpr const char* kScriptTag = "<script type=\"module\" src=\"viewer.js\"></script>";
constexpr const char* kDracoFiles[] = {"draco_wasm_wrapper.js", "draco_decoder.wasm"};

bool holds_viewer(const fs::path& dir) {
  std::error_code error;
  return fs::is_regular_file(dir / "index.html", error) && fs::is_regular_file(dir / "viewer.js", error) &&
         fs::is_regular_file(dir / "draco" / kDracoFiles[0], error) && fs::is_regular_file(dir / "draco" / kDracoFiles[1], error);
}

Status read_whole(const fs::path& path, std::string& bytes, Code code, std::uint64_t limit) {
  std::error_code error;
  const auto size = fs::file_size(path, error);
  if (error) return Status::error(code, path.string(), "cannot read: " + error.message());
  if (size > limit) {
    return Status::error(Code::kUsage, path.string(),
                         std::to_string(size >> 20) + " MiB is too large to embed in a page (at most " + std::to_string(limit >> 20) +
                             " MiB): serve it with `gaussmesh view FILE` instead");
  }
  std::ifstream in(path, std::ios::binary);
  bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) return Status::error(code, path.string(), "cannot read");
  if (bytes.size() != size) return Status::error(code, path.string(), "changed while being read");
  return {};
}

std::string base64(const std::string& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t n = (std::uint8_t(bytes[i]) << 16) | (std::uint8_t(bytes[i + 1]) << 8) | std::uint8_t(bytes[i + 2]);
    for (int shift : {18, 12, 6, 0}) out.push_back(kAlphabet[(n >> shift) & 63]);
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const std::uint32_t n = (std::uint8_t(bytes[i]) << 16) | (two ? std::uint8_t(bytes[i + 1]) << 8 : 0);
    out.push_back(kAlphabet[(n >> 18) & 63]);
    out.push_back(kAlphabet[(n >> 12) & 63]);
    out.push_back(two ? kAlphabet[(n >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

// A JSON string literal of plain text (the file name).
std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out.push_back('\\');
      out.push_back(static_cast<char>(c));
    } else if (c < 0x20 || c == '<' || c == '>' || c == '&') {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", c);
      out += escaped;
    } else {
      out.push_back(static_cast<char>(c));
    }
  }
  return out + "\"";
}

// Script text inside <script>: a "</script" would end the element early.
std::string inline_script(std::string text) {
  for (std::size_t at = 0; (at = text.find("</script", at)) != std::string::npos; at += 2) text.replace(at, 2, "<\\/");
  return text;
}

}  // namespace

Result<std::string> find_viewer(const std::string& executable_dir) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("GAUSSMESH_VIEWER_DIR"); env != nullptr && *env != '\0') candidates.emplace_back(env);
  candidates.push_back(fs::path(executable_dir) / ".." / "viewer");
  candidates.push_back(fs::path(executable_dir) / ".." / "share" / "gaussmesh" / "viewer");
  for (const fs::path& dir : candidates) {
    if (holds_viewer(dir)) return fs::weakly_canonical(dir).string();
  }
  return Status::error(Code::kUsage, "view",
                       "the viewer is not built (bash scripts/bootstrap viewer builds it into build/viewer; "
                       "GAUSSMESH_VIEWER_DIR names another folder)");
}

Status write_viewer_page(const std::string& viewer_dir, const std::string& model, const std::string& output) {
  const fs::path dir(viewer_dir);
  std::string page, script, model_bytes;
  constexpr std::uint64_t kViewerFileLimit = std::uint64_t{64} << 20;
  GM_RETURN_IF_ERROR(read_whole(dir / "index.html", page, Code::kUsage, kViewerFileLimit));
  GM_RETURN_IF_ERROR(read_whole(dir / "viewer.js", script, Code::kUsage, kViewerFileLimit));
  GM_RETURN_IF_ERROR(read_whole(model, model_bytes, Code::kBadInput, kMaxEmbeddedModelBytes));
  const auto marker = page.find(kEmbedMarker);
  const auto tag = page.find(kScriptTag);
  if (marker == std::string::npos || tag == std::string::npos || tag < marker) {
    return Status::error(Code::kUsage, (dir / "index.html").string(), "not the viewer page this gaussmesh embeds into");
  }
  std::string embedded = "<script>window.gaussmeshEmbedded = {\"name\": " + json_string(fs::path(model).filename().string()) +
                         ", \"model\": \"" + base64(model_bytes) + "\", \"draco\": {";
  model_bytes.clear();
  model_bytes.shrink_to_fit();
  for (const char* file : kDracoFiles) {
    std::string bytes;
    GM_RETURN_IF_ERROR(read_whole(dir / "draco" / file, bytes, Code::kUsage, kViewerFileLimit));
    embedded += json_string(file) + ": \"" + base64(bytes) + "\"" + (file == kDracoFiles[1] ? "" : ", ");
  }
  embedded += "}};</script>";
  std::string html = page.substr(0, marker) + embedded + page.substr(marker + std::strlen(kEmbedMarker), tag - marker - std::strlen(kEmbedMarker)) +
                     "<script type=\"module\">" + inline_script(std::move(script)) + "</script>" + page.substr(tag + std::strlen(kScriptTag));
  auto out = format::OutputFile::create(output, false);
  if (!out) return out.status();
  GM_RETURN_IF_ERROR((*out)->write(html));
  return (*out)->commit();
}

}  // namespace gaussmesh
