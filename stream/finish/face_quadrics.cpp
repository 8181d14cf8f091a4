#include "stream/finish/face_quadrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gaussmesh::stream {
namespace {

// Cells are keyed by 21 bits per axis, offset so that the frame's [-1, 2] range stays positive.
constexpr std::int64_t kCellBias = std::int64_t{1} << 20;

}  // namespace

QuadricFrame frame_of(MeshView mesh) {
  Vec3dq lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
            std::numeric_limits<double>::max()};
  Vec3dq hi{-lo.x, -lo.y, -lo.z};
  for (const auto& v : mesh.positions) {
    lo = {std::min(lo.x, double(v.x)), std::min(lo.y, double(v.y)), std::min(lo.z, double(v.z))};
    hi = {std::max(hi.x, double(v.x)), std::max(hi.y, double(v.y)), std::max(hi.z, double(v.z))};
  }
  if (mesh.positions.empty()) lo = hi = {};
  const Vec3dq extent = sub(hi, lo);
  const double diagonal = std::sqrt(dot(extent, extent));
  QuadricFrame frame;
  frame.origin = lo;
  frame.scale = diagonal > 0 ? diagonal : 1;
  return frame;
}

FaceQuadrics::FaceQuadrics(MeshView approximation) : frame_(frame_of(approximation)) {
  const auto& p = approximation.positions;
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

void FaceQuadrics::nearest(const Vec3dq* points, int count, const Vec3dq& normal, std::uint32_t* out) const {
  // All the points share the first one's cell (add_face checks): one search visits the cells for
  // all of them, each point keeping its own best and its own stopping shell, so the answer for a
  // point is the one a search for it alone would give.
  const std::int64_t ci = std::int64_t(std::floor(points[0].x / cell_));
  const std::int64_t cj = std::int64_t(std::floor(points[0].y / cell_));
  const std::int64_t ck = std::int64_t(std::floor(points[0].z / cell_));
  // Per point: the best facing vertex and the best of any orientation (used when no vertex faces
  // the point's side within kFacingShells), both by (squared distance, id).
  double best_facing[3], best_any[3];
  std::uint32_t facing[3], any[3];
  bool done[3] = {false, false, false};
  for (int p = 0; p < count; ++p) {
    best_facing[p] = best_any[p] = std::numeric_limits<double>::infinity();
    facing[p] = any[p] = UINT32_MAX;
  }
  auto visit_cell = [&](const std::pair<std::uint32_t, std::uint32_t>& range) {
    for (std::uint32_t s = range.first; s < range.second; ++s) {
      const std::uint32_t v = cell_vertices_[s];
      const bool faces_side = dot(normals_[v], normal) > 0;
      for (int p = 0; p < count; ++p) {
        if (done[p]) continue;
        const Vec3dq d = sub(positions_[v], points[p]);
        const double d2 = dot(d, d);
        if (d2 < best_any[p] || (d2 == best_any[p] && v < any[p])) best_any[p] = d2, any[p] = v;
        if (faces_side && (d2 < best_facing[p] || (d2 == best_facing[p] && v < facing[p])))
          best_facing[p] = d2, facing[p] = v;
      }
    }
  };
  auto visit = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    auto it = cells_.find(cell_key(i, j, k));
    if (it != cells_.end()) visit_cell(it->second);
  };
  // Where a shell has more cells than the grid has occupied ones (a few vertices far apart in a
  // grid of tiny cells: a degenerate approximation), the occupied cells are taken by their
  // distance from the centre cell instead, and the empty shells between are passed over: the same
  // cells are visited, and the answers are by (distance, id), so they are the same as the shell
  // walk's, at a cost bounded by the occupied cells rather than by the shells' volume.
  std::vector<std::pair<std::int64_t, const std::pair<std::uint32_t, std::uint32_t>*>> by_shell;
  auto occupied_by_shell = [&] {
    by_shell.reserve(cells_.size());
    const std::uint64_t mask = (std::uint64_t{1} << 21) - 1;
    for (const auto& [key, range] : cells_) {
      const std::int64_t i = std::int64_t(key >> 42 & mask) - kCellBias, j = std::int64_t(key >> 21 & mask) - kCellBias,
                         k = std::int64_t(key & mask) - kCellBias;
      by_shell.emplace_back(std::max({std::abs(i - ci), std::abs(j - cj), std::abs(k - ck)}), &range);
    }
    std::sort(by_shell.begin(), by_shell.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  };
  constexpr std::int64_t kFacingShells = 6;
  // Every vertex lies within the frame's unit box and every point within a cell of it (add_face
  // clamps them), so shells beyond 2 / cell_ + 3 find nothing new.
  const std::int64_t max_shell = std::int64_t(std::ceil(2.0 / cell_)) + 3;
  int left = count;
  for (std::int64_t r = 0; r <= max_shell && left > 0; ++r) {
    // Shell r: the cells at Chebyshev distance r from the centre cell.
    const std::int64_t side = 2 * r + 1, inner = std::max<std::int64_t>(side - 2, 0);
    const bool sparse = side * side * side - inner * inner * inner > std::int64_t(cells_.size());
    std::int64_t next_occupied = max_shell;  // in sparse mode: the next shell with an occupied cell
    if (sparse) {
      if (by_shell.empty()) occupied_by_shell();
      auto at = std::lower_bound(by_shell.begin(), by_shell.end(), r, [](const auto& e, std::int64_t d) { return e.first < d; });
      for (; at != by_shell.end() && at->first == r; ++at) visit_cell(*at->second);
      if (at != by_shell.end()) next_occupied = std::min(at->first, max_shell);
    } else {
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
    }
    // A vertex not yet visited lies outside the searched box: at least `reach` from the point.
    const double lo_x = double(ci - r) * cell_, hi_x = double(ci + r + 1) * cell_;
    const double lo_y = double(cj - r) * cell_, hi_y = double(cj + r + 1) * cell_;
    const double lo_z = double(ck - r) * cell_, hi_z = double(ck + r + 1) * cell_;
    for (int p = 0; p < count; ++p) {
      if (done[p]) continue;
      const Vec3dq& q = points[p];
      const double reach = std::max(0.0, std::min({q.x - lo_x, hi_x - q.x, q.y - lo_y, hi_y - q.y, q.z - lo_z, hi_z - q.z}));
      if (facing[p] != UINT32_MAX && best_facing[p] <= reach * reach) {
        out[p] = facing[p];
      } else if (r >= kFacingShells && any[p] != UINT32_MAX && best_any[p] <= reach * reach) {
        out[p] = facing[p] != UINT32_MAX ? facing[p] : any[p];
      } else {
        continue;
      }
      done[p] = true;
      --left;
    }
    // Past empty shells, nothing changes but the reach, which only grows: the stopping test at
    // the last of them (the shell before the next occupied one) decides as any of them would.
    if (sparse && next_occupied - 1 > r + 1) r = next_occupied - 2;
  }
  for (int p = 0; p < count; ++p)
    if (!done[p]) out[p] = facing[p] != UINT32_MAX ? facing[p] : any[p];
}

bool FaceQuadrics::nearest_cached(const Vec3dq* points, const Vec3dq& normal, std::uint64_t key, std::int64_t ci,
                                  std::int64_t cj, std::int64_t ck, Accumulator& cache, std::uint32_t* out) const {
  if (cache.cached_cell != key) {
    cache.cached_cell = key;
    cache.centre.clear();
    cache.ring.clear();
    for (std::int64_t i = ci - 1; i <= ci + 1; ++i)
      for (std::int64_t j = cj - 1; j <= cj + 1; ++j)
        for (std::int64_t k = ck - 1; k <= ck + 1; ++k) {
          auto it = cells_.find(cell_key(i, j, k));
          if (it == cells_.end()) continue;
          auto& into = i == ci && j == cj && k == ck ? cache.centre : cache.ring;
          into.insert(into.end(), cell_vertices_.begin() + it->second.first, cell_vertices_.begin() + it->second.second);
        }
  }
  // As nearest() stops at shells 0 and 1: ties go to the lower id, so the visiting order within
  // a shell does not matter.
  double best[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
  std::uint32_t facing[3] = {UINT32_MAX, UINT32_MAX, UINT32_MAX};
  bool found[3] = {false, false, false};
  for (int shell = 0; shell < 2; ++shell) {
    for (std::uint32_t v : shell == 0 ? cache.centre : cache.ring) {
      if (!(dot(normals_[v], normal) > 0)) continue;
      const Vec3dq& x = positions_[v];
      for (int p = 0; p < 3; ++p) {
        if (found[p]) continue;
        const Vec3dq d = sub(x, points[p]);
        const double d2 = dot(d, d);
        if (d2 < best[p] || (d2 == best[p] && v < facing[p])) best[p] = d2, facing[p] = v;
      }
    }
    const double lo_x = double(ci - shell) * cell_, hi_x = double(ci + shell + 1) * cell_;
    const double lo_y = double(cj - shell) * cell_, hi_y = double(cj + shell + 1) * cell_;
    const double lo_z = double(ck - shell) * cell_, hi_z = double(ck + shell + 1) * cell_;
    bool all = true;
    for (int p = 0; p < 3; ++p) {
      if (found[p]) continue;
      const Vec3dq& q = points[p];
      const double reach = std::max(0.0, std::min({q.x - lo_x, hi_x - q.x, q.y - lo_y, hi_y - q.y, q.z - lo_z, hi_z - q.z}));
      found[p] = facing[p] != UINT32_MAX && best[p] <= reach * reach;
      all = all && found[p];
    }
    if (all) break;
  }
  if (!(found[0] && found[1] && found[2])) return false;
  for (int p = 0; p < 3; ++p) out[p] = facing[p];
  return true;
}

void FaceQuadrics::add_face(const Vec3f& a, const Vec3f& b, const Vec3f& c, Accumulator& into) const {
  std::vector<FixedQuadric>& sums = into.sums;
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
  // Searched from within the frame's box grown by a cell: a corner far outside (an outlier the
  // approximation left out) is assigned as its nearest point of that box, which keeps every search
  // within a bounded number of shells.
  auto inside = [this](const Vec3dq& q) {
    const double lo = -cell_, hi = 1 + cell_;
    return Vec3dq{std::clamp(q.x, lo, hi), std::clamp(q.y, lo, hi), std::clamp(q.z, lo, hi)};
  };
  const Vec3dq corners[3] = {inside(p0), inside(p1), inside(p2)};
  std::uint32_t v[3];
  auto cell_of = [this](const Vec3dq& q) {
    return cell_key(std::int64_t(std::floor(q.x / cell_)), std::int64_t(std::floor(q.y / cell_)),
                    std::int64_t(std::floor(q.z / cell_)));
  };
  const std::uint64_t c0 = cell_of(corners[0]);
  if (cell_of(corners[1]) == c0 && cell_of(corners[2]) == c0) {
    // The common case: a face much smaller than a cell.
    const std::int64_t ci = std::int64_t(std::floor(corners[0].x / cell_)),
                       cj = std::int64_t(std::floor(corners[0].y / cell_)),
                       ck = std::int64_t(std::floor(corners[0].z / cell_));
    if (!nearest_cached(corners, unit, c0, ci, cj, ck, into, v)) nearest(corners, 3, unit, v);
  } else {
    for (int k = 0; k < 3; ++k) nearest(&corners[k], 1, unit, &v[k]);
  }
  const std::uint32_t v0 = v[0], v1 = v[1], v2 = v[2];
  if (v0 == UINT32_MAX || v1 == UINT32_MAX || v2 == UINT32_MAX) return;  // no vertex at all
  sums[v0] += q;
  if (v1 != v0) sums[v1] += q;
  if (v2 != v0 && v2 != v1) sums[v2] += q;
}

void FaceQuadrics::add_mesh(MeshView mesh, Accumulator& into) const {
  for (const auto& t : mesh.triangles)
    add_face(mesh.positions[t.v[0]], mesh.positions[t.v[1]], mesh.positions[t.v[2]], into);
}

void add_sums(std::vector<FixedQuadric>& into, const std::vector<FixedQuadric>& from) {
  for (std::size_t i = 0; i < into.size() && i < from.size(); ++i) into[i] += from[i];
}

}  // namespace gaussmesh::stream
