// gaussmesh::compare: symmetric Hausdorff and RMS distance between two meshes.
#include <optional>

#include <tbb/global_control.h>

#include "api/internal.h"
#include "stream/analysis/mesh_distance.h"
#include "stream/core/stopwatch.h"

namespace gaussmesh {
namespace {

OneSidedDistance public_side(const stream::OneSidedDistance& d) {
  return {d.max,
          {d.max_at.x, d.max_at.y, d.max_at.z},
          d.rms,
          d.mean,
          d.area_samples,
          d.feature_samples,
          d.facing_away,
          d.facing_away_pct()};
}

api::Json side_json(const OneSidedDistance& d, const Distance& all) {
  api::Json j;
  j["max_pct"] = all.pct(d.max);
  j["max_at"] = d.max_at;
  j["rms_pct"] = all.pct(d.rms);
  j["mean_pct"] = all.pct(d.mean);
  j["area_samples"] = d.area_samples;
  j["feature_samples"] = d.feature_samples;
  j["facing_away_faces"] = d.facing_away_faces;
  j["facing_away_area_pct"] = d.facing_away_area_pct;
  return j;
}

}  // namespace

namespace {

Result<Distance> compare_job(const Source& a, const Source& b, const CompareOptions& options) {
  if (a.kind == Source::Kind::kStandardInput && b.kind == Source::Kind::kStandardInput) {
    return Status::error(Code::kUsage, "compare", "only one of A and B can be '-'");
  }
  if (options.samples == 0) return Status::error(Code::kUsage, "--samples", "must be at least 1");
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(a, "compare"));
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(b, "compare"));
  std::optional<tbb::global_control> thread_limit;
  if (options.threads > 0) thread_limit.emplace(tbb::global_control::max_allowed_parallelism, options.threads);
  const auto t0 = stream::Clock::now();
  auto mesh_a = api::load(a);  // errors name the file and place
  if (!mesh_a) return mesh_a.status();
  auto mesh_b = api::load(b);
  if (!mesh_b) return mesh_b.status();
  const auto t1 = stream::Clock::now();
  stream::DistanceOptions distance_options;
  distance_options.samples = options.samples;
  distance_options.seed = options.seed;
  auto d = stream::mesh_distance(mesh_a->view, mesh_b->view, distance_options);
  if (!d) {
    // The engine names the mesh "A" or "B"; the caller knows it by its source's name.
    const Status& s = d.status();
    if (s.where() == "A") return Status::error(s.code(), a.name(), s.message());
    if (s.where() == "B") return Status::error(s.code(), b.name(), s.message());
    return s;
  }
  Distance out;
  out.diagonal = d->diagonal;
  out.a_to_b = public_side(d->a_to_b);
  out.b_to_a = public_side(d->b_to_a);
  out.hausdorff = d->hausdorff;
  out.rms = d->rms;
  const double read_s = stream::seconds_between(t0, t1);
  const double measure_s = stream::seconds_since(t1);
  out.seconds = read_s + measure_s;

  api::Json j;
  j["a"] = a.name();
  j["b"] = b.name();
  j["a_vertices"] = mesh_a->view.positions.size();
  j["a_faces"] = mesh_a->view.triangles.size();
  j["b_vertices"] = mesh_b->view.positions.size();
  j["b_faces"] = mesh_b->view.triangles.size();
  j["diagonal"] = d->diagonal;
  j["hausdorff_pct"] = d->hausdorff_pct();
  j["rms_pct"] = d->rms_pct();
  j["hausdorff_a_to_b_pct"] = out.pct(d->a_to_b.max);
  j["hausdorff_b_to_a_pct"] = out.pct(d->b_to_a.max);
  j["rms_a_to_b_pct"] = out.pct(d->a_to_b.rms);
  j["rms_b_to_a_pct"] = out.pct(d->b_to_a.rms);
  j["hausdorff"] = d->hausdorff;
  j["rms"] = d->rms;
  j["samples_a"] = d->a_to_b.area_samples + d->a_to_b.feature_samples;
  j["samples_b"] = d->b_to_a.area_samples + d->b_to_a.feature_samples;
  j["a_to_b"] = side_json(out.a_to_b, out);
  j["b_to_a"] = side_json(out.b_to_a, out);
  j["seed"] = options.seed;
  j["samples_option"] = options.samples;
  j["peak_rss_bytes"] = peak_rss_bytes();
  j["seconds"] = {{"read", read_s}, {"measure", measure_s}};
  out.report_json = j.dump(2);
  return out;
}

}  // namespace

Result<Distance> compare(const Source& a, const Source& b, const CompareOptions& options) {
  return api::guarded("compare", [&] { return compare_job(a, b, options); });
}

}  // namespace gaussmesh
