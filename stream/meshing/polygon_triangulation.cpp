// Triangulation of one planar polygon with holes for the per-patch mesher (paper §5): exact 2D
// predicates on projected coordinates, verified hole bridges, best-shape ear clipping of the
// weakly simple polygon they make, then Lawson's Delaunay flips over the new edges.
//
// The stages, each deciding with exact orientation / in-circle predicates only:
//   1. check the loops: sizes, indices, finite coordinates, no zero-length edge, and no two
//      loop edges meeting anywhere but at a common endpoint (sweep over x-sorted edges);
//   2. orient the loops (outer counter-clockwise, holes clockwise) from the extreme edge at
//      the lowest vertex, which is exact and also right for loops that touch themselves;
//   3. join the holes, rightmost first: a hole sharing a point with what is already joined is
//      spliced there; otherwise a bridge from its rightmost vertex to a vertex found by a ray
//      cast (doubles, a guess only) or, failing that, to one of the nearest vertices, accepted
//      only when it crosses and touches nothing and leaves both ends into the interior;
//   4. check every point visited more than once: its visits' interior wedges must not overlap;
//   5. clip ears, best shape first (priority queue with a total order, so the result depends
//      on the input only); an ear is strictly convex, contains no other vertex, is not entered
//      by an edge at a shared corner, and its diagonal is neither forbidden nor existing;
//   6. flip new edges toward the Delaunay triangulation where the quad is strictly convex and
//      the new edge is neither forbidden nor existing.
#include "stream/meshing/polygon_triangulation.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include "stream/core/edge_key_map.h"

namespace gaussmesh::stream {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalPoint = Kernel::Point_2;
using P2 = PolygonPoint2;
using Loop = std::vector<std::uint32_t>;

constexpr const char* kWhere = "polygon triangulation";
// Vertices tried as the far end of one hole's bridge after the ray-cast guess fails.
constexpr std::size_t kMaxBridgeCandidates = 256;
// Full re-evaluations of every ear when the queue runs dry (only degenerate input needs any).
constexpr int kMaxRescans = 32;

format::Status failure(const std::string& message) {
  return format::Status::error(format::Code::kProcessing, kWhere, message);
}

std::uint64_t edge_key(std::uint32_t u, std::uint32_t v) {
  const auto [lo, hi] = std::minmax(u, v);
  return (std::uint64_t(lo) << 32) | hi;
}
std::uint64_t directed_key(std::uint32_t u, std::uint32_t v) { return (std::uint64_t(u) << 32) | v; }

bool is_forbidden(const ForbiddenEdge& forbidden, std::uint32_t u, std::uint32_t v) {
  if (!forbidden) return false;
  const auto [lo, hi] = std::minmax(u, v);
  return forbidden(lo, hi);
}

bool same_point(const P2& a, const P2& b) { return a[0] == b[0] && a[1] == b[1]; }
bool lex_less(const P2& a, const P2& b) { return a[0] < b[0] || (a[0] == b[0] && a[1] < b[1]); }
int sign_of(double x) { return (x > 0) - (x < 0); }

// x within the bounding box of a and b (closed).
bool in_box(const P2& a, const P2& b, const P2& x) {
  return std::min(a[0], b[0]) <= x[0] && x[0] <= std::max(a[0], b[0]) && std::min(a[1], b[1]) <= x[1] &&
         x[1] <= std::max(a[1], b[1]);
}

// For a, b collinear with v (and both distinct from v): do they lie on the same ray from v?
bool same_direction(const P2& v, const P2& a, const P2& b) {
  return sign_of(a[0] - v[0]) == sign_of(b[0] - v[0]) && sign_of(a[1] - v[1]) == sign_of(b[1] - v[1]);
}

// t on the open ray from v through d.
bool on_ray(const P2& v, const P2& d, const P2& t) {
  return !same_point(v, t) && orientation_2d(v, d, t) == 0 && same_direction(v, d, t);
}

// Do the closed segments [p, q] and [a, b] share a point other than a common endpoint, or are
// they the same segment? Exact.
bool segments_conflict(const P2& p, const P2& q, const P2& a, const P2& b) {
  if (std::max(a[0], b[0]) < std::min(p[0], q[0]) || std::max(p[0], q[0]) < std::min(a[0], b[0]) ||
      std::max(a[1], b[1]) < std::min(p[1], q[1]) || std::max(p[1], q[1]) < std::min(a[1], b[1])) {
    return false;
  }
  const bool a_is_end = same_point(a, p) || same_point(a, q);
  const bool b_is_end = same_point(b, p) || same_point(b, q);
  if (a_is_end && b_is_end) return true;
  const int oa = orientation_2d(p, q, a), ob = orientation_2d(p, q, b);
  const int op = orientation_2d(a, b, p), oq = orientation_2d(a, b, q);
  if (oa * ob < 0 && op * oq < 0) return true;
  const bool p_is_end = same_point(p, a) || same_point(p, b);
  const bool q_is_end = same_point(q, a) || same_point(q, b);
  return (!a_is_end && oa == 0 && in_box(p, q, a)) || (!b_is_end && ob == 0 && in_box(p, q, b)) ||
         (!p_is_end && op == 0 && in_box(a, b, p)) || (!q_is_end && oq == 0 && in_box(a, b, q));
}

// Is t strictly inside the interior wedge at v of a boundary passing prev -> v -> next with the
// interior on its left? Points on the two bounding rays are not inside.
bool wedge_contains(const P2& prev, const P2& v, const P2& next, const P2& t) {
  if (same_point(t, v)) return false;
  const int turn = orientation_2d(prev, v, next);
  const bool left_of_in = orientation_2d(prev, v, t) > 0;
  const bool left_of_out = orientation_2d(v, next, t) > 0;
  if (turn > 0) return left_of_in && left_of_out;
  if (turn < 0) return (left_of_in || left_of_out) && !on_ray(v, next, t) && !on_ray(v, prev, t);
  if (same_direction(v, prev, next)) return false;  // a spike has no proper wedge
  return left_of_in;
}

// Triangle shape in (0, 1], 1 for equilateral: 4 sqrt(3) area / sum of squared edge lengths.
double shape_quality(const P2& a, const P2& b, const P2& c) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], vx = c[0] - a[0], vy = c[1] - a[1];
  const double wx = c[0] - b[0], wy = c[1] - b[1];
  const double twice_area = ux * vy - uy * vx;
  const double squares = ux * ux + uy * uy + vx * vx + vy * vy + wx * wx + wy * wy;
  const double quality = 2.0 * std::sqrt(3.0) * twice_area / squares;
  return std::isfinite(quality) ? quality : 0.0;
}

// ---------------------------------------------------------------------------------------------
// Stage 1: the loops as given.

// A loop edge for the crossing sweep of check_loops.
struct SweepEdge {
  double min_x, max_x;
  std::uint32_t u, v;
};

format::Status check_loops(std::span<const P2> points, std::span<const Loop> loops, std::vector<SweepEdge>& edges) {
  if (loops.empty()) return failure("no boundary loop");
  for (std::size_t k = 0; k < loops.size(); ++k) {
    const Loop& loop = loops[k];
    if (loop.size() < 3) {
      return failure("loop " + std::to_string(k) + " has " + std::to_string(loop.size()) +
                     " vertices, fewer than 3");
    }
    for (std::uint32_t id : loop) {
      if (id >= points.size()) {
        return failure("loop " + std::to_string(k) + " refers to point " + std::to_string(id) + " of " +
                       std::to_string(points.size()));
      }
      if (!std::isfinite(points[id][0]) || !std::isfinite(points[id][1])) {
        return failure("point " + std::to_string(id) + " has a non-finite coordinate");
      }
    }
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const std::uint32_t u = loop[i], v = loop[(i + 1) % loop.size()];
      if (same_point(points[u], points[v])) {
        return failure("loop " + std::to_string(k) + " has a zero-length edge " + std::to_string(u) + "-" +
                       std::to_string(v) + " in the plane");
      }
    }
  }
  // Every pair of edges whose x-ranges overlap, found by a sweep over edges sorted by min x.
  using Edge = SweepEdge;
  edges.clear();
  for (const Loop& loop : loops) {
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const std::uint32_t u = loop[i], v = loop[(i + 1) % loop.size()];
      edges.push_back({std::min(points[u][0], points[v][0]), std::max(points[u][0], points[v][0]), u, v});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) {
    return std::tie(x.min_x, x.max_x, x.u, x.v) < std::tie(y.min_x, y.max_x, y.u, y.v);
  });
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const P2 &p = points[edges[i].u], &q = points[edges[i].v];
    for (std::size_t j = i + 1; j < edges.size() && edges[j].min_x <= edges[i].max_x; ++j) {
      if (segments_conflict(p, q, points[edges[j].u], points[edges[j].v])) {
        return failure("loop edges " + std::to_string(edges[i].u) + "-" + std::to_string(edges[i].v) + " and " +
                       std::to_string(edges[j].u) + "-" + std::to_string(edges[j].v) +
                       " cross or overlap in the plane (self-intersecting projection)");
      }
    }
  }
  return {};
}

// +1 when the loop runs counter-clockwise, -1 clockwise. Exact for loops whose edges meet only
// at common endpoints: at the lexicographically lowest point every incident edge points into
// the half-plane x > v.x (or straight up), and the most clockwise of them leaves v on a
// counter-clockwise loop and enters it on a clockwise one.
int loop_orientation(std::span<const P2> points, const Loop& loop) {
  std::size_t lowest = 0;
  for (std::size_t i = 1; i < loop.size(); ++i) {
    if (lex_less(points[loop[i]], points[loop[lowest]])) lowest = i;
  }
  const P2& v = points[loop[lowest]];
  const P2* extreme = nullptr;
  bool extreme_leaves = false;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    if (!same_point(points[loop[i]], v)) continue;
    const P2& next = points[loop[(i + 1) % loop.size()]];
    const P2& prev = points[loop[(i + loop.size() - 1) % loop.size()]];
    if (extreme == nullptr || orientation_2d(v, next, *extreme) > 0) extreme = &next, extreme_leaves = true;
    if (orientation_2d(v, prev, *extreme) > 0) extreme = &prev, extreme_leaves = false;
  }
  return extreme_leaves ? 1 : -1;
}

// Reverses the loop, keeping its first vertex first (so a rotated input stays a rotation).
void reverse_loop(Loop& loop) { std::reverse(loop.begin() + 1, loop.end()); }

// ---------------------------------------------------------------------------------------------
// Stage 3: joining holes into one weakly simple polygon.

class HoleJoiner {
 public:
  HoleJoiner(std::span<const P2> points, const std::vector<Loop>& loops, const ForbiddenEdge& forbidden)
      : points_(points), loops_(loops), forbidden_(forbidden), joined_(loops.size(), 0) {}

  // The joined boundary (outer loop with every hole spliced in) and how many holes were
  // spliced at a shared point rather than bridged.
  format::Status run(Loop& boundary, std::size_t& spliced) {
    boundary = loops_[0];
    joined_[0] = 1;
    spliced = 0;
    std::vector<std::size_t> order;
    std::vector<P2> rightmost(loops_.size());
    for (std::size_t k = 1; k < loops_.size(); ++k) {
      order.push_back(k);
      rightmost[k] = points_[loops_[k][rightmost_vertex(k)]];
    }
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      if (!same_point(rightmost[x], rightmost[y])) return lex_less(rightmost[y], rightmost[x]);
      return x < y;
    });
    for (std::size_t k = 0; k < loops_.size(); ++k) {
      for (std::uint32_t id : loops_[k]) where_.push_back({points_[id], std::uint32_t(k)});
    }
    std::sort(where_.begin(), where_.end(), [](const Where& x, const Where& y) {
      return lex_less(x.point, y.point) || (same_point(x.point, y.point) && x.loop < y.loop);
    });
    for (std::size_t k : order) {
      if (auto shared = shared_point(k)) {
        GM_RETURN_IF_ERROR(splice(boundary, k, *shared));
        ++spliced;
      } else {
        GM_RETURN_IF_ERROR(bridge(boundary, k));
      }
      joined_[k] = 1;
    }
    return {};
  }

 private:
  struct Where {
    P2 point;
    std::uint32_t loop;
  };

  const P2& at(std::uint32_t id) const { return points_[id]; }

  // Position in hole k of its lexicographically greatest point (lowest index among equals).
  std::size_t rightmost_vertex(std::size_t k) const {
    const Loop& loop = loops_[k];
    std::size_t best = 0;
    for (std::size_t i = 1; i < loop.size(); ++i) {
      const P2 &p = at(loop[i]), &b = at(loop[best]);
      if (lex_less(b, p) || (same_point(b, p) && loop[i] < loop[best])) best = i;
    }
    return best;
  }

  // The lowest point of hole k that an already joined loop also visits.
  std::optional<P2> shared_point(std::size_t k) const {
    std::optional<P2> best;
    for (std::uint32_t id : loops_[k]) {
      const P2& p = at(id);
      auto range = std::equal_range(where_.begin(), where_.end(), Where{p, 0}, [](const Where& x, const Where& y) {
        return lex_less(x.point, y.point);
      });
      for (auto it = range.first; it != range.second; ++it) {
        if (it->loop != k && joined_[it->loop] && (!best || lex_less(p, *best))) best = p;
      }
    }
    return best;
  }

  // Positions in `loop` where it visits point p.
  std::vector<std::size_t> visits(const Loop& loop, const P2& p) const {
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      if (same_point(at(loop[i]), p)) out.push_back(i);
    }
    return out;
  }

  const P2& prev_of(const Loop& loop, std::size_t i) const { return at(loop[(i + loop.size() - 1) % loop.size()]); }
  const P2& next_of(const Loop& loop, std::size_t i) const { return at(loop[(i + 1) % loop.size()]); }

  // Hole k touches the boundary at point v: ..., a, v, c, ... and ..., p, v, q, ... become
  // ..., a, v, q, ..., p, v, c, ... where that pairs every incoming edge with the next
  // outgoing one clockwise (the hole's edges inside the boundary's wedge at that visit).
  format::Status splice(Loop& boundary, std::size_t k, const P2& v) const {
    const Loop& hole = loops_[k];
    for (std::size_t i : visits(boundary, v)) {
      const P2 &a = prev_of(boundary, i), &c = next_of(boundary, i);
      for (std::size_t j : visits(hole, v)) {
        const P2 &p = prev_of(hole, j), &q = next_of(hole, j);
        if (!wedge_contains(a, v, c, p) || !wedge_contains(a, v, c, q)) continue;
        if (wedge_contains(a, v, q, p) || wedge_contains(a, v, q, c) || wedge_contains(p, v, c, a) ||
            wedge_contains(p, v, c, q)) {
          continue;
        }
        Loop joined(boundary.begin(), boundary.begin() + std::ptrdiff_t(i) + 1);
        for (std::size_t t = 1; t <= hole.size(); ++t) joined.push_back(hole[(j + t) % hole.size()]);
        joined.insert(joined.end(), boundary.begin() + std::ptrdiff_t(i) + 1, boundary.end());
        boundary = std::move(joined);
        return {};
      }
    }
    return failure("hole " + std::to_string(k) + " touches another loop at a vertex but not from inside it");
  }

  // Hole k gets a bridge from its rightmost vertex m to a boundary vertex that sees it.
  format::Status bridge(Loop& boundary, std::size_t k) const {
    const Loop& hole = loops_[k];
    const std::uint32_t m = hole[rightmost_vertex(k)];
    std::vector<std::uint32_t> tried;
    auto attempt = [&](std::uint32_t target) {
      if (std::find(tried.begin(), tried.end(), target) != tried.end()) return false;
      tried.push_back(target);
      return try_bridge(boundary, k, m, target);
    };
    if (auto guess = ray_cast_guess(boundary, at(m)); guess && attempt(*guess)) return {};
    // Fallback: the nearest boundary vertices (distance in doubles, ties by position and index).
    std::vector<std::uint32_t> nearest(boundary.begin(), boundary.end());
    std::sort(nearest.begin(), nearest.end());
    nearest.erase(std::unique(nearest.begin(), nearest.end()), nearest.end());
    auto distance2 = [&](std::uint32_t id) {
      const double dx = at(id)[0] - at(m)[0], dy = at(id)[1] - at(m)[1];
      return dx * dx + dy * dy;
    };
    std::vector<std::pair<double, std::uint32_t>> ranked;
    for (std::uint32_t id : nearest) ranked.push_back({distance2(id), id});
    const std::size_t count = std::min(ranked.size(), kMaxBridgeCandidates);
    std::partial_sort(ranked.begin(), ranked.begin() + std::ptrdiff_t(count), ranked.end(),
                      [&](const auto& x, const auto& y) {
                        if (x.first != y.first) return x.first < y.first;
                        if (!same_point(at(x.second), at(y.second))) return lex_less(at(x.second), at(y.second));
                        return x.second < y.second;
                      });
    for (std::size_t r = 0; r < count; ++r) {
      if (attempt(ranked[r].second)) return {};
    }
    return failure("hole " + std::to_string(k) + " cannot be joined: no visible, allowed bridge from its vertex " +
                   std::to_string(m) + " (hole outside the outer loop, nested, or every bridge forbidden)");
  }

  // The classic guess (a ray from m towards +x, the nearest edge hit, the best-aligned vertex
  // in the triangle it spans), computed in doubles: only a candidate, verified exactly later.
  std::optional<std::uint32_t> ray_cast_guess(const Loop& boundary, const P2& m) const {
    double best_x = std::numeric_limits<double>::infinity();
    std::optional<std::uint32_t> vertex_hit;
    std::optional<std::size_t> edge_hit;
    for (std::size_t i = 0; i < boundary.size(); ++i) {
      const P2 &a = at(boundary[i]), &b = next_of(boundary, i);
      if (a[1] == m[1] && a[0] > m[0] && a[0] < best_x) {
        best_x = a[0], vertex_hit = boundary[i], edge_hit.reset();
      } else if ((a[1] < m[1] && b[1] > m[1]) || (a[1] > m[1] && b[1] < m[1])) {
        const double x = a[0] + (m[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
        if (x > m[0] && x < best_x) best_x = x, edge_hit = i, vertex_hit.reset();
      }
    }
    if (vertex_hit) return vertex_hit;
    if (!edge_hit) return std::nullopt;
    const std::uint32_t a = boundary[*edge_hit], b = boundary[(*edge_hit + 1) % boundary.size()];
    std::uint32_t target = (at(b)[0] > at(a)[0] || (at(b)[0] == at(a)[0] && b < a)) ? b : a;
    const P2 hit = {best_x, m[1]};
    const P2 end = at(target);
    double best_slope = std::numeric_limits<double>::infinity(), best_distance = best_slope;
    for (std::uint32_t id : boundary) {
      const P2& w = at(id);
      if (same_point(w, end) || w[0] <= m[0]) continue;
      const int s1 = orientation_2d(m, hit, w), s2 = orientation_2d(hit, end, w), s3 = orientation_2d(end, m, w);
      if (!((s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0))) continue;
      const double slope = std::abs(w[1] - m[1]) / (w[0] - m[0]);
      const double distance = (w[0] - m[0]) * (w[0] - m[0]) + (w[1] - m[1]) * (w[1] - m[1]);
      if (slope < best_slope || (slope == best_slope && distance < best_distance)) {
        best_slope = slope, best_distance = distance, target = id;
      }
    }
    return target;
  }

  // Joins hole k by the bridge m-target if it is exactly valid: a new, allowed edge whose
  // segment meets no loop edge except at its own endpoints and leaves both ends into the
  // interior wedge of one visit there.
  bool try_bridge(Loop& boundary, std::size_t k, std::uint32_t m, std::uint32_t target) const {
    const P2 &pm = at(m), &pt = at(target);
    if (same_point(pm, pt) || is_forbidden(forbidden_, m, target)) return false;
    const Loop& hole = loops_[k];
    std::optional<std::size_t> at_hole, at_boundary;
    for (std::size_t j : visits(hole, pm)) {
      if (hole[j] == m && wedge_contains(prev_of(hole, j), pm, next_of(hole, j), pt)) {
        at_hole = j;
        break;
      }
    }
    for (std::size_t i : visits(boundary, pt)) {
      if (boundary[i] == target && wedge_contains(prev_of(boundary, i), pt, next_of(boundary, i), pm)) {
        at_boundary = i;
        break;
      }
    }
    if (!at_hole || !at_boundary) return false;
    auto clear_of = [&](const Loop& loop) {
      for (std::size_t i = 0; i < loop.size(); ++i) {
        if (segments_conflict(pm, pt, at(loop[i]), next_of(loop, i))) return false;
      }
      return true;
    };
    if (!clear_of(boundary)) return false;
    for (std::size_t other = 1; other < loops_.size(); ++other) {
      if (!joined_[other] && !clear_of(loops_[other])) return false;
    }
    const std::size_t i = *at_boundary, j = *at_hole;
    Loop joined(boundary.begin(), boundary.begin() + std::ptrdiff_t(i) + 1);
    for (std::size_t t = 0; t <= hole.size(); ++t) joined.push_back(hole[(j + t) % hole.size()]);
    joined.push_back(boundary[i]);
    joined.insert(joined.end(), boundary.begin() + std::ptrdiff_t(i) + 1, boundary.end());
    boundary = std::move(joined);
    return true;
  }

  std::span<const P2> points_;
  const std::vector<Loop>& loops_;
  const ForbiddenEdge& forbidden_;
  std::vector<char> joined_;
  std::vector<Where> where_;
};

// Stage 4: at every point the joined boundary visits more than once, no visit's interior wedge
// may hold an edge of another visit (that would be a crossing at a vertex, or overlapping
// interiors). Edges along a wedge's bounding ray (the two sides of a bridge) are allowed.
format::Status check_repeated_points(std::span<const P2> points, const Loop& boundary, std::vector<std::size_t>& order) {
  order.resize(boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const P2 &p = points[boundary[x]], &q = points[boundary[y]];
    return lex_less(p, q) || (same_point(p, q) && x < y);
  });
  const std::size_t n = boundary.size();
  auto prev = [&](std::size_t i) -> const P2& { return points[boundary[(i + n - 1) % n]]; };
  auto next = [&](std::size_t i) -> const P2& { return points[boundary[(i + 1) % n]]; };
  for (std::size_t first = 0; first < n;) {
    std::size_t last = first + 1;
    const P2& v = points[boundary[order[first]]];
    while (last < n && same_point(points[boundary[order[last]]], v)) ++last;
    for (std::size_t x = first; x < last; ++x) {
      for (std::size_t y = first; y < last; ++y) {
        if (x == y) continue;
        const std::size_t i = order[x], j = order[y];
        if (wedge_contains(prev(i), v, next(i), prev(j)) || wedge_contains(prev(i), v, next(i), next(j))) {
          return failure("the boundary crosses itself at point " + std::to_string(boundary[i]));
        }
      }
    }
    first = last;
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Stage 5: ear clipping of the weakly simple boundary, best shape first.

struct EarCandidate {
  double quality;
  std::uint32_t tip, before, after;  // point indices, for a tie order that ignores loop rotation
  std::uint32_t node, version;
};

// The ear clipper's arrays, kept in a workspace between polygons.
struct EarBuffers {
  std::vector<std::uint32_t> prev, next, version;
  std::vector<char> alive;
  std::vector<EarCandidate> queue;  // a binary heap (std::push_heap / pop_heap), best on top
};

class EarClipper {
 public:
  EarClipper(std::span<const P2> points, const Loop& boundary, const ForbiddenEdge& forbidden, EdgeKeyMap& edges,
             EarBuffers& buffers)
      : points_(points), forbidden_(forbidden), edges_(edges), id_(boundary), prev_(buffers.prev),
        next_(buffers.next), alive_(buffers.alive), version_(buffers.version), queue_(buffers.queue),
        remaining_(boundary.size()) {
    const std::size_t n = boundary.size();
    prev_.resize(n);
    next_.resize(n);
    alive_.assign(n, 1);
    version_.assign(n, 0);
    queue_.clear();
    for (std::size_t i = 0; i < n; ++i) {
      prev_[i] = std::uint32_t((i + n - 1) % n);
      next_[i] = std::uint32_t((i + 1) % n);
    }
  }

  format::Status run(std::vector<PolygonTriangle>& triangles) {
    int rescans = 0;
    rescan();
    while (remaining_ >= 3) {
      if (queue_.empty()) {
        if (++rescans > kMaxRescans) {
          return failure("gave up after " + std::to_string(kMaxRescans) + " full ear searches with " +
                         std::to_string(remaining_) + " vertices left");
        }
        rescan();
        if (queue_.empty()) {
          return failure("no valid ear among the " + std::to_string(remaining_) +
                         " remaining vertices (self-intersecting or degenerate polygon, or every ear needs a "
                         "forbidden or existing edge)");
        }
        continue;
      }
      std::pop_heap(queue_.begin(), queue_.end(), LowerPriority());
      const Candidate top = queue_.back();
      queue_.pop_back();
      if (!alive_[top.node] || version_[top.node] != top.version) continue;
      // New diagonals elsewhere can spoil a queued ear (its diagonal may now exist): re-check.
      if (!ear_quality(top.node)) continue;
      clip(top.node, triangles);
    }
    if (remaining_ != 0) {
      return failure("the polygon degenerates to a dangling edge after " + std::to_string(triangles.size()) +
                     " triangles");
    }
    return {};
  }

  std::size_t lobes() const { return lobes_; }

 private:
  using Candidate = EarCandidate;
  struct LowerPriority {
    bool operator()(const Candidate& x, const Candidate& y) const {
      if (x.quality != y.quality) return x.quality < y.quality;
      return std::tie(x.tip, x.before, x.after, x.node) > std::tie(y.tip, y.before, y.after, y.node);
    }
  };

  const P2& at(std::uint32_t node) const { return points_[id_[node]]; }

  // Does an edge of `node` (a vertex at the triangle corner `corner`) point strictly into the
  // triangle's angle there? side_in and side_out are the corner's neighbours in the triangle,
  // counter-clockwise: the angle is left of corner -> side_in and right of corner -> side_out.
  bool enters_corner(std::uint32_t node, const P2& corner, const P2& side_in, const P2& side_out) const {
    for (std::uint32_t neighbour : {prev_[node], next_[node]}) {
      const P2& n = at(neighbour);
      if (orientation_2d(corner, side_in, n) > 0 && orientation_2d(side_out, corner, n) > 0) return true;
    }
    return false;
  }

  // The shape quality of the ear at node b, or nothing if clipping it would not be valid.
  std::optional<double> ear_quality(std::uint32_t b) const {
    const std::uint32_t a = prev_[b], c = next_[b];
    const P2 &pa = at(a), &pb = at(b), &pc = at(c);
    if (orientation_2d(pa, pb, pc) <= 0) return std::nullopt;
    if (remaining_ == 3) return shape_quality(pa, pb, pc);
    const bool closes_lobe = id_[next_[c]] == id_[a];
    if (!closes_lobe && (edges_.contains(edge_key(id_[a], id_[c])) || is_forbidden(forbidden_, id_[a], id_[c]))) {
      return std::nullopt;
    }
    const double min_x = std::min({pa[0], pb[0], pc[0]}), max_x = std::max({pa[0], pb[0], pc[0]});
    const double min_y = std::min({pa[1], pb[1], pc[1]}), max_y = std::max({pa[1], pb[1], pc[1]});
    for (std::uint32_t w = next_[c]; w != a; w = next_[w]) {
      const P2& pw = at(w);
      if (pw[0] < min_x || pw[0] > max_x || pw[1] < min_y || pw[1] > max_y) continue;
      if (same_point(pw, pa)) {
        if (enters_corner(w, pa, pb, pc)) return std::nullopt;
      } else if (same_point(pw, pb)) {
        if (enters_corner(w, pb, pc, pa)) return std::nullopt;
      } else if (same_point(pw, pc)) {
        if (enters_corner(w, pc, pa, pb)) return std::nullopt;
      } else if (orientation_2d(pa, pb, pw) >= 0 && orientation_2d(pb, pc, pw) >= 0 &&
                 orientation_2d(pc, pa, pw) >= 0) {
        return std::nullopt;
      }
    }
    return shape_quality(pa, pb, pc);
  }

  void push_if_ear(std::uint32_t node) {
    if (auto quality = ear_quality(node)) {
      queue_.push_back({*quality, id_[node], id_[prev_[node]], id_[next_[node]], node, version_[node]});
      std::push_heap(queue_.begin(), queue_.end(), LowerPriority());
    }
  }

  void rescan() {
    queue_.clear();
    for (std::uint32_t node = 0; node < id_.size(); ++node) {
      if (!alive_[node]) continue;
      ++version_[node];
      push_if_ear(node);
    }
  }

  void unlink(std::uint32_t node) {
    next_[prev_[node]] = next_[node];
    prev_[next_[node]] = prev_[node];
    alive_[node] = 0;
    --remaining_;
  }

  void clip(std::uint32_t b, std::vector<PolygonTriangle>& triangles) {
    const std::uint32_t a = prev_[b], c = next_[b];
    triangles.push_back({id_[a], id_[b], id_[c]});
    if (remaining_ == 3) {
      unlink(b), unlink(c), unlink(a);
      return;
    }
    std::uint32_t after = c;
    if (id_[next_[c]] == id_[a]) {
      // ..., a, b, c, a, q, ...: the triangle closes a lobe of the boundary on its own.
      const std::uint32_t again = next_[c];
      after = next_[again];
      unlink(b), unlink(c), unlink(again);
      ++lobes_;
    } else {
      edges_.insert(edge_key(id_[a], id_[c]));
      unlink(b);
    }
    for (std::uint32_t node : {a, after}) {
      if (!alive_[node]) continue;
      ++version_[node];
      if (remaining_ >= 3) push_if_ear(node);
    }
  }

  std::span<const P2> points_;
  const ForbiddenEdge& forbidden_;
  EdgeKeyMap& edges_;  // membership only
  const Loop& id_;
  std::vector<std::uint32_t>&prev_, &next_;
  std::vector<char>& alive_;
  std::vector<std::uint32_t>& version_;
  std::vector<Candidate>& queue_;
  std::size_t remaining_;
  std::size_t lobes_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Stage 6: Lawson's flips towards the Delaunay triangulation, over new edges only.

void flip_towards_delaunay(std::span<const P2> points, std::vector<PolygonTriangle>& triangles,
                           const EdgeKeyMap& loop_edges, EdgeKeyMap& edges, const ForbiddenEdge& forbidden,
                           EdgeKeyMap& owner, std::vector<std::pair<std::uint32_t, std::uint32_t>>& pending) {
  owner.reset(3 * triangles.size());  // directed edge -> triangle; lookups only
  pending.clear();
  for (std::uint32_t t = 0; t < triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = triangles[t][k], v = triangles[t][(k + 1) % 3];
      owner.emplace(directed_key(u, v), 0) = t;
      if (u < v && !loop_edges.contains(edge_key(u, v))) pending.push_back({u, v});
    }
  }
  std::reverse(pending.begin(), pending.end());  // first triangles first
  // Lawson's algorithm terminates (each flip lowers the lifted surface); the cap only bounds
  // the work, and stopping early still leaves a valid triangulation.
  const std::size_t max_flips = 4 * triangles.size() * triangles.size() + 64;
  std::size_t flips = 0;
  auto third = [&](std::uint32_t t, std::uint32_t u, std::uint32_t v) {
    const PolygonTriangle& tri = triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] == u && tri[(k + 1) % 3] == v) return tri[(k + 2) % 3];
    }
    assert(false && "triangle does not hold the edge");
    return u;
  };
  while (!pending.empty() && flips < max_flips) {
    const auto [u, v] = pending.back();
    pending.pop_back();
    const std::uint32_t* first = owner.find(directed_key(u, v));
    const std::uint32_t* second = owner.find(directed_key(v, u));
    if (first == nullptr || second == nullptr) continue;
    const std::uint32_t t1 = *first, t2 = *second;
    const std::uint32_t w = third(t1, u, v), x = third(t2, v, u);
    if (w == x) continue;
    const P2 &pu = points[u], &pv = points[v], &pw = points[w], &px = points[x];
    if (CGAL::side_of_oriented_circle(CgalPoint(pu[0], pu[1]), CgalPoint(pv[0], pv[1]), CgalPoint(pw[0], pw[1]),
                                      CgalPoint(px[0], px[1])) != CGAL::ON_POSITIVE_SIDE) {
      continue;
    }
    if (orientation_2d(pu, px, pw) <= 0 || orientation_2d(px, pv, pw) <= 0) continue;
    if (edges.contains(edge_key(w, x)) || is_forbidden(forbidden, w, x)) continue;
    triangles[t1] = {u, x, w};
    triangles[t2] = {x, v, w};
    owner.erase(directed_key(u, v));
    owner.erase(directed_key(v, u));
    owner.emplace(directed_key(u, x), 0) = t1, owner.emplace(directed_key(x, w), 0) = t1;
    owner.emplace(directed_key(w, u), 0) = t1;
    owner.emplace(directed_key(x, v), 0) = t2, owner.emplace(directed_key(v, w), 0) = t2;
    owner.emplace(directed_key(w, x), 0) = t2;
    edges.erase(edge_key(u, v));
    edges.insert(edge_key(w, x));
    ++flips;
    for (auto [p, q] : {std::pair{u, x}, std::pair{x, v}, std::pair{v, w}, std::pair{w, u}}) {
      if (!loop_edges.contains(edge_key(p, q))) pending.push_back({std::min(p, q), std::max(p, q)});
    }
  }
}

}  // namespace

struct PolygonWorkspace::Buffers {
  std::vector<SweepEdge> sweep;
  std::vector<Loop> oriented;
  Loop boundary;
  std::vector<std::size_t> order;
  EdgeKeyMap loop_edges, edges, owner;
  EarBuffers ears;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pending;
};

PolygonWorkspace::PolygonWorkspace() : buffers_(std::make_unique<Buffers>()) {}
PolygonWorkspace::~PolygonWorkspace() = default;

int orientation_2d(const PolygonPoint2& a, const PolygonPoint2& b, const PolygonPoint2& c) {
  // Two equal points are collinear with any third: exactly 0, which the filtered predicate
  // would only reach through its exact (slow) stage.
  if (same_point(a, b) || same_point(b, c) || same_point(a, c)) return 0;
  const CGAL::Orientation o = CGAL::orientation(CgalPoint(a[0], a[1]), CgalPoint(b[0], b[1]), CgalPoint(c[0], c[1]));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

std::vector<PolygonPoint2> project_to_plane(std::span<const PolygonPoint3> points, const PolygonPoint3& normal,
                                            const PolygonPoint3& origin) {
  std::vector<PolygonPoint2> out;
  project_to_plane(points, normal, origin, out);
  return out;
}

void project_to_plane(std::span<const PolygonPoint3> points, const PolygonPoint3& normal, const PolygonPoint3& origin,
                      std::vector<PolygonPoint2>& out) {
  const double length = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  assert(std::isfinite(length) && length > 0 && "project_to_plane needs a finite non-zero normal");
  const PolygonPoint3 n = {normal[0] / length, normal[1] / length, normal[2] / length};
  // Helper axis: the coordinate axis least aligned with n (lowest index on ties).
  int axis = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(n[i]) < std::abs(n[axis])) axis = i;
  }
  PolygonPoint3 e = {0, 0, 0};
  e[axis] = 1;
  PolygonPoint3 u = {n[1] * e[2] - n[2] * e[1], n[2] * e[0] - n[0] * e[2], n[0] * e[1] - n[1] * e[0]};
  const double u_length = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  u = {u[0] / u_length, u[1] / u_length, u[2] / u_length};
  const PolygonPoint3 v = {n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
  out.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double dx = points[i][0] - origin[0], dy = points[i][1] - origin[1], dz = points[i][2] - origin[2];
    out[i] = {dx * u[0] + dy * u[1] + dz * u[2], dx * v[0] + dy * v[1] + dz * v[2]};
  }
}

format::Result<std::vector<PolygonTriangle>> triangulate_polygon(std::span<const PolygonPoint3> points,
                                                                 std::span<const std::vector<std::uint32_t>> loops,
                                                                 const PolygonPoint3& normal,
                                                                 const ForbiddenEdge& forbidden) {
  const double length2 = normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2];
  if (!std::isfinite(length2) || !(length2 > 0)) return failure("the normal is zero or not finite");
  if (loops.empty() || loops[0].empty()) return failure("no boundary loop");
  if (loops[0][0] >= points.size()) {
    return failure("loop 0 refers to point " + std::to_string(loops[0][0]) + " of " + std::to_string(points.size()));
  }
  const std::vector<PolygonPoint2> plane = project_to_plane(points, normal, points[loops[0][0]]);
  return triangulate_polygon_2d(plane, loops, forbidden);
}

format::Result<std::vector<PolygonTriangle>> triangulate_polygon_2d(std::span<const PolygonPoint2> points,
                                                                    std::span<const std::vector<std::uint32_t>> loops,
                                                                    const ForbiddenEdge& forbidden) {
  PolygonWorkspace workspace;
  std::vector<PolygonTriangle> triangles;
  GM_RETURN_IF_ERROR(triangulate_polygon_2d(points, loops, forbidden, workspace, triangles));
  return triangles;
}

format::Status triangulate_polygon_2d(std::span<const PolygonPoint2> points,
                                      std::span<const std::vector<std::uint32_t>> loops, const ForbiddenEdge& forbidden,
                                      PolygonWorkspace& workspace, std::vector<PolygonTriangle>& triangles) {
  PolygonWorkspace::Buffers& ws = workspace.buffers();
  triangles.clear();
  GM_RETURN_IF_ERROR(check_loops(points, loops, ws.sweep));
  std::vector<Loop>& oriented = ws.oriented;
  oriented.resize(loops.size());
  std::size_t total = 0;
  for (std::size_t k = 0; k < oriented.size(); ++k) {
    oriented[k].assign(loops[k].begin(), loops[k].end());
    const int wanted = k == 0 ? 1 : -1;
    if (loop_orientation(points, oriented[k]) != wanted) reverse_loop(oriented[k]);
    total += oriented[k].size();
  }
  if (total >= std::numeric_limits<std::uint32_t>::max() / 2) return failure("too many loop vertices");

  EdgeKeyMap& loop_edges = ws.loop_edges;
  loop_edges.reset(total);
  for (const Loop& loop : oriented) {
    for (std::size_t i = 0; i < loop.size(); ++i) loop_edges.insert(edge_key(loop[i], loop[(i + 1) % loop.size()]));
  }

  Loop& boundary = ws.boundary;
  std::size_t spliced = 0;
  if (oriented.size() == 1) {
    boundary = oriented[0];  // no hole to join
  } else {
    GM_RETURN_IF_ERROR(HoleJoiner(points, oriented, forbidden).run(boundary, spliced));
  }
  GM_RETURN_IF_ERROR(check_repeated_points(points, boundary, ws.order));

  // Every loop edge, then the bridges (a bridge is an edge of the joined boundary).
  EdgeKeyMap& edges = ws.edges;
  edges.reset(2 * boundary.size());
  for (const Loop& loop : oriented) {
    for (std::size_t i = 0; i < loop.size(); ++i) edges.insert(edge_key(loop[i], loop[(i + 1) % loop.size()]));
  }
  for (std::size_t i = 0; i < boundary.size(); ++i) edges.insert(edge_key(boundary[i], boundary[(i + 1) % boundary.size()]));

  triangles.reserve(boundary.size());
  EarClipper clipper(points, boundary, forbidden, edges, ws.ears);
  GM_RETURN_IF_ERROR(clipper.run(triangles));
  // A weakly simple boundary of N visits gives N - 2 triangles, 2 fewer per closed lobe.
  if (triangles.size() + 2 + 2 * clipper.lobes() != boundary.size()) {
    return failure("internal count mismatch: " + std::to_string(triangles.size()) + " triangles for " +
                   std::to_string(boundary.size()) + " boundary visits");
  }
  flip_towards_delaunay(points, triangles, loop_edges, edges, forbidden, ws.owner, ws.pending);
  return {};
}

}  // namespace gaussmesh::stream
