// The tessellated Gaussian sphere G (paper §3.1, §4; docs/sampling.md): a base polyhedron whose
// faces are split into f² sub-triangles, pushed onto the unit sphere and rotated; O(1) point
// location by central projection; global ids for Gaussian vertices and triangles; adjacency
// tables.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "format/status.h"
#include "stream/core/exact_predicates.h"

namespace gaussmesh::stream {

enum class GaussBase { kTetrahedron, kOctahedron, kIcosahedron };

// "tetra", "octa", "icosa".
const char* gauss_base_name(GaussBase base);

inline constexpr std::uint32_t kMaxGaussFrequency = 512;
// Seed of the default orientation: a fixed pseudo-random rotation, because a mesh plane whose
// normal falls exactly on a Gaussian vertex or edge is a degeneracy (paper §4.1).
inline constexpr std::uint64_t kDefaultGaussSeed = 1;

// A uniformly distributed unit quaternion (w, x, y, z) drawn from seed (Shoemake's method over
// a splitmix64 stream); the same seed gives the same rotation on every platform.
std::array<double, 4> gauss_rotation_from_seed(std::uint64_t seed);

struct GaussSphereOptions {
  GaussBase base = GaussBase::kIcosahedron;
  std::uint32_t frequency = 2;  // f >= 1: f² sub-triangles per base face (--level K: f = 2^K)
  // Unit quaternion (w, x, y, z) taking the canonical tessellation to G; normalized on create.
  std::array<double, 4> rotation = gauss_rotation_from_seed(kDefaultGaussSeed);
};

// Immutable after create(); cheap to share between threads (all queries are const).
//
// Ids: Gaussian vertices 0 .. vertex_count()-1 (base vertices first, then base-edge interiors,
// then base-face interiors; a vertex on a base edge has one id); Gaussian triangles
// 0 .. triangle_count()-1, f² consecutive ids per base face. Triangles are counter-clockwise
// seen from outside the sphere.
class GaussSphere {
 public:
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

  // Errors (kUsage): frequency 0 or above kMaxGaussFrequency; a rotation that is not finite
  // or has zero length.
  static format::Result<GaussSphere> create(const GaussSphereOptions& options);

  const GaussSphereOptions& options() const { return options_; }
  std::size_t vertex_count() const { return vertices_.size(); }
  std::size_t triangle_count() const { return triangle_vertices_.size(); }

  // Unit position of a Gaussian vertex (rotated). Precondition: id < vertex_count().
  const Vec3d& vertex(std::uint32_t id) const { return vertices_[id]; }
  const std::array<std::uint32_t, 3>& triangle_vertices(std::uint32_t t) const {
    return triangle_vertices_[t];
  }
  // Triangle across edge (v[i], v[i+1]) of triangle t; G is closed, so never kNone.
  const std::array<std::uint32_t, 3>& triangle_neighbors(std::uint32_t t) const {
    return triangle_neighbors_[t];
  }
  // Triangles incident on Gaussian vertex v, counter-clockwise around it (3 to 6 of them).
  std::span<const std::uint32_t> vertex_triangles(std::uint32_t v) const {
    return {vertex_triangles_.data() + vertex_offsets_[v],
            vertex_triangles_.data() + vertex_offsets_[v + 1]};
  }
  // Slot j: the position of t in vertex_triangles(triangle_vertices(t)[j]) (0 to 5).
  const std::array<std::uint8_t, 3>& vertex_triangle_slots(std::uint32_t t) const {
    return vertex_triangle_slots_[t];
  }
  bool triangle_has_vertex(std::uint32_t t, std::uint32_t v) const {
    const auto& tv = triangle_vertices_[t];
    return tv[0] == v || tv[1] == v || tv[2] == v;
  }
  bool are_edge_adjacent(std::uint32_t a, std::uint32_t b) const {
    const auto& n = triangle_neighbors_[a];
    return n[0] == b || n[1] == b || n[2] == b;
  }
  // Unit direction through the centroid of triangle t, and the cosine of the largest angle
  // between it and the triangle's corners (a cap that holds the triangle).
  const Vec3d& triangle_center(std::uint32_t t) const { return centers_[t]; }
  double triangle_cap_cos(std::uint32_t t) const { return cap_cos_[t]; }
  // acos(clamp(triangle_cap_cos(t), -1, 1)) (the cap's angular radius), and its cosine and sine,
  // precomputed so that cap searches compare cosines instead of calling acos.
  double triangle_cap_angle(std::uint32_t t) const { return cap_angle_[t].angle; }
  double triangle_cap_angle_cos(std::uint32_t t) const { return cap_angle_[t].cos; }
  double triangle_cap_angle_sin(std::uint32_t t) const { return cap_angle_[t].sin; }

  // The cosine of a lower bound (radians, with a margin of 1e-6) on the angle from any point of
  // a Gaussian triangle t to any Gaussian vertex that is not a corner of t: a cap around a point
  // of t narrower than that angle holds no Gaussian vertex but t's corners.
  double vertex_clearance_cos() const { return clearance_cos_; }

  // The Gaussian triangle holding direction n (any length > 0; the zero vector yields some
  // valid id). O(1): rotate by Rᵀ, pick the base face whose cone holds it (the face plane the
  // ray leaves the base polyhedron through), centrally project onto that flat face, read the
  // cell from barycentric coordinates × f. Central projection maps great circles to lines, so
  // the cells are exactly G's spherical triangles. A direction on a cell boundary (to within
  // double rounding) goes to a deterministic neighbour: the lowest base face, then the
  // lower row/column and the "up" cell.
  std::uint32_t locate(const Vec3d& n) const;
  // locate() of many float directions (widened exactly to double): out[i] for directions[i], or
  // `for_zero` for the zero vector. One call per batch lets the table lookup inline into the
  // loop. Precondition: out.size() >= directions.size().
  void locate(std::span<const format::Vec3f> directions, std::span<std::uint32_t> out, std::uint32_t for_zero) const;
  // The same answer as locate() without the fine lookup table: what locate() computes where
  // the table has no answer, and the reference that tests and benchmarks compare it with.
  std::uint32_t locate_without_table(const Vec3d& n) const;
  // Cells per side of each cube face in the fine lookup table of locate() (0: no table), and
  // how many of its cells it answers (one triangle, or two across one edge; the others fall
  // back to the full computation).
  std::uint32_t locate_table_cells() const { return fine_cells_; }

 private:
  GaussSphere() = default;
  void build_locate_table();

  GaussSphereOptions options_;
  std::uint32_t frequency_ = 1;
  double rotation_[3][3] = {};  // R: canonical -> rotated
  // Base polyhedron (canonical frame).
  std::vector<Vec3d> base_vertices_;
  std::vector<std::array<std::uint32_t, 3>> base_faces_;
  std::vector<Vec3d> base_centers_;
  std::vector<std::array<Vec3d, 3>> base_bary_;  // per face: B×C, C×A, A×B
  // Cube map of candidate base faces for locate(): per cell, ids in increasing order.
  std::vector<std::uint16_t> cube_offsets_;
  std::vector<std::uint8_t> cube_faces_;
  // Fine lookup table of locate() (build_locate_table): the axis-aligned cube, each
  // face split into fine_cells_² gnomonic cells (axis, sign, i, j). A cell either lies in one
  // Gaussian triangle (plus == minus), or is cut by one edge of G into a part in `plus` (the
  // inner side of plane `plane`) and a part in `minus`, all with a margin of 1e-9 from the
  // other edges; or it is a fallback cell (plus == kNoFine: the full computation runs).
  static constexpr std::uint16_t kNoFine = 0xFFFF;
  struct FineCell {
    std::uint16_t plus = kNoFine, minus = kNoFine, plane = 0, unused = 0;
  };
  // The table's answer for m (fine: cells² cells per cube face, planes: edge_planes_, half:
  // cells / 2), or kNone (a fallback cell, m within the margin of the cell's edge, or m zero or
  // not finite): locate_without_table() answers then.
  static std::uint32_t locate_in_table(const Vec3d& m, const FineCell* fine, const Vec3d* planes,
                                       std::uint32_t cells, double half);
  std::uint32_t fine_cells_ = 0;
  double fine_half_ = 0;  // fine_cells_ / 2
  std::vector<FineCell> fine_;
  std::vector<Vec3d> edge_planes_;  // unit, at 3 t + i: inner side of edge i of t
  // G.
  std::vector<Vec3d> vertices_;
  std::vector<std::array<std::uint32_t, 3>> triangle_vertices_;
  std::vector<std::array<std::uint32_t, 3>> triangle_neighbors_;
  std::vector<std::uint32_t> vertex_offsets_;
  std::vector<std::uint32_t> vertex_triangles_;
  std::vector<std::array<std::uint8_t, 3>> vertex_triangle_slots_;
  std::vector<Vec3d> centers_;
  std::vector<double> cap_cos_;
  struct CapAngle {
    double angle, cos, sin;
  };
  std::vector<CapAngle> cap_angle_;
  double clearance_cos_ = 1;
};

}  // namespace gaussmesh::stream
