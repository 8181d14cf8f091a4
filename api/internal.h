// What the api/ files share: the JSON record behind every stats struct, the conversion of the
// public options into the engine's, and reading a Source.
#pragma once

#include <cstdint>
#include <exception>
#include <new>
#include <string>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>

#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "gaussmesh/gaussmesh.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/memory_budget.h"
#include "stream/core/mesh.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::api {

using Json = nlohmann::ordered_json;

// The Gaussian spheres to try, in order: orientation 0 is the rotation if given, else the one
// drawn from the seed; orientation k > 0 is drawn from seed + k. kUsage for a frequency out of
// range, a malformed or zero rotation, or no orientation.
Result<std::vector<stream::GaussSphereOptions>> gauss_spheres(const SamplingOptions& options);
// --frequency auto with a target: G at frequencies 1, 2, 4, … kMaxAutoFrequency, in that order, the
// first whose sampling reaches the finish's sample count kept (stream::finish_min_samples).
Result<std::vector<stream::GaussSphereOptions>> frequency_ladder(const SamplingOptions& options);
// What this process may use, in bytes: physical memory, or less under a cgroup limit or an
// rlimit (stream::process_memory_limit; 0 if unknown).
std::uint64_t usable_memory();
stream::SamplerOptions sampler_options(const SamplingOptions& options);

format::ReadOptions read_options(const Source& source);
// What an out-of-core run lets a reader hold when the input must be held whole (Draco): an
// explicit --memory, else as far as the automatic budget may grow (a quarter of usable memory).
std::uint64_t whole_input_limit(const ResourceOptions& resources);

// The mesh of a source in memory: read from its file or stream, or viewed where it lies.
struct LoadedMesh {
  stream::Mesh owned;
  MeshView view;
  MeshFormat format = MeshFormat::kUnknown;  // as read (kUnknown for a mesh in memory)
  std::vector<std::string> ignored_vertex_values;  // what the reader did not deliver (MeshSink::on_ignored)
  std::vector<std::string> input_warnings;         // what the reader skipped (MeshSink::on_warning)
};
// weld_stl, memory_limit, corner_values: format::ReadOptions's (0: no limit; an in-core run
// passes an explicit --memory, so that a Draco input whose decode cannot fit is refused before it
// is decoded; simplify asks for corner values, and keeps the seams they make).
Result<LoadedMesh> load(const Source& source, bool weld_stl = true, std::uint64_t memory_limit = 0,
                        bool corner_values = false);

// The out-of-core engines read a path ("-": standard input).
std::string stream_path(const Source& source);

// Whether path ends with `extension` (".ply"), in any case.
bool has_extension(const std::string& path, const std::string& extension);

// Writes `mesh` to `sink`; returns the bytes written (0 for a memory sink).
Result<std::uint64_t> write_mesh(const Sink& sink, MeshView mesh, const DracoOptions& draco);
// The same for a mesh delivered in parts (the chunked finish's output): PLY and OBJ stream it;
// Draco and a memory sink need it whole, gathered first, and are refused (kResources, one line)
// when that would pass `memory_limit` bytes (0: no limit).
// What write_mesh_parts holds a face of the output when the sink needs the mesh whole (0: it streams).
std::uint64_t whole_output_bytes_per_face(const Sink& sink);
// What the process holds to write an output of `faces` faces gathered whole, with
// `more_per_face` bytes a face beside what the sink needs, the process itself included.
std::uint64_t whole_output_bytes(const Sink& sink, std::uint64_t faces, std::uint64_t more_per_face = 0);
// `attributes`: the parts' per-vertex attributes, for a sink that streams them (PLY, OBJ).
Result<std::uint64_t> write_mesh_parts(const Sink& sink, format::MeshParts& mesh, const DracoOptions& draco,
                                       std::uint64_t memory_limit, const format::PartsAttributes& attributes = {});
// A mesh delivered in parts, held whole.
Result<Mesh> gather(format::MeshParts& parts);

// The engine for a job that has no streaming form (the Voronoi mesher, the patch mesh): in core,
// unless it is forced out of core, or an explicit budget under the automatic engine is smaller
// than the in-core working set; then kUsage naming `flag`.
Result<EngineChoice> choose_in_core_only(const Source& source, const ResourceOptions& resources, const char* flag,
                                         const std::string& job);

// Texture seams are kept only by the in-core engine: an OBJ's per-corner vt and vn only its
// in-core reader keeps (format::ReadOptions::corner_values), and a PLY's per-vertex texture
// coordinates come split at their seams, which out of core are open edges. Under the automatic
// engine, when `choice` streams such a file, its triangles are counted (format::census_obj for an
// OBJ whose corners name vt or vn; a read of a PLY whose header has texture coordinates) and the
// file is turned in core if their working set fits the in-core limit (an explicit --memory, else a
// quarter of usable memory), at any size: keeping the input's seams comes before the streaming
// engine's speed. `extra_bytes_per_face`: what the job holds beyond in_core_bytes (a target's
// finish).
void keep_seams_in_core(const Source& source, const ResourceOptions& resources, std::uint64_t extra_bytes_per_face,
                        EngineChoice& choice);

// Threads to use: the option, or the machine's cores when 0.
std::uint32_t thread_count(std::uint32_t threads);

// The fields every out-of-core engine's options share: the budget, the temporary directory, the
// threads, the spheres and the sampler, and the partition's progress.
template <class StreamingOptions>
void set_streaming_options(StreamingOptions& options, const ResourceOptions& resources, std::uint64_t memory,
                           const std::vector<stream::GaussSphereOptions>& spheres, const stream::SamplerOptions& sampler) {
  options.memory = stream::MemoryBudget(memory);
  options.partition.tmp_dir = resources.tmp_dir;
  options.threads = thread_count(resources.threads);
  options.spheres = spheres;
  options.sampler = sampler;
  if (resources.progress) {
    const ProgressFn& progress = resources.progress;  // outlives the run: the caller's options hold it
    options.partition.progress = [&progress](const char* pass, std::uint64_t done, std::uint64_t total) {
      progress(pass, done, total, total);
    };
  }
}

// A well-spread colour for an id (patch or segment), each channel in 64..255.
inline void spread_colour(std::uint32_t id, std::uint8_t rgb[3]) {
  std::uint32_t h = id * 2654435761u;
  h ^= h >> 15;
  for (int i = 0; i < 3; ++i) rgb[i] = static_cast<std::uint8_t>(64 + (h >> (8 * i) & 0xFF) * 3 / 4);
}

// Runs a job and turns what it throws (an allocation that failed, a library's exception) into a
// Status, so that nothing throws across the API.
template <class Job>
auto guarded(const char* job, Job&& run) -> decltype(run()) {
  try {
    return run();
  } catch (const std::bad_alloc&) {
    return Status::error(Code::kResources, job, "out of memory");
  } catch (const std::system_error& e) {
    // A thread the system would not start (EAGAIN: an address-space or process limit) is a
    // resource error, like memory.
    if (e.code() == std::errc::resource_unavailable_try_again || e.code() == std::errc::not_enough_memory) {
      return Status::error(Code::kResources, job, std::string("out of resources: ") + e.what());
    }
    return Status::error(Code::kProcessing, job, std::string("internal error: ") + e.what());
  } catch (const std::exception& e) {
    return Status::error(Code::kProcessing, job, std::string("internal error: ") + e.what());
  }
}

// kUsage when a standard-input source is a terminal.
Status check_not_a_terminal(const Source& source, const char* job);

}  // namespace gaussmesh::api
