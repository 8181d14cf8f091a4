// The first half of the quadric finish (Garland & Shaffer's multiphase simplification): every
// input face's plane quadric, weighted by its area, goes to one vertex of the Gauss
// approximation — the vertex nearest to the face's centroid among those whose normal faces the
// same side as the face (so the two sides of a thin plate keep their own planes). The sums are
// fixed point (FixedQuadric): any order of the faces, any split into chunks or threads, gives the
// same bits, which is what keeps the out-of-core answer equal to the in-core one.
#pragma once

#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "stream/core/mesh.h"
#include "stream/finish/quadric.h"

namespace gaussmesh::stream {

class FaceQuadrics {
 public:
  // `approximation` is the Gauss mesh the quadrics are for; its bounding box sets the frame.
  explicit FaceQuadrics(MeshView approximation);

  const QuadricFrame& frame() const { return frame_; }
  std::size_t vertex_count() const { return positions_.size(); }
  // One thread's sums (one per approximation vertex) and its cache of the cells around the last
  // face's cell (consecutive faces are mostly neighbours; the cache changes no answer).
  struct Accumulator {
    std::vector<FixedQuadric> sums;
    std::uint64_t cached_cell = UINT64_MAX;
    std::vector<std::uint32_t> centre, ring;  // the cell's vertices, its 26 neighbours'
  };
  Accumulator new_accumulator() const { return {std::vector<FixedQuadric>(positions_.size()), UINT64_MAX, {}, {}}; }
  std::vector<FixedQuadric> new_sums() const { return std::vector<FixedQuadric>(positions_.size()); }

  // Adds the face (a, b, c) to `into`. Zero-area faces add nothing. Const: threads may add to
  // accumulators of their own at once.
  void add_face(const Vec3f& a, const Vec3f& b, const Vec3f& c, Accumulator& into) const;

  // Every face of `mesh`, on the calling thread.
  void add_mesh(MeshView mesh, Accumulator& into) const;

 private:
  // For each of `count` (1 to 3) points in the first one's cell: the nearest vertex whose normal
  // faces `normal`'s side (found within a few shells of cells), else the nearest of any.
  void nearest(const Vec3dq* points, int count, const Vec3dq& normal, std::uint32_t* out) const;
  // The same for points of cell `key` = (ci, cj, ck), from the accumulator's cache of shells 0
  // and 1; false if a point needs a farther shell (then nothing is written).
  bool nearest_cached(const Vec3dq* points, const Vec3dq& normal, std::uint64_t key, std::int64_t ci,
                      std::int64_t cj, std::int64_t ck, Accumulator& cache, std::uint32_t* out) const;
  std::uint64_t cell_key(std::int64_t i, std::int64_t j, std::int64_t k) const;

  QuadricFrame frame_;
  std::vector<Vec3dq> positions_;  // in the frame
  std::vector<Vec3dq> normals_;    // area-weighted, not normalised
  double cell_ = 1;                // grid cell size, in the frame
  std::vector<std::uint32_t> cell_vertices_;  // vertex ids grouped by cell
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cells_;  // key -> [begin, end)
};

// The frame quadrics live in: the mesh's bounding box, scaled to unit diagonal.
QuadricFrame frame_of(MeshView mesh);

// Sums a set of per-thread or per-chunk sums into `into`.
void add_sums(std::vector<FixedQuadric>& into, const std::vector<FixedQuadric>& from);

}  // namespace gaussmesh::stream
