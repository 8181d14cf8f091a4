// Choosing in core or out of core, and the automatic memory budget (docs/api.md, "Choosing the
// engine"); the process-level helpers of the API.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <thread>

#include "api/internal.h"
#include "format/byte_source.h"
#include "format/draco_header.h"
#include "format/obj_census.h"
#include "format/output_file.h"
#include "format/temp_registry.h"
#include "stream/core/memory_limit.h"
#include "stream/core/process_memory.h"
#include "stream/partition/chunk_partition.h"

namespace gaussmesh {
namespace api {

std::uint64_t usable_memory() { return stream::process_memory_limit().bytes; }

}  // namespace api

namespace {

using api::usable_memory;

// Fewest input bytes a face takes in any format we read (binary PLY: a 13-byte face record and
// a share of the 12-byte vertices; Draco is compressed further but decodes whole anyway), so
// that the estimate errs towards more faces and hence towards streaming.
constexpr std::uint64_t kMinBytesPerFace = 16;
// In-core working set: the mesh, its adjacency, the sampler's per-face and per-vertex arrays and
// the mesher's, with a margin over what docs/benchmarks.md measures ("Engine choice").
constexpr std::uint64_t kInCoreBytesPerFace = 96;
constexpr std::uint64_t kProcessBytes = std::uint64_t{16} << 20;
// What per-corner texture coordinates and normals add to it: each corner's value index, the
// values, and the seams' split vertices (docs/benchmarks.md, "Engine choice").
constexpr std::uint64_t kCornerValuesBytesPerFace = 96;
// What a counted file holds per vertex statement beyond that, so that one with long lists and few
// faces is not taken in core: an OBJ reader's lists (a position and a colour, a texture
// coordinate, a normal), a PLY vertex with every value.
constexpr std::uint64_t kObjPositionBytes = 28, kObjTexcoordBytes = 8, kObjNormalBytes = 12, kPlyVertexBytes = 64;

// The partition refuses smaller budgets; the API checks before choosing an engine.
static_assert(kMinMemory == stream::kMinPartitionMemory);
static_assert(kInCoreMaxFileBytes == kInCoreMaxFaces * kMinBytesPerFace);

// A regular file the job will read from its start, and its size: the source's file, or standard
// input redirected from one (or a copy the command line made of a pipe), which a count reopens
// through /proc/self/fd/0 (a description of its own, so the job's read is not moved).
struct RegularInput {
  std::string path;
  std::uint64_t size = 0;
};
std::optional<RegularInput> regular_input(const Source& source) {
  struct stat st {};
  if (source.kind == Source::Kind::kFile) {
    if (::stat(source.path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
    return RegularInput{source.path, static_cast<std::uint64_t>(st.st_size)};
  }
  if (source.kind != Source::Kind::kStandardInput) return std::nullopt;
  if (::fstat(STDIN_FILENO, &st) != 0 || !S_ISREG(st.st_mode) || ::lseek(STDIN_FILENO, 0, SEEK_CUR) != 0) return std::nullopt;
  return RegularInput{"/proc/self/fd/0", static_cast<std::uint64_t>(st.st_size)};
}

// A Draco file's faces as its header declares them: Draco compresses a face into far fewer than
// kMinBytesPerFace bytes (the refined cow: a fifth of a byte), so its size says little. nullopt
// when the file is not Draco or its header cannot be read (the reader says why when it reads it).
std::optional<std::uint64_t> draco_faces(const std::string& path, MeshFormat format) {
  if (format != MeshFormat::kUnknown && format != MeshFormat::kDraco) return std::nullopt;
  auto bytes = format::ByteSource::open(path);
  if (!bytes) return std::nullopt;
  format::ByteSource& in = **bytes;
  auto got = in.ensure(5);
  if (!got || *got < 5 || std::memcmp(in.cursor(), "DRACO", 5) != 0) return std::nullopt;
  got = in.ensure(format::ByteSource::kMaxWindow);
  if (!got) return std::nullopt;
  auto counts = format::read_draco_counts({in.cursor(), *got}, in.name(), in.total_size().value_or(0));
  if (!counts) return std::nullopt;
  return counts->faces;
}

}  // namespace

std::uint64_t auto_memory_budget() {
  const std::uint64_t usable = usable_memory();
  const std::uint64_t cap = std::uint64_t{64} << 20;
  if (usable == 0) return cap;
  return std::clamp(usable / 64, kMinMemory, cap);
}

std::uint64_t in_core_bytes(std::uint64_t faces) { return kProcessBytes + kInCoreBytesPerFace * faces; }

Result<EngineChoice> choose_engine(const Source& source, const ResourceOptions& resources) {
  if (resources.memory_bytes != 0 && resources.memory_bytes < kMinMemory) {
    return Status::error(Code::kUsage, "--memory", "at least 16M (the reader's window and the spill buffers)");
  }
  // Past a cgroup limit the kernel kills the process rather than fail an allocation: a budget
  // above what the process may use is refused before anything is read or written.
  if (const stream::MemoryLimit limit = stream::process_memory_limit(); limit.limited && resources.memory_bytes > limit.bytes) {
    return Status::error(Code::kResources, "--memory",
                         "more than this process may use (" + std::to_string(limit.bytes >> 20) + " MiB, its " + limit.by + ")");
  }
  EngineChoice choice;
  choice.memory_bytes = resources.memory_bytes != 0 ? resources.memory_bytes : auto_memory_budget();
  if (source.kind == Source::Kind::kMemory || source.kind == Source::Kind::kBytes) {
    choice.estimated_faces = source.kind == Source::Kind::kMemory ? source.mesh.triangles.size()
                                                                   : source.bytes.size() / kMinBytesPerFace;
    choice.engine = Engine::kInCore;  // already in memory; the streaming engines read files
    if (resources.engine == Engine::kOutOfCore) {
      return Status::error(Code::kUsage, "engine", "a mesh in memory runs in core (the streaming engine reads a file or stdin)");
    }
    return choice;
  }
  const std::optional<RegularInput> regular = regular_input(source);  // a pipe's size is not known
  const bool known = regular.has_value();
  if (known) {
    choice.estimated_faces = regular->size / kMinBytesPerFace;
    if (auto faces = draco_faces(regular->path, source.format)) choice.estimated_faces = std::max(choice.estimated_faces, *faces);
  }
  if (resources.engine != Engine::kAuto) {
    choice.engine = resources.engine;
    return choice;
  }
  const std::uint64_t in_core_limit = resources.memory_bytes != 0 ? resources.memory_bytes : usable_memory() / 4;
  choice.engine = known && choice.estimated_faces <= kInCoreMaxFaces && in_core_bytes(choice.estimated_faces) <= in_core_limit
                      ? Engine::kInCore
                      : Engine::kOutOfCore;
  return choice;
}

namespace api {

Result<EngineChoice> choose_in_core_only(const Source& source, const ResourceOptions& resources, const char* flag,
                                         const std::string& job) {
  if (resources.engine == Engine::kOutOfCore) return Status::error(Code::kUsage, flag, job + " runs in core only");
  auto choice = choose_engine(source, resources);
  if (!choice) return choice.status();
  const std::uint64_t needs = in_core_bytes(choice->estimated_faces);
  if (resources.engine == Engine::kAuto && resources.memory_bytes != 0 && needs > resources.memory_bytes) {
    return Status::error(Code::kUsage, flag,
                         job + " runs in core, and the input needs more than --memory (~" + std::to_string(needs >> 20) + " MiB)");
  }
  choice->engine = Engine::kInCore;
  return choice;
}

namespace {

// The triangles of a PLY file with texture coordinates, counted by reading it (positions and
// faces are passed over, never held): a header without them, or more than `enough` triangles,
// stops the read.
class TexturedFaceCount final : public format::MeshSink {
 public:
  explicit TexturedFaceCount(std::uint64_t enough) : enough_(enough) {}
  Status on_header(const format::MeshHeader& header) override {
    textured_ = header.attributes.texcoords;
    vertices_ = header.declared_vertices.value_or(0);
    // Every declared polygon is a triangle at least.
    return textured_ && header.declared_faces.value_or(0) <= enough_ ? Status() : stop();
  }
  Status on_vertices(std::span<const Vec3f>) override { return {}; }
  Status on_triangles(std::span<const Triangle> batch) override {
    triangles_ += batch.size();
    return triangles_ > enough_ ? stop() : Status();
  }
  Status on_end() override {
    complete_ = true;
    return {};
  }
  // The triangles, when the file has texture coordinates and was read to its end within `enough`.
  std::optional<std::uint64_t> triangles() const { return textured_ && complete_ ? std::optional(triangles_) : std::nullopt; }
  std::uint64_t vertices() const { return vertices_; }  // as the header declares them

 private:
  static Status stop() { return Status::error(Code::kProcessing, "", "counted"); }
  std::uint64_t enough_, triangles_ = 0, vertices_ = 0;
  bool textured_ = false, complete_ = false;
};

}  // namespace

void keep_seams_in_core(const Source& source, const ResourceOptions& resources, std::uint64_t extra_bytes_per_face,
                        EngineChoice& choice) {
  if (resources.engine != Engine::kAuto || choice.engine != Engine::kOutOfCore ||
      (source.format != MeshFormat::kUnknown && source.format != MeshFormat::kObj && source.format != MeshFormat::kPly)) {
    return;
  }
  const std::optional<RegularInput> regular = regular_input(source);
  if (!regular) return;
  const std::string& path = regular->path;
  const std::uint64_t limit = resources.memory_bytes != 0 ? resources.memory_bytes : usable_memory() / 4;
  const std::uint64_t per_face = kInCoreBytesPerFace + kCornerValuesBytesPerFace + extra_bytes_per_face;
  if (limit <= kProcessBytes) return;
  const std::uint64_t enough = (limit - kProcessBytes) / per_face;
  // Any error here is the reader's to say when the run reads the file.
  auto bytes = format::ByteSource::open(path);
  if (!bytes) return;
  MeshFormat format = source.format;
  if (format == MeshFormat::kUnknown) {
    auto detected = format::detect_format(**bytes);
    if (!detected) return;
    format = *detected != MeshFormat::kUnknown ? *detected : format::format_from_extension(path);
  }
  std::optional<std::uint64_t> triangles;
  std::uint64_t held = 0;  // what the file's lists take beyond its faces
  if (format == MeshFormat::kObj) {
    auto slash = format::any_slash(**bytes);
    if (!slash || !*slash) return;
    bytes = format::ByteSource::open(path);
    if (!bytes) return;
    auto census = format::census_obj(**bytes, enough);
    if (census && census->complete && census->corner_values) {
      triangles = census->triangles;
      held = kObjPositionBytes * census->vertices + kObjTexcoordBytes * census->texcoords + kObjNormalBytes * census->normals;
    }
  } else if (format == MeshFormat::kPly) {
    TexturedFaceCount count(enough);
    format::ReadOptions read;
    read.format = MeshFormat::kPly;
    (void)format::read_mesh(**bytes, read, count);
    triangles = count.triangles();
    held = kPlyVertexBytes * std::min<std::uint64_t>(count.vertices(), UINT32_MAX);
  }
  if (!triangles || kProcessBytes + per_face * *triangles + held > limit) return;
  choice.engine = Engine::kInCore;
  choice.estimated_faces = *triangles;
}

std::uint32_t thread_count(std::uint32_t threads) {
  if (threads > 0) return threads;
  const unsigned cores = std::thread::hardware_concurrency();
  return cores > 0 ? cores : 1;
}

}  // namespace api

void install_signal_cleanup() { format::install_signal_cleanup(); }
void remove_temporary_files() { format::remove_registered_temp_paths(); }

Status write_report(const std::string& path, const std::string& report_json) {
  auto out = format::OutputFile::create(path, false);
  if (!out) return out.status();
  GM_RETURN_IF_ERROR((*out)->write(report_json + "\n"));
  return (*out)->commit();
}

std::uint64_t peak_rss_bytes() { return stream::peak_rss(); }

}  // namespace gaussmesh
