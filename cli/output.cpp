// Output format choice and the write-then-commit of a result mesh.
#include "cli/output.h"

#include <algorithm>
#include <cctype>

namespace gaussmesh::cli {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

format::Result<OutputKind> choose_output_kind(const std::string& format_flag, const std::string& path) {
  std::string flag = lower(format_flag);
  if (flag == "draco" || flag == "drc") return OutputKind::kDraco;
  if (flag == "ply") return OutputKind::kPlyBinary;
  if (flag == "ply-ascii") return OutputKind::kPlyAscii;
  if (flag == "obj") return OutputKind::kObj;
  if (!flag.empty()) {
    return format::Status::error(format::Code::kUsage, "--format",
                                 "unknown output format '" + format_flag + "' (draco, ply, ply-ascii, obj)");
  }
  std::string name = lower(path);
  if (ends_with(name, ".ply")) return OutputKind::kPlyBinary;
  if (ends_with(name, ".obj")) return OutputKind::kObj;
  return OutputKind::kDraco;
}

const char* output_kind_name(OutputKind kind) {
  switch (kind) {
    case OutputKind::kDraco: return "draco";
    case OutputKind::kPlyBinary: return "ply";
    case OutputKind::kPlyAscii: return "ply-ascii";
    case OutputKind::kObj: return "obj";
  }
  return "draco";
}

format::Result<std::uint64_t> write_mesh_output(const std::string& path, OutputKind kind, format::MeshView mesh,
                                                const format::DracoWriteOptions& draco) {
  const bool binary = kind == OutputKind::kDraco || kind == OutputKind::kPlyBinary;
  auto out = format::OutputFile::create(path, binary);
  if (!out) return out.status();
  format::Status status;
  switch (kind) {
    case OutputKind::kDraco: status = format::write_draco(**out, mesh, draco); break;
    case OutputKind::kPlyBinary:
    case OutputKind::kPlyAscii: {
      format::PlyWriteOptions ply;
      ply.binary = kind == OutputKind::kPlyBinary;
      ply.comments.push_back("written by gaussmesh");
      status = format::write_ply(**out, mesh, ply);
      break;
    }
    case OutputKind::kObj: status = format::write_obj(**out, mesh); break;
  }
  GM_RETURN_IF_ERROR(status);
  GM_RETURN_IF_ERROR((*out)->commit());
  return (*out)->bytes_written();
}

}  // namespace gaussmesh::cli
