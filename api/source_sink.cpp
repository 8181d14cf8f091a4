// Sources and sinks: naming them, reading a source into memory, writing a result mesh through
// OutputFile's write-then-rename.
#include <unistd.h>

#include <algorithm>
#include <cctype>

#include "api/internal.h"
#include "format/output_file.h"

namespace gaussmesh {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

}  // namespace

MeshFormat parse_mesh_format(std::string_view name) { return format::parse_format_name(name); }

Source Source::file(std::string path, MeshFormat format) {
  if (path == "-") return standard_input(format);
  Source s;
  s.kind = Kind::kFile;
  s.path = std::move(path);
  s.format = format;
  return s;
}

Source Source::standard_input(MeshFormat format) {
  Source s;
  s.kind = Kind::kStandardInput;
  s.format = format;
  return s;
}

Source Source::memory(MeshView mesh) {
  Source s;
  s.kind = Kind::kMemory;
  s.mesh = mesh;
  return s;
}

Source Source::file_bytes(std::string_view bytes, std::string name, MeshFormat format) {
  Source s;
  s.kind = Kind::kBytes;
  s.bytes = bytes;
  s.path = std::move(name);
  s.format = format;
  return s;
}

std::string Source::name() const {
  switch (kind) {
    case Kind::kFile: return path;
    case Kind::kStandardInput: return "<stdin>";
    case Kind::kMemory: return "<memory>";
    case Kind::kBytes: return path;
  }
  return path;
}

std::optional<OutputFormat> parse_output_format(const std::string& name) {
  const std::string flag = lower(name);
  if (flag.empty()) return OutputFormat::kAuto;
  if (flag == "draco" || flag == "drc") return OutputFormat::kDraco;
  if (flag == "ply") return OutputFormat::kPlyBinary;
  if (flag == "ply-ascii") return OutputFormat::kPlyAscii;
  if (flag == "obj") return OutputFormat::kObj;
  if (flag == "glb") return OutputFormat::kGlb;
  if (flag == "gltf") return OutputFormat::kGltf;
  return std::nullopt;
}

const char* output_format_name(OutputFormat format) {
  switch (format) {
    case OutputFormat::kAuto: return "auto";
    case OutputFormat::kDraco: return "draco";
    case OutputFormat::kPlyBinary: return "ply";
    case OutputFormat::kPlyAscii: return "ply-ascii";
    case OutputFormat::kObj: return "obj";
    case OutputFormat::kGlb: return "glb";
    case OutputFormat::kGltf: return "gltf";
  }
  return "draco";
}

Sink Sink::file(std::string path, OutputFormat format) {
  if (path == "-") return standard_output(format);
  Sink s;
  s.kind = Kind::kFile;
  s.path = std::move(path);
  s.format = format;
  return s;
}

Sink Sink::standard_output(OutputFormat format) {
  Sink s;
  s.kind = Kind::kStandardOutput;
  s.format = format;
  return s;
}

Sink Sink::memory(Mesh* mesh) {
  Sink s;
  s.kind = Kind::kMemory;
  s.mesh = mesh;
  return s;
}

OutputFormat Sink::resolved_format() const {
  if (format != OutputFormat::kAuto) return format;
  if (kind == Kind::kFile) {
    if (api::has_extension(path, ".ply")) return OutputFormat::kPlyBinary;
    if (api::has_extension(path, ".obj")) return OutputFormat::kObj;
    if (api::has_extension(path, ".glb")) return OutputFormat::kGlb;
    if (api::has_extension(path, ".gltf")) return OutputFormat::kGltf;
  }
  return OutputFormat::kDraco;
}

namespace api {

bool has_extension(const std::string& path, const std::string& extension) {
  const std::string name = lower(path);
  return name.size() >= extension.size() && name.compare(name.size() - extension.size(), extension.size(), extension) == 0;
}

format::ReadOptions read_options(const Source& source) {
  format::ReadOptions options;
  options.format = source.format;
  return options;
}

std::uint64_t whole_input_limit(const ResourceOptions& resources) {
  return resources.memory_bytes != 0 ? resources.memory_bytes : usable_memory() / 4;
}

std::string stream_path(const Source& source) { return source.kind == Source::Kind::kFile ? source.path : "-"; }

// A mesh in memory gets the checks a reader makes on a file: every index in range, every
// position and attribute value a finite number (a mesh built on a NaN or an infinity is garbage,
// and the engine would carry it to the output), and each attribute empty or one per position
// (MeshView's contract, which the engine reads by vertex id).
static Status check_memory_mesh(const MeshView& mesh) {
  const std::size_t n = mesh.positions.size();
  for (const Triangle& t : mesh.triangles) {
    for (VertexIndex v : t.v) {
      if (v >= n) {
        return Status::error(Code::kBadInput, "<memory>", "a triangle references vertex " + std::to_string(v) + " of " + std::to_string(n));
      }
    }
  }
  const auto sized = [n](std::size_t size, const char* what) {
    if (size == 0 || size == n) return Status();
    return Status::error(Code::kBadInput, "<memory>", std::to_string(size) + " " + what + " for " + std::to_string(n) + " positions");
  };
  GM_RETURN_IF_ERROR(sized(mesh.normals.size(), "normals"));
  GM_RETURN_IF_ERROR(sized(mesh.colors.size(), "colours"));
  GM_RETURN_IF_ERROR(sized(mesh.texcoords.size(), "texture coordinates"));
  for (std::size_t v = 0; v < n; ++v) {
    format::VertexAttributes a;
    if (!mesh.normals.empty()) a.normal = mesh.normals[v];
    if (!mesh.colors.empty()) a.color = mesh.colors[v];
    if (!mesh.texcoords.empty()) a.texcoord = mesh.texcoords[v];
    if (!format::is_finite(mesh.positions[v]) || !format::is_finite(a)) {
      return Status::error(Code::kBadInput, "<memory>", "vertex " + std::to_string(v) + " has a value that is not a finite number");
    }
  }
  return {};
}

Result<LoadedMesh> load(const Source& source, bool weld_stl, std::uint64_t memory_limit, bool corner_values) {
  LoadedMesh loaded;
  if (source.kind == Source::Kind::kMemory) {
    GM_RETURN_IF_ERROR(check_memory_mesh(source.mesh));
    loaded.view = source.mesh;
    return loaded;
  }
  stream::MeshBuilder builder;
  if (source.kind == Source::Kind::kBytes) {
    auto bytes = format::ByteSource::from_memory(source.bytes, source.path);
    format::ReadOptions read = read_options(source);
    read.weld_stl = weld_stl;
    read.memory_limit = memory_limit;
    read.corner_values = corner_values;
    GM_RETURN_IF_ERROR(format::read_mesh(*bytes, read, builder));
  } else {
    format::ReadOptions read = read_options(source);
    read.weld_stl = weld_stl;
    read.memory_limit = memory_limit;
    read.corner_values = corner_values;
    GM_RETURN_IF_ERROR(format::read_mesh_file(stream_path(source), read, builder));
  }
  loaded.format = builder.header().format;
  loaded.ignored_vertex_values = builder.ignored();
  loaded.input_warnings = builder.warnings();
  loaded.owned = builder.take();
  loaded.view = loaded.owned.view();
  return loaded;
}

Result<std::uint64_t> write_mesh(const Sink& sink, MeshView mesh, const DracoOptions& draco) {
  if (sink.kind == Sink::Kind::kMemory) {
    if (sink.mesh == nullptr) return Status::error(Code::kUsage, "sink", "a memory sink needs a mesh to fill");
    sink.mesh->positions.assign(mesh.positions.begin(), mesh.positions.end());
    sink.mesh->triangles.assign(mesh.triangles.begin(), mesh.triangles.end());
    sink.mesh->normals.assign(mesh.normals.begin(), mesh.normals.end());
    sink.mesh->colors.assign(mesh.colors.begin(), mesh.colors.end());
    sink.mesh->texcoords.assign(mesh.texcoords.begin(), mesh.texcoords.end());
    return std::uint64_t{0};
  }
  const OutputFormat kind = sink.resolved_format();
  const bool binary = kind != OutputFormat::kPlyAscii && kind != OutputFormat::kObj && kind != OutputFormat::kGltf;
  auto out = format::OutputFile::create(sink.kind == Sink::Kind::kFile ? sink.path : "-", binary);
  if (!out) return out.status();
  format::DracoWriteOptions draco_options;
  draco_options.quantization_bits = draco.quantization_bits;
  draco_options.compression_level = draco.compression_level;
  draco_options.normal_bits = draco.normal_bits;
  draco_options.texcoord_bits = draco.texcoord_bits;
  Status status;
  switch (kind) {
    case OutputFormat::kAuto:
    case OutputFormat::kDraco: status = format::write_draco(**out, mesh, draco_options); break;
    case OutputFormat::kGlb:
    case OutputFormat::kGltf: {
      format::GltfWriteOptions gltf;
      gltf.binary = kind == OutputFormat::kGlb;
      gltf.draco = draco_options;
      status = format::write_gltf(**out, mesh, gltf);
      break;
    }
    case OutputFormat::kPlyBinary:
    case OutputFormat::kPlyAscii: {
      format::PlyWriteOptions ply;
      ply.binary = kind == OutputFormat::kPlyBinary;
      ply.comments.push_back("written by gaussmesh");
      status = format::write_ply(**out, mesh, ply);
      break;
    }
    case OutputFormat::kObj: status = format::write_obj(**out, mesh); break;
  }
  GM_RETURN_IF_ERROR(status);
  GM_RETURN_IF_ERROR((*out)->commit());
  return (*out)->bytes_written();
}

// Gathering a mesh costs its arrays (12 B a vertex, 12 B a face, about half as many vertices as
// faces); Draco's encoder about 80 B a face more (measured on 1M faces: docs/finish.md); glTF
// decodes the Draco bytes again to describe them, and holds the container's copy.
constexpr std::uint64_t kGatheredBytesPerFace = 18;
constexpr std::uint64_t kDracoBytesPerFace = 80;
constexpr std::uint64_t kGltfBytesPerFace = 120;
constexpr std::uint64_t kProcessBytes = std::uint64_t{20} << 20;  // the process itself

std::uint64_t whole_output_bytes_per_face(const Sink& sink) {
  if (sink.kind == Sink::Kind::kMemory) return kGatheredBytesPerFace;
  switch (sink.resolved_format()) {
    case OutputFormat::kAuto:
    case OutputFormat::kDraco: return kGatheredBytesPerFace + kDracoBytesPerFace;
    case OutputFormat::kGlb:
    case OutputFormat::kGltf: return kGatheredBytesPerFace + kGltfBytesPerFace;
    default: return 0;
  }
}

std::uint64_t whole_output_bytes(const Sink& sink, std::uint64_t faces, std::uint64_t more_per_face) {
  return faces * (whole_output_bytes_per_face(sink) + more_per_face) + kProcessBytes;
}

Result<std::uint64_t> write_mesh_parts(const Sink& sink, format::MeshParts& mesh, const DracoOptions& draco,
                                       std::uint64_t memory_limit, const format::PartsAttributes& attributes) {
  const OutputFormat kind = sink.kind == Sink::Kind::kMemory ? OutputFormat::kAuto : sink.resolved_format();
  if (sink.kind != Sink::Kind::kMemory && whole_output_bytes_per_face(sink) == 0) {
    auto out = format::OutputFile::create(sink.kind == Sink::Kind::kFile ? sink.path : "-", kind != OutputFormat::kObj && kind != OutputFormat::kPlyAscii);
    if (!out) return out.status();
    Status status = kind == OutputFormat::kObj
                        ? format::write_obj_parts(**out, mesh, attributes)
                        : format::write_ply_parts(**out, mesh, kind == OutputFormat::kPlyBinary, {"written by gaussmesh"}, attributes);
    GM_RETURN_IF_ERROR(status);
    GM_RETURN_IF_ERROR((*out)->commit());
    return (*out)->bytes_written();
  }
  const std::uint64_t need = whole_output_bytes(sink, mesh.face_count());
  if (memory_limit > 0 && need > memory_limit) {
    return Status::error(Code::kResources, "--memory",
                         std::string("the output's ") + std::to_string(mesh.face_count()) + " faces need about " +
                             std::to_string(need >> 20) + " MiB to write in this format" +
                             ", above the budget of " + std::to_string(memory_limit >> 20) +
                             " MiB: write PLY or OBJ (streamed), raise --memory or lower the target");
  }
  auto whole = gather(mesh);
  if (!whole) return whole.status();
  return write_mesh(sink, whole->view(), draco);
}

Result<Mesh> gather(format::MeshParts& parts) {
  Mesh whole;
  whole.positions.reserve(parts.vertex_count());
  whole.triangles.reserve(parts.face_count());
  GM_RETURN_IF_ERROR(parts.vertices([&](std::span<const format::Vec3f> b) {
    whole.positions.insert(whole.positions.end(), b.begin(), b.end());
    return Status();
  }));
  GM_RETURN_IF_ERROR(parts.faces([&](std::span<const format::Triangle> b) {
    whole.triangles.insert(whole.triangles.end(), b.begin(), b.end());
    return Status();
  }));
  return whole;
}

Status check_not_a_terminal(const Source& source, const char* job) {
  if (source.kind == Source::Kind::kStandardInput && ::isatty(0)) {
    return Status::error(Code::kUsage, job, "no input file, and standard input is a terminal");
  }
  return {};
}

}  // namespace api
}  // namespace gaussmesh
