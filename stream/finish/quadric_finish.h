// The quadric finish (docs/finish.md): turns the Gauss approximation into the mesh the user asked
// for — a face target, an error bound — by QEM collapses with the input's own plane quadrics
// (face_quadrics.h, quadric_decimation.h). In core the input faces are at hand; out of core the
// pipeline adds them chunk by chunk into the same fixed-point sums, so both reach the same mesh.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>

#include "format/status.h"
#include "stream/core/mesh.h"
#include "stream/finish/face_quadrics.h"
#include "stream/finish/quadric_decimation.h"

namespace gaussmesh::stream {

// The collapses' RMS estimate is held to max_error / kMaxErrorMargin: a Hausdorff distance runs
// several times the RMS one (docs/finish.md, "The error bound", has the measured ratios).
inline constexpr double kMaxErrorMargin = 8;

struct FinishOptions {
  std::uint64_t target_faces = 0;                               // 0: no face target
  double max_error = std::numeric_limits<double>::infinity();  // estimated error bound, input units
  bool enabled() const { return target_faces > 0 || std::isfinite(max_error); }
};

// What the user asked for, before the input is known.
struct FinishTarget {
  std::uint64_t faces = 0;  // 0: none
  double ratio = 0;         // of the input's faces; 0: none
  double max_error = 0;     // 0: none; absolute, or percent of the diagonal when relative
  bool max_error_relative = false;
  bool any() const { return faces > 0 || ratio > 0 || max_error > 0; }
};

// The face target is the smaller of `faces` and round(ratio × input_faces) (at least 1); the
// error bound is made absolute with the input's bounding-box diagonal.
FinishOptions resolve_finish(const FinishTarget& target, std::uint64_t input_faces, double diagonal);

// The bounding-box diagonal the relative error bound refers to, from the bounds of the input's
// finite positions (the same doubles in and out of core).
double diagonal_of(const Vec3f& lo, const Vec3f& hi);
// The same from the positions themselves (in core), skipping the non-finite ones as the
// partition's bounds do.
double finite_diagonal(std::span<const Vec3f> positions);

// kUsage when the face target is above the input's faces (`name`: the input, for the message):
// the finish only removes faces, and an output as large as the input is the input.
format::Status check_finish_target(const FinishOptions& options, std::uint64_t input_faces, const std::string& name);

// How many samples the Gauss approximation should reach (--frequency auto) so that the finish
// has kFinishOversampling times the target's faces to collapse from (about two faces per
// sample), at most kFinishMaxSampleShare of the input's faces; with an error bound (with or
// without a face target), an eighth of the input's faces. docs/finish.md has the measurements behind both.
inline constexpr double kFinishOversampling = 8;
inline constexpr double kFinishMaxSampleShare = 0.45;
std::uint64_t finish_min_samples(const FinishOptions& options, std::uint64_t input_faces);

// Out of core, the peak of the stitch, mesh and finish passes with an approximation of `samples`
// samples (about two faces each, kFinishBytesPerFace a face) and G at `frequency` (~3 KB per
// f²), on top of what the process keeps from the earlier passes (12 MiB, and up to 24 MiB more
// as the input grows). Fitted to measured peaks with a margin (docs/finish.md, "Memory"): an
// estimate, not a bound.
inline constexpr std::uint64_t kFinishBytesPerFace = 2048;
inline constexpr std::uint64_t kGaussBytesPerFrequencySquared = 3072;
inline std::uint64_t kept_memory_estimate(std::uint64_t input_faces) {
  return (std::uint64_t{12} << 20) + std::min<std::uint64_t>(std::uint64_t{24} << 20, 256 * input_faces);
}
inline std::uint64_t finish_memory_estimate(std::uint64_t samples, std::uint32_t frequency, std::uint64_t input_faces) {
  return kept_memory_estimate(input_faces) + kGaussBytesPerFrequencySquared * frequency * frequency +
         2 * samples * kFinishBytesPerFace;
}

struct FinishResult {
  Mesh mesh;
  std::uint64_t approximation_faces = 0;  // the Gauss approximation's faces, before the finish
  std::uint64_t collapses = 0, refused = 0;
  double estimated_error = 0;  // largest estimated error of a collapse made, input units
  bool reached_target = false;
  // What ended the collapses: "target" (the face target, or no collapse left without one),
  // "max_error" (every further collapse passes the error bound), "topology" (every further one
  // breaks the link condition, flips or degenerates a face), "approximation" (the Gauss
  // approximation had no more faces than the target).
  const char* stopped_by = "target";
  double seconds_quadrics = 0, seconds_decimate = 0;
  // With seams (finish_input's corner_wedges), as DecimationResult: per output vertex its input
  // vertex, per output face corner its wedge, per input vertex its output vertex.
  std::vector<std::uint32_t> source, corner_wedges, region;
};

// Targets above kFinishInputShare of the input's faces (with the oversampling, what would need
// G at frequency 32 or more), and error bounds, collapse the input itself rather than a Gauss
// approximation: finer Gauss approximations cost more than the input's own collapses and are
// further off (docs/finish.md, "The approximation"). Only for an input the collapses can hold (an
// oriented manifold once faces with a repeated corner are left out); else the Gauss one.
inline constexpr double kFinishInputShare = 0.02;
bool finish_collapses_input(const FinishOptions& options, std::uint64_t input_faces);

// The input as the finish collapses it: faces with a repeated corner left out, the vertices
// they use renumbered in id order. `faces` is the input's faces in order; out of core the
// chunks' owned faces sorted by global id are the same list.
Mesh compact_input(std::span<const Vec3f> positions, std::span<const Triangle> faces);

// Garland & Heckbert's quadrics of `mesh` itself: each face's plane to its three corners, in
// `frame` (frame_of(mesh)); fixed point, so any split of the faces reaches the same sums.
void add_own_faces(MeshView mesh, std::span<const Triangle> faces, const QuadricFrame& frame,
                   std::vector<FixedQuadric>& sums);
// One face's plane quadric, weighted by its area (corners in frame units); false for a
// degenerate face, which adds nothing.
bool own_face_quadric(const Vec3dq& p0, const Vec3dq& p1, const Vec3dq& p2, FixedQuadric& out);

// Out of core, the peak of collapsing the input itself: kInputBytesPerFace a face on top of the
// kept memory of finish_memory_estimate.
inline constexpr std::uint64_t kInputBytesPerFace = 512;
inline std::uint64_t input_finish_memory_estimate(std::uint64_t input_faces) {
  return kept_memory_estimate(input_faces) + kInputBytesPerFace * input_faces;
}

// The collapses on the input itself (compact_input), both halves, on every core. kProcessing
// when the input is not an oriented manifold (the caller then takes the Gauss approximation).
// `corner_wedges` (empty: none): the seams to keep (DecimationOptions::corner_wedges).
// `colour_quadrics`, `colours` (empty: none): the colour terms, one per vertex, in
// frame_of(compact) units (colour_quadrics.h).
format::Result<FinishResult> finish_input(MeshView compact, const FinishOptions& options,
                                          std::span<const std::uint32_t> corner_wedges = {},
                                          std::span<const FixedQuadric> colour_quadrics = {},
                                          std::span<const ColourSum> colours = {});

// The decimation half, once `sums` (in `frame`) holds every input face (FaceQuadrics::add_face);
// with `sweeps`, the first collapses are sweeps (DecimationOptions::sweep_to_faces) where
// sweep_share_of_faces allows them.
format::Result<FinishResult> finish_from_sums(MeshView approximation, const QuadricFrame& frame,
                                              const std::vector<FixedQuadric>& sums, const FinishOptions& options,
                                              bool sweeps = false, std::span<const std::uint32_t> corner_wedges = {},
                                              std::span<const ColourSum> colours = {});

// Both halves in core: the input's faces are added on every core.
format::Result<FinishResult> finish_in_core(MeshView input, MeshView approximation, const FinishOptions& options);

}  // namespace gaussmesh::stream
