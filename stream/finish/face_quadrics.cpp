#include "stream/finish/face_quadrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gaussmesh::stream {
namespace {

Vec3dq sub(const Vec3dq& a, const Vec3dq& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3dq cross(const Vec3dq& a, const Vec3dq& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(const Vec3dq& a, const Vec3dq& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Cells are keyed by 21 bits per axis, offset so that the frame's [-1, 2] range stays positive.
constexpr std::int64_t kCellBias = std::int64_t{1} << 20;

}  // namespace

FaceQuadrics::FaceQuadrics(MeshView approximation) {
  const auto& p = approximation.positions;
  Vec3dq lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
            std::numeric_limits<double>::max()};
  Vec3dq hi{-lo.x, -lo.y, -lo.z};
  for (const auto& v : p) {
    lo = {std::min(lo.x, double(v.x)), std::min(lo.y, double(v.y)), std::min(lo.z, double(v.z))};
    hi = {std::max(hi.x, double(v.x)), std::max(hi.y, double(v.y)), std::max(hi.z, double(v.z))};
  }
  if (p.empty()) lo = hi = {};
  const Vec3dq extent = sub(hi, lo);
  const double diagonal = std::sqrt(dot(extent, extent));
  frame_.origin = lo;
  frame_.scale = diagonal > 0 ? diagonal : 1;

  positions_.reserve(p.size());
  for (const auto& v : p) positions_.push_back(frame_.to_frame(v.x, v.y, v.z));
  normals_.assign(p.size(), {});
  double edge_sum = 0;
  std::size_t edges = 0;
  for (const auto& t : approximation.triangles) {
    const Vec3dq& a = positions_[t.v[0]];
    const Vec3dq& b = positions_[t.v[1]];
    const Vec3dq& c = positions_[t.v[2]];
    const Vec3dq n = cross(sub(b, a), sub(c, a));
    for (int i = 0; i < 3; ++i) {
      Vec3dq& m = normals_[t.v[i]];
      m = {m.x + n.x, m.y + n.y, m.z + n.z};
    }
    const Vec3dq e = sub(b, a);
    edge_sum += std::sqrt(dot(e, e));
    ++edges;
  }
  // About one vertex per cell on a surface: the mean edge length (capped so that the key's 21
  // bits per axis cover the frame).
  cell_ = edges > 0 ? std::max(edge_sum / double(edges), 1.0 / double(kCellBias / 4)) : 1.0;

  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(positions_.size());
  for (std::uint32_t v = 0; v < positions_.size(); ++v) {
    const Vec3dq& q = positions_[v];
    keyed[v] = {cell_key(std::int64_t(std::floor(q.x / cell_)), std::int64_t(std::floor(q.y / cell_)),
                         std::int64_t(std::floor(q.z / cell_))),
                v};
  }
  std::sort(keyed.begin(), keyed.end());
  cell_vertices_.resize(keyed.size());
  cells_.reserve(keyed.size());
  for (std::uint32_t i = 0; i < keyed.size();) {
    std::uint32_t j = i;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) {
      cell_vertices_[j] = keyed[j].second;
      ++j;
    }
    cells_.emplace(keyed[i].first, std::make_pair(i, j));
    i = j;
  }
}

std::uint64_t FaceQuadrics::cell_key(std::int64_t i, std::int64_t j, std::int64_t k) const {
  auto axis = [](std::int64_t c) { return std::uint64_t(std::clamp<std::int64_t>(c + kCellBias, 0, (kCellBias << 1) - 1)); };
  return axis(i) << 42 | axis(j) << 21 | axis(k);
}

std::uint32_t FaceQuadrics::nearest(const Vec3dq& point, const Vec3dq& normal) const {
  const std::int64_t ci = std::int64_t(std::floor(point.x / cell_));
  const std::int64_t cj = std::int64_t(std::floor(point.y / cell_));
  const std::int64_t ck = std::int64_t(std::floor(point.z / cell_));
  // Best facing vertex, and best of any orientation (used when no vertex faces the face's side
  // within the search), both by (squared distance, id).
  double best_facing = std::numeric_limits<double>::infinity(), best_any = best_facing;
  std::uint32_t facing = UINT32_MAX, any = UINT32_MAX;
  auto visit = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    auto it = cells_.find(cell_key(i, j, k));
    if (it == cells_.end()) return;
    for (std::uint32_t s = it->second.first; s < it->second.second; ++s) {
      const std::uint32_t v = cell_vertices_[s];
      const Vec3dq d = sub(positions_[v], point);
      const double d2 = dot(d, d);
      if (d2 < best_any || (d2 == best_any && v < any)) best_any = d2, any = v;
      if (dot(normals_[v], normal) > 0 && (d2 < best_facing || (d2 == best_facing && v < facing)))
        best_facing = d2, facing = v;
    }
  };
  // Shells of cells at Chebyshev radius r: a vertex in shell r + 1 is at least r cells away.
  constexpr std::int64_t kFacingShells = 6;
  // Every vertex lies within the frame's unit box, so shells beyond 2 / cell_ find nothing new.
  const std::int64_t max_shell = std::int64_t(std::ceil(2.0 / cell_)) + 1;
  for (std::int64_t r = 0; r <= max_shell; ++r) {
    for (std::int64_t i = ci - r; i <= ci + r; ++i)
      for (std::int64_t j = cj - r; j <= cj + r; ++j) {
        const bool edge = i == ci - r || i == ci + r || j == cj - r || j == cj + r;
        if (edge) {
          for (std::int64_t k = ck - r; k <= ck + r; ++k) visit(i, j, k);
        } else {
          visit(i, j, ck - r);
          if (r > 0) visit(i, j, ck + r);
        }
      }
    const double reach = double(r) * cell_;
    if (facing != UINT32_MAX && best_facing <= reach * reach) return facing;
    if (r >= kFacingShells && any != UINT32_MAX && best_any <= reach * reach) return facing != UINT32_MAX ? facing : any;
  }
  return facing != UINT32_MAX ? facing : any;
}

void FaceQuadrics::add_face(const Vec3f& a, const Vec3f& b, const Vec3f& c, std::vector<FixedQuadric>& sums) const {
  if (positions_.empty()) return;
  const Vec3dq p0 = frame_.to_frame(a.x, a.y, a.z);
  const Vec3dq p1 = frame_.to_frame(b.x, b.y, b.z);
  const Vec3dq p2 = frame_.to_frame(c.x, c.y, c.z);
  const Vec3dq n = cross(sub(p1, p0), sub(p2, p0));
  const double length = std::sqrt(dot(n, n));
  if (!(length > 0) || !std::isfinite(length)) return;
  const Vec3dq unit{n.x / length, n.y / length, n.z / length};
  // The face counts for the vertex nearest to each of its corners (one to three of them), as
  // Garland & Heckbert give a face's plane to each of its corners.
  const FixedQuadric q = FixedQuadric::from(Quadric::plane(unit, -dot(unit, p0), length / 2));
  const std::uint32_t v0 = nearest(p0, unit), v1 = nearest(p1, unit), v2 = nearest(p2, unit);
  sums[v0] += q;
  if (v1 != v0) sums[v1] += q;
  if (v2 != v0 && v2 != v1) sums[v2] += q;
}

void FaceQuadrics::add_mesh(MeshView mesh, std::vector<FixedQuadric>& sums) const {
  for (const auto& t : mesh.triangles)
    add_face(mesh.positions[t.v[0]], mesh.positions[t.v[1]], mesh.positions[t.v[2]], sums);
}

void add_sums(std::vector<FixedQuadric>& into, const std::vector<FixedQuadric>& from) {
  for (std::size_t i = 0; i < into.size() && i < from.size(); ++i) into[i] += from[i];
}

}  // namespace gaussmesh::stream
