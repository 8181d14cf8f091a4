// The tessellated Gaussian sphere G (paper §3.1 "iterated regular subdivision of the faces of a
// regular polyhedron", §4.1 orientation): construction, ids, adjacency, location.
#include "stream/core/gauss_sphere.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <string>

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double unit_double(std::uint64_t& state) {
  return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53;
}

Vec3d normalized(const Vec3d& v) {
  const double len = std::sqrt(dot(v, v));
  return len > 0 ? (1.0 / len) * v : v;
}

// Vertices of the regular base polyhedra, on the unit sphere after normalization.
std::vector<Vec3d> base_polyhedron_vertices(GaussBase base) {
  switch (base) {
    case GaussBase::kTetrahedron:
      return {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    case GaussBase::kOctahedron:
      return {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    case GaussBase::kIcosahedron: {
      const double p = std::numbers::phi;
      std::vector<Vec3d> v;
      for (double s : {-1.0, 1.0}) {
        for (double t : {-1.0, 1.0}) {
          v.push_back({0, s, t * p});
          v.push_back({s, t * p, 0});
          v.push_back({t * p, 0, s});
        }
      }
      return v;
    }
  }
  return {};
}

// Faces of a regular polyhedron: the triples of vertices that are pairwise at the shortest
// vertex distance, oriented counter-clockwise seen from outside.
std::vector<std::array<std::uint32_t, 3>> base_polyhedron_faces(const std::vector<Vec3d>& v) {
  const std::uint32_t n = static_cast<std::uint32_t>(v.size());
  double shortest = 1e300;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j) shortest = std::min(shortest, dot(v[i] - v[j], v[i] - v[j]));
  auto is_edge = [&](std::uint32_t i, std::uint32_t j) {
    return dot(v[i] - v[j], v[i] - v[j]) < shortest * 1.01;
  };
  std::vector<std::array<std::uint32_t, 3>> faces;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j)
      for (std::uint32_t k = j + 1; k < n; ++k)
        if (is_edge(i, j) && is_edge(j, k) && is_edge(i, k)) {
          if (dot(cross(v[j] - v[i], v[k] - v[i]), v[i]) > 0) faces.push_back({i, j, k});
          else faces.push_back({i, k, j});
        }
  return faces;
}

// Cube map of the base faces a direction can pick (canonical frame): each cube face is split
// into kCubeCells² gnomonic cells; a cell lists, in increasing id, every base face whose centre
// can be the most aligned with some direction in the cell. A face is left out only when its
// centre is farther (in angle) from every point of the cell, by 1e-6 rad, than some other
// centre is from all of them: it can never win, not even by rounding, so the argmax over the
// list (first maximum in id order) equals the argmax over all faces.
constexpr int kCubeCells = 8;

Vec3d cube_direction(int axis, int sign, double u, double v) {
  double c[3];
  c[axis] = sign;
  c[(axis + 1) % 3] = u;
  c[(axis + 2) % 3] = v;
  return normalized(Vec3d{c[0], c[1], c[2]});
}

double angle_between(const Vec3d& a, const Vec3d& b) { return std::acos(std::clamp(dot(a, b), -1.0, 1.0)); }

}  // namespace

const char* gauss_base_name(GaussBase base) {
  switch (base) {
    case GaussBase::kTetrahedron: return "tetra";
    case GaussBase::kOctahedron: return "octa";
    case GaussBase::kIcosahedron: return "icosa";
  }
  return "?";
}

std::array<double, 4> gauss_rotation_from_seed(std::uint64_t seed) {
  std::uint64_t state = seed;
  const double u1 = unit_double(state), u2 = unit_double(state), u3 = unit_double(state);
  const double two_pi = 2 * std::numbers::pi;
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  return {b * std::cos(two_pi * u3), a * std::sin(two_pi * u2), a * std::cos(two_pi * u2),
          b * std::sin(two_pi * u3)};
}

format::Result<GaussSphere> GaussSphere::create(const GaussSphereOptions& options) {
  const std::uint32_t f = options.frequency;
  if (f < 1 || f > kMaxGaussFrequency) {
    return Status::error(Code::kUsage, "gauss sphere",
                         "frequency must be between 1 and " + std::to_string(kMaxGaussFrequency) +
                             ", got " + std::to_string(f));
  }
  auto q = options.rotation;
  const double qlen = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!std::isfinite(qlen) || qlen < 1e-12) {
    return Status::error(Code::kUsage, "gauss sphere", "rotation quaternion must be finite and non-zero");
  }
  for (double& c : q) c /= qlen;

  GaussSphere g;
  g.options_ = options;
  g.options_.rotation = q;
  g.frequency_ = f;
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  std::copy(&r[0][0], &r[0][0] + 9, &g.rotation_[0][0]);
  auto rotate = [&](const Vec3d& p) {
    return Vec3d{r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z,
                 r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z,
                 r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z};
  };

  g.base_vertices_ = base_polyhedron_vertices(options.base);
  for (Vec3d& v : g.base_vertices_) v = normalized(v);
  g.base_faces_ = base_polyhedron_faces(g.base_vertices_);
  const auto& bv = g.base_vertices_;
  for (const auto& face : g.base_faces_) {
    const Vec3d& a = bv[face[0]];
    const Vec3d& b = bv[face[1]];
    const Vec3d& c = bv[face[2]];
    g.base_centers_.push_back(normalized(a + b + c));
    g.base_bary_.push_back({cross(b, c), cross(c, a), cross(a, b)});
  }

  // Cube map of candidate base faces (see cube_direction): cell (axis, sign, i, j).
  {
    const std::size_t cells = 6 * kCubeCells * kCubeCells;
    g.cube_offsets_.assign(cells + 1, 0);
    g.cube_faces_.clear();
    const std::size_t nbf = g.base_centers_.size();
    std::vector<double> gamma(nbf);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side)
        for (int i = 0; i < kCubeCells; ++i)
          for (int j = 0; j < kCubeCells; ++j) {
            const double step = 2.0 / kCubeCells;
            const double u0 = -1 + i * step, v0 = -1 + j * step;
            const int sign = side == 0 ? 1 : -1;
            const Vec3d d = cube_direction(axis, sign, u0 + step / 2, v0 + step / 2);
            double radius = 0;
            for (int corner = 0; corner < 4; ++corner)
              radius = std::max(radius, angle_between(d, cube_direction(axis, sign, u0 + step * (corner & 1),
                                                                           v0 + step * (corner >> 1))));
            radius += 1e-6;
            double best_far = 1e300;
            for (std::size_t k = 0; k < nbf; ++k) {
              gamma[k] = angle_between(d, g.base_centers_[k]);
              best_far = std::min(best_far, gamma[k] + radius);
            }
            for (std::size_t k = 0; k < nbf; ++k)
              if (gamma[k] - radius <= best_far + 1e-6) g.cube_faces_.push_back(static_cast<std::uint8_t>(k));
            g.cube_offsets_[(axis * 2 + side) * kCubeCells * kCubeCells + i * kCubeCells + j + 1] =
                static_cast<std::uint16_t>(g.cube_faces_.size());
          }
  }

  // Base edges, numbered in order of their sorted endpoint pairs.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> base_edges;
  for (const auto& face : g.base_faces_)
    for (int i = 0; i < 3; ++i)
      base_edges.emplace_back(std::min(face[i], face[(i + 1) % 3]), std::max(face[i], face[(i + 1) % 3]));
  std::sort(base_edges.begin(), base_edges.end());
  base_edges.erase(std::unique(base_edges.begin(), base_edges.end()), base_edges.end());
  auto edge_index = [&](std::uint32_t a, std::uint32_t b) {
    const auto key = std::make_pair(std::min(a, b), std::max(a, b));
    return static_cast<std::uint32_t>(std::lower_bound(base_edges.begin(), base_edges.end(), key) -
                                      base_edges.begin());
  };

  const std::uint32_t nb = static_cast<std::uint32_t>(bv.size());
  const std::uint32_t ne = static_cast<std::uint32_t>(base_edges.size());
  const std::uint32_t nf = static_cast<std::uint32_t>(g.base_faces_.size());
  const std::uint32_t interior_per_face = f >= 3 ? (f - 1) * (f - 2) / 2 : 0;
  const std::uint32_t vertex_total = nb + ne * (f - 1) + nf * interior_per_face;
  g.vertices_.assign(vertex_total, Vec3d{});
  std::vector<bool> placed(vertex_total, false);

  // Grid point (a, b) of a face (A, B, C) is ((f-a-b) A + a B + b C) / f, a, b >= 0, a+b <= f.
  const std::uint32_t grid_size = (f + 1) * (f + 2) / 2;
  std::vector<std::uint32_t> grid(grid_size);
  auto grid_slot = [f](std::uint32_t a, std::uint32_t b) { return b * (f + 1) - b * (b - 1) / 2 + a; };
  auto edge_vertex = [&](std::uint32_t from, std::uint32_t to, std::uint32_t t) {
    // t-th point (0 < t < f) from base vertex `from` towards `to`.
    const std::uint32_t e = edge_index(from, to);
    const std::uint32_t along = from < to ? t : f - t;
    return nb + e * (f - 1) + (along - 1);
  };
  g.triangle_vertices_.reserve(static_cast<std::size_t>(nf) * f * f);
  for (std::uint32_t fi = 0; fi < nf; ++fi) {
    const auto& face = g.base_faces_[fi];
    const Vec3d& va = bv[face[0]];
    const Vec3d& vb = bv[face[1]];
    const Vec3d& vc = bv[face[2]];
    std::uint32_t interior = 0;
    for (std::uint32_t b = 0; b <= f; ++b) {
      for (std::uint32_t a = 0; a + b <= f; ++a) {
        const std::uint32_t c = f - a - b;
        std::uint32_t id;
        if (a == 0 && b == 0) id = face[0];
        else if (a == f) id = face[1];
        else if (b == f) id = face[2];
        else if (b == 0) id = edge_vertex(face[0], face[1], a);
        else if (a == 0) id = edge_vertex(face[0], face[2], b);
        else if (c == 0) id = edge_vertex(face[1], face[2], b);
        else id = nb + ne * (f - 1) + fi * interior_per_face + interior++;
        grid[grid_slot(a, b)] = id;
        if (!placed[id]) {
          placed[id] = true;
          g.vertices_[id] = rotate(normalized(static_cast<double>(c) * va + static_cast<double>(a) * vb +
                                              static_cast<double>(b) * vc));
        }
      }
    }
    // Row b holds up cells a = 0..f-1-b and down cells a = 0..f-2-b, interleaved (2a + down).
    for (std::uint32_t b = 0; b < f; ++b) {
      for (std::uint32_t a = 0; a + b < f; ++a) {
        g.triangle_vertices_.push_back({grid[grid_slot(a, b)], grid[grid_slot(a + 1, b)], grid[grid_slot(a, b + 1)]});
        if (a + b + 2 <= f) {
          g.triangle_vertices_.push_back(
              {grid[grid_slot(a + 1, b)], grid[grid_slot(a + 1, b + 1)], grid[grid_slot(a, b + 1)]});
        }
      }
    }
  }

  // Edge adjacency: sort directed edges and pair each with its reverse.
  const std::size_t nt = g.triangle_vertices_.size();
  struct DirectedEdge {
    std::uint64_t key;  // from << 32 | to
    std::uint32_t slot;  // 3 t + i
  };
  std::vector<DirectedEdge> edges;
  edges.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t)
    for (int i = 0; i < 3; ++i) {
      const std::uint64_t from = g.triangle_vertices_[t][i], to = g.triangle_vertices_[t][(i + 1) % 3];
      edges.push_back({from << 32 | to, static_cast<std::uint32_t>(3 * t + i)});
    }
  std::sort(edges.begin(), edges.end(), [](const DirectedEdge& l, const DirectedEdge& r) { return l.key < r.key; });
  g.triangle_neighbors_.assign(nt, {kNone, kNone, kNone});
  for (const DirectedEdge& e : edges) {
    const std::uint64_t reverse = (e.key << 32) | (e.key >> 32);
    auto it = std::lower_bound(edges.begin(), edges.end(), reverse,
                               [](const DirectedEdge& l, std::uint64_t k) { return l.key < k; });
    if (it != edges.end() && it->key == reverse) g.triangle_neighbors_[e.slot / 3][e.slot % 3] = it->slot / 3;
  }

  // Vertex-triangle incidence, counter-clockwise: from a triangle with corner v, the next one
  // counter-clockwise is the neighbour across the edge (prev, v).
  g.vertex_offsets_.assign(vertex_total + 1, 0);
  for (const auto& tv : g.triangle_vertices_)
    for (std::uint32_t v : tv) ++g.vertex_offsets_[v + 1];
  for (std::uint32_t v = 0; v < vertex_total; ++v) g.vertex_offsets_[v + 1] += g.vertex_offsets_[v];
  std::vector<std::uint32_t> first(vertex_total, kNone);
  for (std::size_t t = 0; t < nt; ++t)
    for (std::uint32_t v : g.triangle_vertices_[t])
      if (first[v] == kNone) first[v] = static_cast<std::uint32_t>(t);
  g.vertex_triangles_.assign(g.vertex_offsets_[vertex_total], kNone);
  g.vertex_triangle_slots_.assign(nt, {0, 0, 0});
  for (std::uint32_t v = 0; v < vertex_total; ++v) {
    std::uint32_t t = first[v];
    for (std::uint32_t k = g.vertex_offsets_[v]; k < g.vertex_offsets_[v + 1]; ++k) {
      g.vertex_triangles_[k] = t;
      const auto& tv = g.triangle_vertices_[t];
      const int i = tv[0] == v ? 0 : (tv[1] == v ? 1 : 2);
      g.vertex_triangle_slots_[t][i] = static_cast<std::uint8_t>(k - g.vertex_offsets_[v]);
      t = g.triangle_neighbors_[t][(i + 2) % 3];
    }
  }

  g.centers_.resize(nt);
  g.cap_cos_.resize(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tv = g.triangle_vertices_[t];
    const Vec3d c = normalized(g.vertices_[tv[0]] + g.vertices_[tv[1]] + g.vertices_[tv[2]]);
    g.centers_[t] = c;
    g.cap_cos_[t] = std::min({dot(c, g.vertices_[tv[0]]), dot(c, g.vertices_[tv[1]]), dot(c, g.vertices_[tv[2]])});
  }
  g.cap_angle_.resize(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const double a = std::acos(std::clamp(g.cap_cos_[t], -1.0, 1.0));
    g.cap_angle_[t] = {a, std::cos(a), std::sin(a)};
  }
  // Vertex clearance: a point c outside the open star of Gaussian vertex v is at least as far
  // from v as v's link (the edges opposite v in its triangles), hence at least the smallest
  // angle from a corner of a triangle to the great circle of its opposite edge.
  double height = std::numbers::pi / 2;
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tv = g.triangle_vertices_[t];
    for (int i = 0; i < 3; ++i) {
      const Vec3d n = normalized(cross(g.vertices_[tv[(i + 1) % 3]], g.vertices_[tv[(i + 2) % 3]]));
      height = std::min(height, std::asin(std::min(1.0, std::abs(dot(n, g.vertices_[tv[i]])))));
    }
  }
  g.clearance_cos_ = std::cos(std::max(0.0, height - 1e-6));
  g.build_locate_table();
  return g;
}

// The fine table of locate(). A cell of the cube is a convex spherical quadrilateral (gnomonic
// grid lines are great circles), so every direction in it is a non-negative combination of its
// four corners, and a half-space through the origin that holds each corner with a margin of
// 1e-9 (unit plane normal · unit direction) holds all of the cell with that margin. A Gaussian
// triangle is the cone over three such half-spaces (its edge planes). So:
// - a cell whose corners all lie in triangle t, by the margin, lies in t: it answers t;
// - a cell whose corners lie, by the margin, in the two other half-spaces of t1 and of t2, two
//   triangles across edge e (plane P), has its part with P·m > 0 in t1 and the rest in t2: it
//   answers t1 or t2 by the sign of P·m when |P·m| exceeds a margin (else the full computation).
// Directions answered so are farther from every cell boundary of G than the rounding of
// locate_without_table() or of the table's own cell index (about 1e-15), so both agree. Corners
// are located with locate_without_table(); a cell whose corners span other triangles, or miss
// the margins, is a fallback cell.
void GaussSphere::build_locate_table() {
  // 16 cells per cube face side and per unit of f (G's edges ≈ 1.1 / f rad for icosa, cells ≈
  // 0.75-1.6 / (8 N) rad), capped at 128 (6 N² × 8 bytes = 768 KiB); none above f = 32 (16-bit
  // ids), where most cells would meet a vertex of G.
  const std::uint32_t f = frequency_;
  const std::size_t nt = triangle_vertices_.size();
  const std::uint32_t n = f <= 32 && 3 * nt < kNoFine ? std::min<std::uint32_t>(128, std::max<std::uint32_t>(16, 16 * f)) : 0;
  fine_cells_ = n;
  fine_half_ = 0.5 * n;
  fine_.clear();
  edge_planes_.clear();
  if (n == 0) return;
  constexpr double kMargin = 1e-9;
  // Unit inner normals of each triangle's three edge planes.
  edge_planes_.resize(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tv = triangle_vertices_[t];
    for (int i = 0; i < 3; ++i) edge_planes_[3 * t + i] = normalized(cross(vertices_[tv[i]], vertices_[tv[(i + 1) % 3]]));
  }
  fine_.assign(static_cast<std::size_t>(6) * n * n, FineCell{});
  std::vector<std::uint32_t> corner_label((n + 1) * (n + 1));
  std::vector<Vec3d> corner_dir((n + 1) * (n + 1));
  // True when every corner of the cell is on the inner side of the edge planes of t, except
  // edge `skip` (3: none), by the margin.
  auto corners_inside = [&](const Vec3d* const* corners, std::uint32_t t, int skip) {
    for (int k = 0; k < 4; ++k)
      for (int e = 0; e < 3; ++e)
        if (e != skip && !(dot(edge_planes_[3 * t + e], *corners[k]) > kMargin)) return false;
    return true;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int sign = side == 0 ? 1 : -1;
      const double step = 2.0 / n;
      for (std::uint32_t i = 0; i <= n; ++i)
        for (std::uint32_t j = 0; j <= n; ++j) {
          const Vec3d c = cube_direction(axis, sign, -1 + i * step, -1 + j * step);
          corner_dir[i * (n + 1) + j] = c;
          corner_label[i * (n + 1) + j] = locate_without_table(c);
        }
      for (std::uint32_t i = 0; i < n; ++i)
        for (std::uint32_t j = 0; j < n; ++j) {
          const std::uint32_t at[4] = {i * (n + 1) + j, (i + 1) * (n + 1) + j, i * (n + 1) + j + 1,
                                       (i + 1) * (n + 1) + j + 1};
          const Vec3d* corners[4] = {&corner_dir[at[0]], &corner_dir[at[1]], &corner_dir[at[2]], &corner_dir[at[3]]};
          const std::uint32_t t1 = corner_label[at[0]];
          std::uint32_t t2 = t1;
          bool two = true;
          for (std::uint32_t a : at) {
            const std::uint32_t t = corner_label[a];
            if (t == t1) continue;
            if (t2 == t1) t2 = t;
            else if (t != t2) two = false;
          }
          FineCell& cell = fine_[(static_cast<std::size_t>(axis * 2 + side) * n + i) * n + j];
          if (!two) continue;
          if (t2 == t1) {
            if (corners_inside(corners, t1, 3)) cell = {static_cast<std::uint16_t>(t1), static_cast<std::uint16_t>(t1),
                                                        static_cast<std::uint16_t>(3 * t1), 0};
            continue;
          }
          int e1 = -1, e2 = -1;
          for (int e = 0; e < 3; ++e) {
            if (triangle_neighbors_[t1][e] == t2) e1 = e;
            if (triangle_neighbors_[t2][e] == t1) e2 = e;
          }
          if (e1 < 0 || e2 < 0) continue;
          if (corners_inside(corners, t1, e1) && corners_inside(corners, t2, e2))
            cell = {static_cast<std::uint16_t>(t1), static_cast<std::uint16_t>(t2), static_cast<std::uint16_t>(3 * t1 + e1), 0};
        }
    }
}

// Inlined into both locate()s: the batch loop then makes no call for the directions the table
// answers, nearly all of them (an out-of-line locate() per face costs a call and a spill of n). The
// table comes as arguments so that the loop keeps it in registers (a member would be reloaded
// after every store of a label).
[[gnu::always_inline]] inline std::uint32_t GaussSphere::locate_in_table(const Vec3d& m, const FineCell* fine,
                                                                         const Vec3d* planes, std::uint32_t cells,
                                                                         double half) {
  // The cube face of m's largest coordinate (on a tie either face holds m), the gnomonic cell
  // of the other two (the table's cube is axis-aligned in G's rotated frame: no rotation).
  const double ax = std::abs(m.x), ay = std::abs(m.y), az = std::abs(m.z);
  double major, c0, c1, c2;
  int axis;
  if (ax >= ay && ax >= az) {
    axis = 0, major = ax, c0 = m.x, c1 = m.y, c2 = m.z;
  } else if (ay >= az) {
    axis = 1, major = ay, c0 = m.y, c1 = m.z, c2 = m.x;
  } else {
    axis = 2, major = az, c0 = m.z, c1 = m.x, c2 = m.y;
  }
  if (!(major > 0 && major <= 1e300)) return kNone;
  const double inv = 1.0 / major;
  const int last = static_cast<int>(cells) - 1;
  const int i = std::clamp(static_cast<int>((c1 * inv + 1) * half), 0, last);
  const int j = std::clamp(static_cast<int>((c2 * inv + 1) * half), 0, last);
  const FineCell cell = fine[(static_cast<std::size_t>(axis * 2 + (c0 > 0 ? 0 : 1)) * cells + i) * cells + j];
  if (cell.plus == kNoFine) return kNone;
  // |m| <= sqrt(3) major: a side margin of 1e-9 major is one of > 5e-10 in angle.
  const double d = dot(m, planes[cell.plane]);
  const bool decided = (cell.plus == cell.minus) | (std::abs(d) > 1e-9 * major);
  if (!decided) return kNone;
  return d > 0 ? cell.plus : cell.minus;
}

std::uint32_t GaussSphere::locate(const Vec3d& n) const {
  if (fine_cells_ > 0) {
    const std::uint32_t t = locate_in_table(n, fine_.data(), edge_planes_.data(), fine_cells_, fine_half_);
    if (t != kNone) return t;
  }
  return locate_without_table(n);
}

void GaussSphere::locate(std::span<const format::Vec3f> directions, std::span<std::uint32_t> out,
                         std::uint32_t for_zero) const {
  assert(out.size() >= directions.size());
  const std::size_t n = directions.size();
  const format::Vec3f* d = directions.data();
  std::uint32_t* o = out.data();
  const FineCell* fine = fine_.data();
  const Vec3d* planes = edge_planes_.data();
  const std::uint32_t cells = fine_cells_;
  const double half = fine_half_;
  for (std::size_t i = 0; i < n; ++i) {
    // The zero vector has no table cell (its largest coordinate is 0), so it is told apart
    // only among the directions the table leaves.
    const Vec3d m = to_d(d[i]);
    std::uint32_t t = cells > 0 ? locate_in_table(m, fine, planes, cells, half) : kNone;
    if (t == kNone) t = m.x == 0 && m.y == 0 && m.z == 0 ? for_zero : locate_without_table(m);
    o[i] = t;
  }
}

std::uint32_t GaussSphere::locate_without_table(const Vec3d& n) const {
  // m = Rᵀ n.
  const auto& r = rotation_;
  const Vec3d m{r[0][0] * n.x + r[1][0] * n.y + r[2][0] * n.z, r[0][1] * n.x + r[1][1] * n.y + r[2][1] * n.z,
                r[0][2] * n.x + r[1][2] * n.y + r[2][2] * n.z};
  // All face planes are at the same distance from the centre, so the ray leaves the base
  // polyhedron through the face whose centre direction is most aligned with it: the first
  // maximum in id order, over the few faces the cube map cell of m lists (the others cannot
  // win), or over all faces for a zero or non-finite m.
  const double ax = std::abs(m.x), ay = std::abs(m.y), az = std::abs(m.z);
  const std::uint8_t* candidates = nullptr;
  std::uint32_t count = 0;
  const double major = std::max({ax, ay, az});
  if (major > 0 && major <= 1e300) {
    const int axis = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
    const double c[3] = {m.x, m.y, m.z};
    const double inv = 1.0 / major;
    const double half = 0.5 * kCubeCells;
    const int i = std::clamp(static_cast<int>((c[(axis + 1) % 3] * inv + 1) * half), 0, kCubeCells - 1);
    const int j = std::clamp(static_cast<int>((c[(axis + 2) % 3] * inv + 1) * half), 0, kCubeCells - 1);
    const int cell = (axis * 2 + (c[axis] > 0 ? 0 : 1)) * kCubeCells * kCubeCells + i * kCubeCells + j;
    candidates = cube_faces_.data() + cube_offsets_[cell];
    count = cube_offsets_[cell + 1] - cube_offsets_[cell];
  }
  std::uint32_t face = 0;
  if (candidates) {
    face = candidates[0];
    double best = dot(m, base_centers_[face]);
    for (std::uint32_t k = 1; k < count; ++k) {
      const double d = dot(m, base_centers_[candidates[k]]);
      if (d > best) {
        best = d;
        face = candidates[k];
      }
    }
  } else {
    double best = dot(m, base_centers_[0]);
    const std::uint32_t nf = static_cast<std::uint32_t>(base_centers_.size());
    for (std::uint32_t i = 1; i < nf; ++i) {
      const double d = dot(m, base_centers_[i]);
      if (d > best) {
        best = d;
        face = i;
      }
    }
  }
  const auto& k = base_bary_[face];
  const double la = dot(m, k[0]), lb = dot(m, k[1]), lc = dot(m, k[2]);
  const double s = la + lb + lc;
  const std::uint32_t f = frequency_;
  const double fd = static_cast<double>(f);
  double u = s > 0 ? fd * lb / s : 0, v = s > 0 ? fd * lc / s : 0;
  u = std::clamp(u, 0.0, fd);
  v = std::clamp(v, 0.0, fd);
  std::uint32_t a = std::min(static_cast<std::uint32_t>(u), f - 1);
  std::uint32_t b = std::min(static_cast<std::uint32_t>(v), f - 1);
  if (a + b > f - 1) {
    // Rounding pushed the point past the face's far edge: take the nearest cell on it.
    if (u - a > v - b) b = f - 1 - a;
    else a = f - 1 - b;
  }
  const bool down = a + b + 2 <= f && (u - a) + (v - b) > 1.0;
  return face * f * f + b * (2 * f - b) + 2 * a + (down ? 1 : 0);
}

}  // namespace gaussmesh::stream
