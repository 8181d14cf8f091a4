// Distance between two triangle meshes (`gaussmesh compare`): symmetric Hausdorff and RMS
// distance by dense, seeded, area-weighted surface sampling of each mesh, every sample's
// distance to the other surface found exactly in an AABB tree over its triangles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/exact_predicates.h"  // Vec3d

namespace gaussmesh::stream {

// --- building blocks (exposed for tests and the cross-check program) -------------------------

// Squared distance from p to the closed triangle (a, b, c), exact up to double rounding.
// Degenerate triangles (collinear or coincident corners) are treated as their segments/point.
// If closest is non-null it receives the nearest point of the triangle.
double point_triangle_distance_squared(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                       const Vec3d& c, Vec3d* closest = nullptr);

// A bounding-volume hierarchy of axis-aligned boxes over a mesh's triangles, for nearest-
// surface queries. Built by median splits on the longest axis (O(n log n)); holds a copy of the
// triangles' corners and their indices (40 bytes per triangle) plus about 1 node per 2 triangles. Thread-safe for
// concurrent queries once built.
class TriangleTree {
 public:
  // Precondition: every index in mesh.triangles is < mesh.positions.size().
  explicit TriangleTree(format::MeshView mesh);
  TriangleTree(const TriangleTree&) = delete;
  TriangleTree& operator=(const TriangleTree&) = delete;
  ~TriangleTree();

  // Squared distance from p to the nearest triangle; +infinity for an empty tree. `hint` is a
  // leaf-order triangle index to start from (e.g. the previous answer for a nearby query; any
  // value is valid) and receives the index of the nearest triangle.
  double nearest_distance_squared(const Vec3d& p, std::uint32_t* hint = nullptr) const;
  // The normal (corners' cross product, not normalised) of the triangle at leaf-order index
  // `leaf`, as a query's hint names it.
  Vec3d leaf_normal(std::uint32_t leaf) const;
  // The mesh's index of the triangle at leaf-order index `leaf`.
  std::uint32_t leaf_triangle(std::uint32_t leaf) const;
  std::size_t triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// --- the measure ---------------------------------------------------------------------------------

struct DistanceOptions {
  // Area samples on mesh A; mesh B gets the same density (samples per unit area), so a sample
  // count scales with area: B's count is A's times area(B) / area(A), at most 4x A's.
  std::size_t samples = 400000;
  std::uint64_t seed = 1;
};

// Distances measured from the samples of one mesh to the surface of the other.
struct OneSidedDistance {
  double max = 0;   // over area samples, vertices and edge midpoints (so sharp features count)
  Vec3d max_at{};   // the sample that is `max` away (the first in triangle order on a tie)
  double rms = 0;   // root mean square over area samples only (area-weighted)
  double mean = 0;  // mean over area samples only
  std::size_t area_samples = 0;
  std::size_t feature_samples = 0;  // referenced vertices + one midpoint per edge
  // Triangles that face away from the other surface: their normal and that of the other mesh's
  // triangle nearest their centroid point apart (negative dot product). A fold, a flipped face,
  // or a sliver turned over; degenerate triangles are left out. Their area in the same units
  // squared, and the whole mesh's area, for the share.
  std::size_t facing_away = 0;
  double facing_away_area = 0, area = 0;
  double facing_away_pct() const { return area > 0 ? 100 * facing_away_area / area : 0; }
};

struct MeshDistance {
  OneSidedDistance a_to_b, b_to_a;
  double hausdorff = 0;  // max(a_to_b.max, b_to_a.max)
  double rms = 0;        // sqrt((a_to_b.rms^2 + b_to_a.rms^2) / 2): both directions weigh alike
  double diagonal = 0;   // of A's bounding box (referenced vertices)
  // In percent of A's bounding-box diagonal.
  double hausdorff_pct() const { return 100 * hausdorff / diagonal; }
  double rms_pct() const { return 100 * rms / diagonal; }
  static double pct(double distance, double diagonal) { return 100 * distance / diagonal; }
};

// Measures a against b. Deterministic for a given seed whatever the number of threads (oneTBB,
// deterministic reduction). Memory: one TriangleTree per mesh; samples are never stored.
// Errors (kBadInput, where "A" or "B"): no triangles, an index out of range, a non-finite
// coordinate, or A's bounding box of zero diagonal; kUsage for samples == 0.
format::Result<MeshDistance> mesh_distance(format::MeshView a, format::MeshView b,
                                           const DistanceOptions& options = {});

}  // namespace gaussmesh::stream
