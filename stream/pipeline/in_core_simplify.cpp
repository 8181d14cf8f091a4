// The in-core simplification job: orientation search, sampling, meshing (paper §4–5).
#include "stream/pipeline/in_core_simplify.h"

#include <algorithm>
#include <optional>

#include "stream/core/stopwatch.h"
#include "stream/meshing/voronoi_mesher.h"

namespace gaussmesh::stream {
const char* mesher_name(MesherKind mesher) { return mesher == MesherKind::kPatch ? "patch" : "voronoi"; }

std::size_t choose_sphere(const std::vector<std::size_t>& samples, std::uint64_t min_samples) {
  std::size_t chosen = 0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    if (min_samples > 0) {
      chosen = k;
      if (samples[k] >= min_samples) break;
    } else if (samples[k] < samples[chosen]) {
      chosen = k;
    }
  }
  return chosen;
}

format::Result<SimplifyResult> simplify_mesh(MeshView mesh, const SimplifyOptions& options) {
  SimplifyResult result;
  auto start = Clock::now();
  std::optional<SamplingResult> best;
  std::optional<GaussSphere> best_gauss;
  std::vector<GaussSphereOptions> spheres = options.spheres;
  if (spheres.empty()) spheres.emplace_back();
  for (std::uint32_t k = 0; k < spheres.size(); ++k) {
    auto gauss = GaussSphere::create(spheres[k]);
    if (!gauss) return gauss.status();
    auto sampled = sample_mesh(mesh, *gauss, options.sampler);
    if (!sampled) return sampled.status();
    const std::size_t n = sampled->samples.size();
    result.samples_per_orientation.push_back(n);
    const bool take = options.min_samples > 0 ? true : !best || n < best->samples.size();
    if (take) {
      best = std::move(sampled.value());
      best_gauss = std::move(gauss.value());
      result.orientation_index = k;
    }
    if (options.min_samples > 0 && n >= options.min_samples) break;
  }
  result.seconds_sample = seconds_since(start);
  const SamplingResult& sampling = *best;
  result.rotation = best_gauss->options().rotation;
  result.gauss_vertices = best_gauss->vertex_count();
  result.gauss_triangles = best_gauss->triangle_count();
  result.patches = sampling.patch_count;
  result.candidates = sampling.candidates.size();
  result.samples = sampling.samples.size();
  result.sampling = sampling.stats;

  start = Clock::now();
  if (options.mesher == MesherKind::kVoronoi) {
    std::vector<std::uint32_t> sample_ids;
    sample_ids.reserve(sampling.samples.size());
    for (const auto& s : sampling.samples) sample_ids.push_back(s.vertex);
    auto meshed = mesh_voronoi(mesh, sample_ids);
    if (!meshed) return meshed.status();
    result.mesh = std::move(meshed->mesh);
    result.birth = std::move(meshed->birth);
  } else {
    std::vector<VertexRole> roles(mesh.positions.size(), VertexRole::kNone);
    for (const auto& c : sampling.candidates) roles[c.vertex] = VertexRole::kCorner;
    for (const auto& s : sampling.samples) roles[s.vertex] = VertexRole::kSample;
    // Each patch is triangulated in the plane of its Gaussian triangle (paper §5).
    std::vector<format::Vec3f> plane(sampling.patch_label.size());
    for (size_t p = 0; p < plane.size(); ++p) {
      if (sampling.patch_label[p] == kNoLabel) continue;  // zero normal: mean normal instead
      const Vec3d& c = best_gauss->triangle_center(sampling.patch_label[p]);
      plane[p] = {float(c.x), float(c.y), float(c.z)};
    }
    const PatchMesherInput input{mesh, sampling.face_patch, roles, plane};
    auto polygons = mesh_patch_polygons(input);
    std::optional<PatchMesherResult> meshed;
    if (polygons) {
      result.polygon = polygons->stats;
      meshed = std::move(polygons->mesh);
    } else {
      result.mesher_fallback = true;
      result.mesher_fallback_reason = polygons.status().to_string();
      auto collapsed = mesh_patches_by_collapse(input);
      if (!collapsed) return collapsed.status();
      meshed = std::move(collapsed).value();
    }
    result.mesh = std::move(meshed->mesh);
    result.birth = std::move(meshed->birth);
    result.graph = meshed->graph;
    result.kept_corners = meshed->kept_corners;
    result.kept_chain_vertices = meshed->kept_chain_vertices;
    result.kept_interior_vertices = meshed->kept_interior_vertices;
    result.skipped_input_faces = meshed->skipped_input_faces;
    result.planar_patches = meshed->planar_patches;
    result.collapse_patches = meshed->collapse_patches;
  }
  result.seconds_mesh = seconds_since(start);
  return result;
}

}  // namespace gaussmesh::stream
