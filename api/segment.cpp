// gaussmesh::segment: spherical segmentation (paper §6) in core, written as a per-face coloured PLY.
#include "api/internal.h"
#include "format/output_file.h"
#include "stream/analysis/segmentation.h"
#include "stream/core/stopwatch.h"

namespace gaussmesh {
namespace {

using api::Json;
using stream::Clock;

// A distinct colour per segment: a fixed palette for the first eight, then spread ones.
void segment_colour(std::uint32_t id, std::uint8_t rgb[3]) {
  static const std::uint8_t kPalette[][3] = {{220, 50, 47},  {60, 170, 60},  {38, 110, 210}, {230, 190, 30},
                                             {160, 80, 200}, {30, 180, 190}, {240, 120, 40}, {140, 140, 140}};
  if (id < 8) {
    for (int i = 0; i < 3; ++i) rgb[i] = kPalette[id][i];
    return;
  }
  api::spread_colour(id, rgb);
}

Status write_segments(const std::string& path, MeshView mesh, const stream::SegmentationResult& r) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint8_t> red(nf), green(nf), blue(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    std::uint8_t rgb[3];
    segment_colour(r.face_segment[f], rgb);
    red[f] = rgb[0];
    green[f] = rgb[1];
    blue[f] = rgb[2];
  }
  format::PlyWriteOptions options;
  options.comments = {"gaussmesh segment: faces coloured per segment; label = Gaussian triangle of the smoothed "
                      "normal, pole = 1 for faces of pole patches"};
  options.face_attributes = {{"red", std::span<const std::uint8_t>(red)},
                             {"green", std::span<const std::uint8_t>(green)},
                             {"blue", std::span<const std::uint8_t>(blue)},
                             {"segment", std::span<const std::uint32_t>(r.face_segment)},
                             {"label", std::span<const std::uint32_t>(r.face_label)},
                             {"pole", std::span<const std::uint8_t>(r.face_pole)}};
  GM_RETURN_IF_ERROR(format::write_ply(**out, mesh, options));
  return (*out)->commit();
}

}  // namespace

namespace {

Result<SegmentStats> segment_job(const Source& source, const std::string& path, const SegmentOptions& o) {
  if (!path.empty() && path != "-" && !api::has_extension(path, ".ply")) {
    return Status::error(Code::kUsage, "-o", "segment writes PLY (per-face segment and colour): give a .ply name or '-'");
  }
  if (o.sampling.orientations != 1) {
    return Status::error(Code::kUsage, "--orientations", "segment uses one orientation of G");
  }
  auto spheres = api::gauss_spheres(o.sampling);
  if (!spheres) return spheres.status();
  if (o.sampling.smooth > o.max_smooth) {
    return Status::error(Code::kUsage, "--smooth", "the starting smoothing exceeds --max-smooth");
  }
  auto gauss = stream::GaussSphere::create(spheres->front());
  if (!gauss) return gauss.status();
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(source, "segment"));
  const auto t0 = Clock::now();
  auto mesh = api::load(source);
  if (!mesh) return mesh.status();
  const MeshView input = mesh->view;
  const auto t1 = Clock::now();
  stream::SegmentationOptions so;
  so.min_smooth = o.sampling.smooth;
  so.max_smooth = o.max_smooth;
  auto segmented = stream::segment_mesh(input, *gauss, so);
  if (!segmented) {
    const Status& s = segmented.status();
    return Status::error(s.code(), source.name() + ": " + s.where(), s.message());
  }
  const auto t2 = Clock::now();
  const stream::SegmentationResult& r = *segmented;
  if (!path.empty()) GM_RETURN_IF_ERROR(write_segments(path, input, r));
  const auto t3 = Clock::now();
  std::size_t duplicates = 0;
  for (std::size_t d : r.duplicate_labels) duplicates += d;

  SegmentStats stats;
  stats.input_vertices = input.positions.size();
  stats.input_faces = input.triangles.size();
  stats.segments = r.segment_count;
  stats.face_segment = r.face_segment;
  stats.seconds = stream::seconds_between(t0, t3);
  if (r.smooth_cap_hit || r.merges > 0) {
    stats.note = std::string(r.smooth_cap_hit ? "smoothing stopped at the cap " : "") +
                 (r.smooth_cap_hit ? std::to_string(r.smooth_iterations) + " with some Gaussian triangle over g+1 pre-images; " : "") +
                 std::to_string(r.greedy_aggregates) + " greedy aggregates merged into " + std::to_string(r.segment_count) +
                 " segments (genus " + std::to_string(r.genus) + "); " + std::to_string(duplicates) +
                 " labels repeat inside a segment";
  }
  stats.summary = "genus " + std::to_string(r.genus) + ", " + std::to_string(r.segment_count) + " segments, " +
                  std::to_string(r.smooth_iterations) + " smoothing iterations, " + std::to_string(r.poles) + " poles, " +
                  std::to_string(r.patch_count) + " patches";

  const stream::GaussSphere& g = *gauss;
  Json j;
  j["input"] = source.name();
  j["input_vertices"] = input.positions.size();
  j["input_faces"] = input.triangles.size();
  j["euler_characteristic"] = r.euler_characteristic;
  j["genus"] = r.genus;
  j["base"] = stream::gauss_base_name(g.options().base);
  j["frequency"] = g.options().frequency;
  j["gauss_vertices"] = g.vertex_count();
  j["gauss_triangles"] = g.triangle_count();
  j["smooth_iterations"] = r.smooth_iterations;
  j["smooth_cap"] = o.max_smooth;
  j["smooth_cap_hit"] = r.smooth_cap_hit;
  j["max_preimages"] = r.max_preimages;
  j["patches"] = r.patch_count;
  j["noise_patches"] = r.noise_patches;
  j["poles"] = r.poles;
  j["empty_labels"] = r.empty_labels;
  j["pole_patches"] = r.pole_patches;
  j["pole_faces"] = r.pole_faces;
  j["greedy_aggregates"] = r.greedy_aggregates;
  j["merges"] = r.merges;
  j["segments"] = r.segment_count;
  j["segment_faces"] = r.segment_faces;
  j["duplicate_labels"] = r.duplicate_labels;
  j["peak_rss_bytes"] = peak_rss_bytes();
  j["seconds"] = {{"read", stream::seconds_between(t0, t1)}, {"segment", stream::seconds_between(t1, t2)}, {"write", stream::seconds_between(t2, t3)}};
  stats.report_json = j.dump(2);
  return stats;
}

}  // namespace

Result<SegmentStats> segment(const Source& source, const std::string& path, const SegmentOptions& o) {
  return api::guarded("segment", [&] { return segment_job(source, path, o); });
}

}  // namespace gaussmesh
