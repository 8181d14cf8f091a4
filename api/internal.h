// What the api/ files share: the JSON record behind every stats struct, the conversion of the
// public options into the engine's, and reading a Source.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "gaussmesh/gaussmesh.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/mesh.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::api {

using Json = nlohmann::ordered_json;

// The Gaussian spheres to try, in order: orientation 0 is the rotation if given, else the one
// drawn from the seed; orientation k > 0 is drawn from seed + k. kUsage for a frequency out of
// range, a malformed or zero rotation, or no orientation.
Result<std::vector<stream::GaussSphereOptions>> gauss_spheres(const SamplingOptions& options);
stream::SamplerOptions sampler_options(const SamplingOptions& options);

format::ReadOptions read_options(const Source& source);

// The mesh of a source in memory: read from its file or stream, or viewed where it lies.
struct LoadedMesh {
  stream::Mesh owned;
  MeshView view;
};
Result<LoadedMesh> load(const Source& source);

// The out-of-core engines read a path ("-": standard input).
std::string stream_path(const Source& source);

// Writes `mesh` to `sink`; returns the bytes written (0 for a memory sink).
Result<std::uint64_t> write_mesh(const Sink& sink, MeshView mesh, const DracoOptions& draco);

// Threads to use: the option, or the machine's cores when 0.
std::uint32_t thread_count(std::uint32_t threads);

// kUsage when a standard-input source is a terminal.
Status check_not_a_terminal(const Source& source, const char* job);

}  // namespace gaussmesh::api
