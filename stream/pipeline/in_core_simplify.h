// The in-core simplification job (paper §4–5): sample the mesh on the Gaussian sphere G (trying
// several orientations of G if asked), then build the approximation with the per-patch or the
// Voronoi mesher. The out-of-core pipeline reaches the same result through records.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/mesh.h"
#include "stream/meshing/collapse_mesher.h"
#include "stream/meshing/polygon_mesher.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {

enum class MesherKind { kPatch, kVoronoi };
const char* mesher_name(MesherKind mesher);

struct SimplifyOptions {
  // The Gaussian spheres to try (base, frequency, rotation); the one giving the fewest samples
  // is kept (ties: the earliest). At least one; an empty list means the default sphere.
  std::vector<GaussSphereOptions> spheres = {GaussSphereOptions{}};
  // When not 0, the choice is instead the first sphere in list order with at least this many
  // samples (the last when none has): a ladder of frequencies for a face target
  // (--frequency auto); the spheres after the chosen one are not sampled.
  std::uint64_t min_samples = 0;
  SamplerOptions sampler;  // smoothing, sample test
  MesherKind mesher = MesherKind::kPatch;
};

struct SimplifyResult {
  Mesh mesh;                         // the approximation; positions copied from the input
  std::vector<std::uint32_t> birth;  // input vertex of every output vertex
  std::array<double, 4> rotation{};  // the orientation of G that was used
  std::uint32_t orientation_index = 0;  // index into options.spheres
  std::vector<std::size_t> samples_per_orientation;
  std::size_t gauss_vertices = 0, gauss_triangles = 0;
  std::size_t patches = 0, candidates = 0, samples = 0;
  SamplingStats sampling;
  PatchGraphStats graph;             // per-patch mesher only
  std::size_t kept_corners = 0, kept_chain_vertices = 0, kept_interior_vertices = 0;
  std::size_t skipped_input_faces = 0;
  std::size_t planar_patches = 0, collapse_patches = 0;  // see PatchMesherResult
  PolygonMesherStats polygon;  // the polygon-first mesher's figures (per-patch mesher)
  // The polygon-first mesher refused (its output would not have been a valid mesh) and the
  // collapse mesher (mesh_patches) built the result instead; the reason is kept.
  bool mesher_fallback = false;
  std::string mesher_fallback_reason;
  double seconds_sample = 0, seconds_mesh = 0;
};

// The sphere SimplifyOptions::min_samples picks from every sphere's sample count: the fewest
// (ties: the first) when min_samples is 0, else the first with at least min_samples (else the last).
std::size_t choose_sphere(const std::vector<std::size_t>& samples, std::uint64_t min_samples);

// Errors: kUsage for invalid G options; kProcessing from the sampler or mesher.
format::Result<SimplifyResult> simplify_mesh(MeshView mesh, const SimplifyOptions& options);

}  // namespace gaussmesh::stream
