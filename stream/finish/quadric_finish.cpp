#include "stream/finish/quadric_finish.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "stream/core/stopwatch.h"

namespace gaussmesh::stream {

FinishOptions resolve_finish(const FinishTarget& target, std::uint64_t input_faces, double diagonal) {
  FinishOptions o;
  if (target.faces > 0) o.target_faces = target.faces;
  if (target.ratio > 0) {
    const auto by_ratio = std::max<std::uint64_t>(1, std::uint64_t(std::llround(target.ratio * double(input_faces))));
    o.target_faces = o.target_faces > 0 ? std::min(o.target_faces, by_ratio) : by_ratio;
  }
  if (target.max_error > 0) o.max_error = target.max_error_relative ? target.max_error / 100 * diagonal : target.max_error;
  return o;
}

double diagonal_of(const Vec3f& lo, const Vec3f& hi) {
  const double dx = double(hi.x) - double(lo.x), dy = double(hi.y) - double(lo.y), dz = double(hi.z) - double(lo.z);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

format::Status check_finish_target(const FinishOptions& options, std::uint64_t input_faces, const std::string& name) {
  if (options.target_faces > input_faces) {
    return format::Status::error(format::Code::kUsage, name,
                                 "the target of " + std::to_string(options.target_faces) + " faces is above the input's " +
                                     std::to_string(input_faces) + " faces");
  }
  return format::Status();
}

double finite_diagonal(std::span<const Vec3f> positions) {
  Vec3f lo{0, 0, 0}, hi{0, 0, 0};
  bool first = true;
  for (const auto& p : positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    if (first) lo = hi = p, first = false;
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return diagonal_of(lo, hi);
}

std::uint64_t finish_min_samples(const FinishOptions& options, std::uint64_t input_faces) {
  // An error bound wants the finest approximation whatever the face target: a coarse one would
  // be further off than the bound before any collapse.
  const double faces = options.target_faces > 0 && !std::isfinite(options.max_error) ? double(options.target_faces)
                                                                                     : double(input_faces) / 8;
  // No more than the finest approximations reach: about as many samples as the input has
  // vertices, which is about half its faces.
  const double cap = kFinishMaxSampleShare * double(input_faces);
  return std::max<std::uint64_t>(1, std::uint64_t(std::min(cap, std::ceil(kFinishOversampling * faces / 2))));
}

format::Result<FinishResult> finish_from_sums(MeshView approximation, const QuadricFrame& frame,
                                              const std::vector<FixedQuadric>& sums, const FinishOptions& options,
                                              bool sweeps, std::span<const std::uint32_t> corner_wedges,
                                              std::span<const ColourSum> colours) {
  const auto start = Clock::now();
  DecimationOptions d;
  d.target_faces = options.target_faces;
  d.max_error = options.max_error / kMaxErrorMargin / frame.scale;
  if (sweeps) {
    const std::uint64_t faces = approximation.triangles.size();
    d.sweep_to_faces = std::uint64_t(std::ceil(sweep_share_of_faces(faces, options.target_faces) * double(faces)));
  }
  d.corner_wedges = corner_wedges;
  d.colours = colours;
  auto decimated = decimate(approximation, sums, frame, d);
  if (!decimated) return decimated.status();
  FinishResult r;
  if (!corner_wedges.empty()) {
    r.source = std::move(decimated->source);
    r.corner_wedges = std::move(decimated->corner_wedges);
    r.region = std::move(decimated->region);
  }
  r.approximation_faces = approximation.triangles.size();
  r.mesh = std::move(decimated->mesh);
  r.collapses = decimated->collapses;
  r.refused = decimated->refused;
  r.estimated_error = decimated->estimated_error * frame.scale;
  r.reached_target = decimated->reached_target;
  if (options.target_faces > 0 && r.approximation_faces <= options.target_faces) r.stopped_by = "approximation";
  else if (options.target_faces == 0 || decimated->reached_target) r.stopped_by = decimated->over_error > 0 && options.target_faces == 0 ? "max_error" : "target";
  else r.stopped_by = decimated->over_error > 0 ? "max_error" : "topology";
  r.seconds_decimate = seconds_since(start);
  return r;
}

format::Result<FinishResult> finish_in_core(MeshView input, MeshView approximation, const FinishOptions& options) {
  const auto start = Clock::now();
  const FaceQuadrics quadrics(approximation);
  // Fixed-point sums: the split over threads does not change the result.
  tbb::enumerable_thread_specific<FaceQuadrics::Accumulator> partial([&] { return quadrics.new_accumulator(); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, input.triangles.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      auto& acc = partial.local();
                      for (std::size_t f = range.begin(); f < range.end(); ++f) {
                        const auto& t = input.triangles[f];
                        quadrics.add_face(input.positions[t.v[0]], input.positions[t.v[1]], input.positions[t.v[2]], acc);
                      }
                    });
  std::vector<FixedQuadric> sums = quadrics.new_sums();
  for (const auto& part : partial) add_sums(sums, part.sums);
  const double seconds_quadrics = seconds_since(start);
  auto r = finish_from_sums(approximation, quadrics.frame(), sums, options);
  if (r) r->seconds_quadrics = seconds_quadrics;
  return r;
}

bool finish_collapses_input(const FinishOptions& options, std::uint64_t input_faces) {
  if (std::isfinite(options.max_error)) return true;
  return options.target_faces > 0 &&
         kFinishOversampling * double(options.target_faces) / 2 >= kFinishInputShare * double(input_faces);
}

Mesh compact_input(std::span<const Vec3f> positions, std::span<const Triangle> faces) {
  auto repeated = [](const Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; };
  std::vector<std::uint32_t> index(positions.size(), UINT32_MAX);
  for (const auto& t : faces)
    if (!repeated(t))
      for (auto v : t.v) index[v] = 0;
  Mesh m;
  for (std::size_t v = 0; v < positions.size(); ++v) {
    if (index[v] == UINT32_MAX) continue;
    index[v] = std::uint32_t(m.positions.size());
    m.positions.push_back(positions[v]);
  }
  for (const auto& t : faces)
    if (!repeated(t)) m.triangles.push_back({{index[t.v[0]], index[t.v[1]], index[t.v[2]]}});
  return m;
}

bool own_face_quadric(const Vec3dq& p0, const Vec3dq& p1, const Vec3dq& p2, FixedQuadric& out) {
  const Vec3dq e1{p1.x - p0.x, p1.y - p0.y, p1.z - p0.z}, e2{p2.x - p0.x, p2.y - p0.y, p2.z - p0.z};
  const Vec3dq n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
  const double length = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
  if (!(length > 0) || !std::isfinite(length)) return false;
  const Vec3dq unit{n.x / length, n.y / length, n.z / length};
  out = FixedQuadric::from(Quadric::plane(unit, -(unit.x * p0.x + unit.y * p0.y + unit.z * p0.z), length / 2));
  return true;
}

void add_own_faces(MeshView mesh, std::span<const Triangle> faces, const QuadricFrame& frame,
                   std::vector<FixedQuadric>& sums) {
  for (const auto& t : faces) {
    const auto& a = mesh.positions[t.v[0]];
    const auto& b = mesh.positions[t.v[1]];
    const auto& c = mesh.positions[t.v[2]];
    FixedQuadric q;
    if (!own_face_quadric(frame.to_frame(a.x, a.y, a.z), frame.to_frame(b.x, b.y, b.z), frame.to_frame(c.x, c.y, c.z), q))
      continue;
    for (auto v : t.v) sums[v] += q;
  }
}

format::Result<FinishResult> finish_input(MeshView compact, const FinishOptions& options,
                                          std::span<const std::uint32_t> corner_wedges,
                                          std::span<const FixedQuadric> colour_quadrics,
                                          std::span<const ColourSum> colours) {
  const auto start = Clock::now();
  const QuadricFrame frame = frame_of(compact);
  // Fixed-point sums: the split over threads does not change the result.
  tbb::enumerable_thread_specific<std::vector<FixedQuadric>> partial(
      [&] { return std::vector<FixedQuadric>(compact.positions.size()); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, compact.triangles.size(), 16384),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      add_own_faces(compact, compact.triangles.subspan(range.begin(), range.size()), frame,
                                    partial.local());
                    });
  std::vector<FixedQuadric> sums(compact.positions.size());
  for (const auto& part : partial) add_sums(sums, part);
  if (colour_quadrics.size() == sums.size())
    for (std::size_t v = 0; v < sums.size(); ++v) sums[v] += colour_quadrics[v];
  const double seconds_quadrics = seconds_since(start);
  auto r = finish_from_sums(compact, frame, sums, options, /*sweeps=*/true, corner_wedges,
                            colours.size() == sums.size() ? colours : std::span<const ColourSum>{});
  if (r) r->seconds_quadrics = seconds_quadrics;
  return r;
}

}  // namespace gaussmesh::stream
