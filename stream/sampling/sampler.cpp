// Memoryless Gauss mesh sampling (paper §4 "Sampling Manifold Meshes", §4.1 noise):
// face normals and labels, feature edges, candidates, non-sample filter, represented Gaussian
// vertex, curvature characteristic, and the exact sample test (winding numbers with exact
// orientation signs); sample_mesh() chains them with the patch filters.
#include "stream/sampling/sampler.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <chrono>
#include <ctime>
#include <numbers>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "stream/core/exact_predicates.h"
#include "stream/sampling/patch_filters.h"

namespace gaussmesh::stream {
namespace {

using format::Vec3f;

constexpr double kDegenerateRatio = 1e-7;  // |cross| <= this × sum of squared edge lengths
constexpr double kHemisphereMargin = 1e-3;  // polygon vertices and g must have n·c above this

// orientation_sign with its static filter inlined (stream/core/exact_predicates.h); the calls the
// filter cannot decide go to orientation_sign. Exact, so the same signs.
inline int orient(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  if (const int sign = orientation_sign_filter(a, b, c)) return sign;
  return orientation_sign(a, b, c);
}

// Winding number, around unit-ish direction g, of the closed spherical polygon poly (great arcs
// between consecutive normals, the last joined to the first). Precondition: every poly[i] and g
// lie in the open hemisphere around some direction c. Central projection onto the plane tangent
// at c maps the arcs to segments and keeps every orientation sign, so this is the plane
// crossing-number rule (upward crossing with g on the left: +1, downward with g on the right:
// -1) with "up" measured by the exact sign of det[p, g, d] for a fixed d not parallel to g.
// sign det[p, g, d] > 0 for d the unit vector of `axis`: the axis component of p × g, a
// difference of two products (rounding of each product and of the difference: at most
// 2u (1 + u) of their absolute sum; the filter allows 4u), else orientation_sign. Exact.
inline bool is_above(const Vec3d& p, const Vec3d& g, int axis, const Vec3d& d) {
  double x, y;
  if (axis == 0) {
    x = p.y * g.z, y = p.z * g.y;
  } else if (axis == 1) {
    x = p.z * g.x, y = p.x * g.z;
  } else {
    x = p.x * g.y, y = p.y * g.x;
  }
  const double det = x - y, perm = std::abs(x) + std::abs(y);
  constexpr double kBound = 4 * 0x1.0p-53;
  if (perm > 1e-150 && perm < 1e150) {
    if (det > kBound * perm) return true;
    if (det < -kBound * perm) return false;
  }
  return orientation_sign(p, g, d) > 0;
}

// Bit i set iff poly[i] is above g (is_above), for k <= 64 points, the filter of is_above
// without branches; false when the filter leaves a point undecided (the caller then asks
// is_above point by point). U, W: the components of p × g whose difference is `axis`'s.
template <int kU, int kW>
bool above_bits(const Vec3d* poly, std::size_t k, const Vec3d& g, std::uint64_t& bits) {
  auto component = [](const Vec3d& p, int c) { return c == 0 ? p.x : (c == 1 ? p.y : p.z); };
  const double gu = component(g, kU), gw = component(g, kW);
  constexpr double kBound = 4 * 0x1.0p-53;
  std::uint64_t above = 0;
  bool decided = true;
  for (std::size_t i = 0; i < k; ++i) {
    const double x = component(poly[i], kU) * gw, y = component(poly[i], kW) * gu;
    const double det = x - y, perm = std::abs(x) + std::abs(y);
    const bool is_up = det > kBound * perm, is_down = det < -kBound * perm;
    decided &= (is_up | is_down) & (perm > 1e-150) & (perm < 1e150);
    above |= static_cast<std::uint64_t>(is_up) << i;
  }
  bits = above;
  return decided;
}

int winding_number(const Vec3d* poly, std::size_t k, const Vec3d& g) {
  const double ax = std::abs(g.x), ay = std::abs(g.y), az = std::abs(g.z);
  const int axis = ax <= ay && ax <= az ? 0 : (ay <= az ? 1 : 2);
  const Vec3d d = axis == 0 ? Vec3d{1, 0, 0} : (axis == 1 ? Vec3d{0, 1, 0} : Vec3d{0, 0, 1});
  int w = 0;
  if (k <= 64) {
    // The same signs as the loop below, as a bit mask: the edges (i, i + 1) that cross the
    // plane are the bits where `above` and its rotation differ; only those need orient.
    std::uint64_t above = 0;
    const bool decided = axis == 0   ? above_bits<1, 2>(poly, k, g, above)
                         : axis == 1 ? above_bits<2, 0>(poly, k, g, above)
                                     : above_bits<0, 1>(poly, k, g, above);
    if (!decided) {
      above = 0;
      for (std::size_t i = 0; i < k; ++i) above |= static_cast<std::uint64_t>(is_above(poly[i], g, axis, d)) << i;
    }
    const std::uint64_t all = k == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << k) - 1;
    const std::uint64_t next = ((above >> 1) | (above << (k - 1))) & all;  // bit i: poly[i + 1 mod k]
    for (std::uint64_t up = ~above & next & all; up != 0; up &= up - 1) {
      const std::size_t i = static_cast<std::size_t>(std::countr_zero(up));
      if (orient(poly[i], poly[i + 1 == k ? 0 : i + 1], g) > 0) ++w;
    }
    for (std::uint64_t down = above & ~next & all; down != 0; down &= down - 1) {
      const std::size_t i = static_cast<std::size_t>(std::countr_zero(down));
      if (orient(poly[i], poly[i + 1 == k ? 0 : i + 1], g) < 0) --w;
    }
    return w;
  }
  bool above_first = is_above(poly[0], g, axis, d);
  bool above_a = above_first;
  for (std::size_t i = 0; i < k; ++i) {
    const Vec3d& a = poly[i];
    const Vec3d& b = poly[i + 1 == k ? 0 : i + 1];
    const bool above_b = i + 1 == k ? above_first : is_above(b, g, axis, d);
    if (!above_a && above_b) {
      if (orient(a, b, g) > 0) ++w;
    } else if (above_a && !above_b) {
      if (orient(a, b, g) < 0) --w;
    }
    above_a = above_b;
  }
  return w;
}

// Characteristic from a winding number and the side of the neighbours (sum of (p_w - p_v)·g),
// which only a positive winding reads.
Characteristic classify(int winding, double neighbour_side) {
  if (winding == 0) return Characteristic::kNone;
  if (winding < 0) return Characteristic::kSaddle;
  return neighbour_side < 0 ? Characteristic::kConvex : Characteristic::kConcave;
}

// Scratch buffers reused across vertices (no per-vertex allocation).
// A set of ids for one cap search: open addressing over a table that grows with the search
// (never with G), cleared per search: linear scans would be quadratic on big caps.
class IdSet {
 public:
  void clear() {
    if (count_ > 0) std::fill(slots_.begin(), slots_.end(), 0u);
    count_ = 0;
  }
  // True if id was not in the set (and is now).
  bool insert(std::uint32_t id) {
    if (2 * (count_ + 1) > slots_.size()) grow();
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t k = hash(id) & mask;; k = (k + 1) & mask) {
      if (slots_[k] == id + 1) return false;
      if (slots_[k] == 0) {
        slots_[k] = id + 1;
        ++count_;
        return true;
      }
    }
  }
  bool contains(std::uint32_t id) const {
    if (slots_.empty()) return false;
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t k = hash(id) & mask;; k = (k + 1) & mask) {
      if (slots_[k] == id + 1) return true;
      if (slots_[k] == 0) return false;
    }
  }

 private:
  static std::size_t hash(std::uint32_t id) { return (id * 0x9E3779B1u) >> 7; }
  void grow() {
    std::vector<std::uint32_t> old;
    old.swap(slots_);
    slots_.assign(old.empty() ? 64 : 2 * old.size(), 0u);
    count_ = 0;
    for (std::uint32_t v : old)
      if (v != 0) insert(v - 1);
  }
  std::vector<std::uint32_t> slots_;  // id + 1; 0 is empty
  std::size_t count_ = 0;
};

struct Scratch {
  std::vector<std::uint32_t> labels;    // distinct labels of the current fan (large fans)
  std::vector<Vec3d> poly;              // the current fan's normals (fit_star: degree entries)
  std::vector<std::uint32_t> visited;   // Gaussian triangles of the cap search, in visit order
  std::vector<std::uint32_t> gauss;     // Gaussian vertices to test
  IdSet visited_set, gauss_set;         // membership of the two lists above
  std::vector<std::uint32_t> star_labels;  // MergeLabels: the labels of the current star
  std::uint32_t star_begin = 0;
  // The current star's labels by slot (read once, by the fast path).
  std::vector<std::uint32_t> star_label;
  std::vector<std::uint8_t> star_slot;  // of each slot's label around the represented v_G
  void fit_star(std::uint32_t degree) {
    if (star_label.size() < degree) {
      star_label.resize(degree);
      star_slot.resize(degree);
      poly.resize(degree);
    }
  }
};

// acos(clamp(x, -1, 1)) <= t, decided with cosines where the answer is clear by a margin of
// 1e-9 (|d acos/dx| >= 1, so a margin in x is at least that margin in angle) and by acos itself
// in that band: the same booleans as the acos comparison, without calling acos almost always.
// cos_t approximates cos(t) to well within the margin.
bool angle_within(double x, double t, double cos_t) {
  if (t >= std::numbers::pi) return true;  // acos never exceeds pi
  if (x > cos_t + 1e-9) return true;
  if (x < cos_t - 1e-9) return false;
  return std::acos(std::clamp(x, -1.0, 1.0)) <= t;
}

// The Gaussian vertices that a polygon inside the cap (c, cos_theta) may enclose: corners of
// the Gaussian triangles that meet the cap, found by a walk from the triangle holding c.
// Angles compare as acos(x) <= theta + alpha + 1e-9 (alpha: a triangle's cap angle), decided by
// angle_within with cos(theta + alpha + 1e-9) from the addition formula.
void gauss_vertices_in_cap(const GaussSphere& gauss, const Vec3d& c, double cos_theta, Scratch& s) {
  const double theta = std::acos(std::clamp(cos_theta, -1.0, 1.0));
  const double ct = std::cos(theta), st = std::sin(theta);
  const double vertex_t = theta + 1e-9;
  const double vertex_cos = ct - 1e-9 * st;  // cos(theta + 1e-9) to O(1e-18)
  s.visited.clear();
  s.gauss.clear();
  s.visited_set.clear();
  s.gauss_set.clear();
  s.visited.push_back(gauss.locate(c));
  s.visited_set.insert(s.visited[0]);
  for (std::size_t k = 0; k < s.visited.size() && s.visited.size() < 4096; ++k) {
    const std::uint32_t t = s.visited[k];
    for (std::uint32_t g : gauss.triangle_vertices(t)) {
      if (s.gauss_set.contains(g)) continue;
      const double gc = dot(gauss.vertex(g), c);
      if (gc > kHemisphereMargin && angle_within(std::min(gc, 1.0), vertex_t, vertex_cos)) {
        s.gauss_set.insert(g);
        s.gauss.push_back(g);
      }
    }
    for (std::uint32_t n : gauss.triangle_neighbors(t)) {
      if (s.visited_set.contains(n)) continue;
      const double alpha = gauss.triangle_cap_angle(n);
      const double reach = theta + alpha + 1e-9;
      const double ca = gauss.triangle_cap_angle_cos(n), sa = gauss.triangle_cap_angle_sin(n);
      // cos(theta + alpha + 1e-9) = cos(theta + alpha) - 1e-9 sin(theta + alpha) + O(1e-18).
      const double reach_cos = (ct * ca - st * sa) - 1e-9 * (st * ca + ct * sa);
      if (angle_within(dot(gauss.triangle_center(n), c), reach, reach_cos)) {
        s.visited.push_back(n);
        s.visited_set.insert(n);
      }
    }
  }
  std::sort(s.gauss.begin(), s.gauss.end());
}

// Closes the polygon of a fan's own normals and checks it lies in an open hemisphere; returns
// false (no verdict) otherwise. On success c is the hemisphere's pole.
bool fan_polygon(const Vec3d* poly, std::size_t k, Vec3d& c, double& cos_theta) {
  c = {};
  for (std::size_t i = 0; i < k; ++i) c = c + poly[i];
  const double len = std::sqrt(dot(c, c));
  if (!(len > 0)) return false;
  c = (1.0 / len) * c;
  cos_theta = 1.0;
  for (std::size_t i = 0; i < k; ++i) cos_theta = std::min(cos_theta, dot(poly[i], c));
  return cos_theta > kHemisphereMargin;
}

// Whether the winding around g is counted: g in the hemisphere around c and in the polygon's cap
// by 1e-9. The polygon lies in the cap {x : x·c >= cos_theta} (convex: cos_theta > 0), so it
// does not wind around a direction outside it; by 1e-9 that is certain despite rounding, and
// the exact winding would be 0.
bool winds_maybe(const Vec3d& g, const Vec3d& c, double cos_theta) {
  const double gc = dot(g, c);
  return gc > kHemisphereMargin && gc >= cos_theta - 1e-9;
}

// Where x / |c| lies against t > 0, for x a dot product with the unnormalised c (len2 = c·c),
// compared through squares: kAbove or kBelow when certain by a relative margin of 1e-9 (far
// above the rounding of either this or fan_polygon's normalised computation, ~1e-15 for unit
// vectors), else kUnsure (also for len2 outside [1e-100, 1e100] and NaN).
enum class Side { kBelow, kAbove, kUnsure };
Side side_of_scaled(double x, double t, double len2) {
  if (!(len2 >= 1e-100 && len2 <= 1e100)) return Side::kUnsure;
  if (x <= 0) return Side::kBelow;
  const double x2 = x * x, bound = t * t * len2;
  if (x2 > bound * (1 + 1e-9)) return Side::kAbove;
  if (x2 < bound * (1 - 1e-9)) return Side::kBelow;
  return Side::kUnsure;
}

// fan_polygon's verdict and, for a Gaussian vertex g (the zero vector: none), winds_maybe's,
// decided from the unnormalised sum c of the polygon's k >= 1 unit normals: the hemisphere test
// is min(1, min_i n_i·c / |c|) > kHemisphereMargin, g's are g·c / |c| > kHemisphereMargin and
// (min_i n_i·c - g·c) / |c| <= 1e-9, each decided by side_of_scaled with a margin (the last one
// between 0.5e-9 and 2e-9, where winds_maybe's 1e-9 cannot fall). kUndecided: ask fan_polygon.
enum class FanDecision { kNoHemisphere, kWindsNot, kWindsMaybe, kUndecided };
FanDecision fan_decisions(const Vec3d* poly, std::size_t k, const Vec3d& g) {
  Vec3d c{};
  for (std::size_t i = 0; i < k; ++i) c = c + poly[i];
  const double len2 = dot(c, c);
  double min_dot = dot(poly[0], c);
  for (std::size_t i = 1; i < k; ++i) min_dot = std::min(min_dot, dot(poly[i], c));
  const Side hemisphere = side_of_scaled(min_dot, kHemisphereMargin, len2);
  if (hemisphere == Side::kUnsure) return FanDecision::kUndecided;
  if (hemisphere == Side::kBelow) return FanDecision::kNoHemisphere;
  if (g.x == 0 && g.y == 0 && g.z == 0) return FanDecision::kWindsNot;
  const double gc = dot(g, c);
  const Side g_hemisphere = side_of_scaled(gc, kHemisphereMargin, len2);
  if (g_hemisphere == Side::kUnsure) return FanDecision::kUndecided;
  if (g_hemisphere == Side::kBelow) return FanDecision::kWindsNot;
  const double outside = min_dot - gc;  // > 0: g beyond the cap's rim
  if (side_of_scaled(outside, 2e-9, len2) == Side::kAbove) return FanDecision::kWindsNot;
  if (side_of_scaled(outside, 0.5e-9, len2) == Side::kBelow) return FanDecision::kWindsMaybe;
  return FanDecision::kUndecided;
}

}  // namespace

const char* sample_test_name(SampleTest test) { return test == SampleTest::kExact ? "exact" : "paper"; }


namespace {

constexpr std::size_t kFaceGrain = 16384;    // faces per parallel task
constexpr std::size_t kVertexBlock = 32768;  // vertices per parallel block of evaluate_vertices

bool is_zero(const Vec3f& n) { return n.x == 0 && n.y == 0 && n.z == 0; }

template <typename Body>
void for_faces(std::size_t n, const Body& body) {
  if (n <= kFaceGrain) {
    body(std::size_t{0}, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kFaceGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

std::uint8_t feature_bits(const std::uint32_t* nb, const std::uint32_t* labels, std::size_t f) {
  // Without branches (labels differ across about half the edges of a noisy mesh): a break edge
  // reads the face's own label and sets its bit anyway.
  const std::uint32_t l = labels[f];
  unsigned bits = 0;
  for (unsigned i = 0; i < 3; ++i) {
    const std::uint32_t g = nb[3 * f + i];
    const bool is_break = g == MeshAdjacency::kNoFace;
    const std::size_t h = is_break ? f : g;
    bits |= static_cast<unsigned>(is_break | (labels[h] != l)) << i;
  }
  return static_cast<std::uint8_t>(bits);
}

}  // namespace

void compute_face_normals(format::MeshView mesh, const MeshAdjacency& adjacency, std::uint32_t smooth_iterations,
                          FaceNormals& out, std::vector<float>& area_buffer, std::vector<format::Vec3f>& scratch) {
  const std::size_t nf = mesh.triangles.size();
  out.normal.resize(nf);
  out.degenerate.resize(nf);
  area_buffer.resize(nf);
  const Vec3f* pos = mesh.positions.data();
  const format::Triangle* tris = mesh.triangles.data();
  Vec3f* normal = out.normal.data();
  std::uint8_t* degenerate = out.degenerate.data();
  float* area = area_buffer.data();
  std::atomic<std::size_t> degenerate_count{0};
  for_faces(nf, [&](std::size_t begin, std::size_t end) {
    std::size_t local = 0;
    auto one_face = [&](std::size_t f) {
      const auto& t = tris[f];
      const Vec3d p0 = to_d(pos[t.v[0]]), p1 = to_d(pos[t.v[1]]), p2 = to_d(pos[t.v[2]]);
      const Vec3d e1 = p1 - p0, e2 = p2 - p0, e3 = p2 - p1;
      const Vec3d n = cross(e1, e2);
      const double len = std::sqrt(dot(n, n));
      if (!(len > kDegenerateRatio * (dot(e1, e1) + dot(e2, e2) + dot(e3, e3)))) {
        degenerate[f] = 1;
        ++local;
        area[f] = 0;
        normal[f] = {};
        return;
      }
      const double s = 1.0 / len;
      degenerate[f] = 0;
      normal[f] = {static_cast<float>(n.x * s), static_cast<float>(n.y * s), static_cast<float>(n.z * s)};
      area[f] = static_cast<float>(0.5 * len);
    };
    std::size_t f = begin;
#if defined(__SSE2__)
    // Two faces per step in the two lanes of SSE2 doubles: one_face's IEEE operations in the
    // same order (no FMA), so the same bits. A pair with a degenerate face goes to one_face.
    auto load = [&](std::uint32_t a, std::uint32_t b, __m128d& x, __m128d& y, __m128d& z) {
      x = _mm_set_pd(pos[b].x, pos[a].x);
      y = _mm_set_pd(pos[b].y, pos[a].y);
      z = _mm_set_pd(pos[b].z, pos[a].z);
    };
    auto dot2 = [](__m128d ax, __m128d ay, __m128d az, __m128d bx, __m128d by, __m128d bz) {
      return _mm_add_pd(_mm_add_pd(_mm_mul_pd(ax, bx), _mm_mul_pd(ay, by)), _mm_mul_pd(az, bz));
    };
    for (; f + 2 <= end; f += 2) {
      const auto& ta = tris[f];
      const auto& tb = tris[f + 1];
      __m128d p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z;
      load(ta.v[0], tb.v[0], p0x, p0y, p0z);
      load(ta.v[1], tb.v[1], p1x, p1y, p1z);
      load(ta.v[2], tb.v[2], p2x, p2y, p2z);
      const __m128d e1x = _mm_sub_pd(p1x, p0x), e1y = _mm_sub_pd(p1y, p0y), e1z = _mm_sub_pd(p1z, p0z);
      const __m128d e2x = _mm_sub_pd(p2x, p0x), e2y = _mm_sub_pd(p2y, p0y), e2z = _mm_sub_pd(p2z, p0z);
      const __m128d e3x = _mm_sub_pd(p2x, p1x), e3y = _mm_sub_pd(p2y, p1y), e3z = _mm_sub_pd(p2z, p1z);
      const __m128d nx = _mm_sub_pd(_mm_mul_pd(e1y, e2z), _mm_mul_pd(e1z, e2y));
      const __m128d ny = _mm_sub_pd(_mm_mul_pd(e1z, e2x), _mm_mul_pd(e1x, e2z));
      const __m128d nz = _mm_sub_pd(_mm_mul_pd(e1x, e2y), _mm_mul_pd(e1y, e2x));
      const __m128d len = _mm_sqrt_pd(dot2(nx, ny, nz, nx, ny, nz));
      const __m128d edges = _mm_add_pd(_mm_add_pd(dot2(e1x, e1y, e1z, e1x, e1y, e1z), dot2(e2x, e2y, e2z, e2x, e2y, e2z)),
                                       dot2(e3x, e3y, e3z, e3x, e3y, e3z));
      if (_mm_movemask_pd(_mm_cmpgt_pd(len, _mm_mul_pd(_mm_set1_pd(kDegenerateRatio), edges))) != 3) {
        one_face(f);
        one_face(f + 1);
        continue;
      }
      const __m128d inv = _mm_div_pd(_mm_set1_pd(1.0), len);
      alignas(16) double x[2], y[2], z[2], a[2];
      _mm_store_pd(x, _mm_mul_pd(nx, inv));
      _mm_store_pd(y, _mm_mul_pd(ny, inv));
      _mm_store_pd(z, _mm_mul_pd(nz, inv));
      _mm_store_pd(a, _mm_mul_pd(_mm_set1_pd(0.5), len));
      for (int l = 0; l < 2; ++l) {
        degenerate[f + l] = 0;
        normal[f + l] = {static_cast<float>(x[l]), static_cast<float>(y[l]), static_cast<float>(z[l])};
        area[f + l] = static_cast<float>(a[l]);
      }
    }
#endif
    for (; f < end; ++f) one_face(f);
    degenerate_count += local;
  });
  out.degenerate_count = degenerate_count;
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  // Degenerate faces inherit the area-weighted mean of their edge neighbours' own normals (in
  // place: only degenerate faces are written, only non-degenerate ones read).
  if (out.degenerate_count > 0) {
    for_faces(nf, [&](std::size_t begin, std::size_t end) {
      for (std::size_t f = begin; f < end; ++f) {
        if (!degenerate[f]) continue;
        Vec3d sum{};
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t g = nb[3 * f + i];
          if (g == MeshAdjacency::kNoFace || degenerate[g]) continue;
          sum = sum + static_cast<double>(area[g]) * to_d(normal[g]);
        }
        normal[f] = unit_f(sum);
      }
    });
  }
  if (smooth_iterations > 0) scratch.resize(nf);
  for (std::uint32_t it = 0; it < smooth_iterations; ++it) {
    const Vec3f* cur = out.normal.data();
    Vec3f* next = scratch.data();
    for_faces(nf, [&](std::size_t begin, std::size_t end) {
      for (std::size_t f = begin; f < end; ++f) {
        Vec3d sum = static_cast<double>(area[f]) * to_d(cur[f]);
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t g = nb[3 * f + i];
          if (g != MeshAdjacency::kNoFace) sum = sum + static_cast<double>(area[g]) * to_d(cur[g]);
        }
        const Vec3f u = unit_f(sum);
        next[f] = is_zero(u) ? cur[f] : u;
      }
    });
    out.normal.swap(scratch);
  }
}

FaceNormals compute_face_normals(format::MeshView mesh, const MeshAdjacency& adjacency,
                                 std::uint32_t smooth_iterations) {
  FaceNormals out;
  std::vector<float> area;
  std::vector<Vec3f> scratch;
  compute_face_normals(mesh, adjacency, smooth_iterations, out, area, scratch);
  return out;
}

void compute_face_labels(const FaceNormals& normals, const GaussSphere& gauss, std::vector<std::uint32_t>& labels) {
  const std::size_t nf = normals.normal.size();
  labels.resize(nf);
  const Vec3f* normal = normals.normal.data();
  std::uint32_t* out = labels.data();
  for_faces(nf, [&](std::size_t begin, std::size_t end) {
    gauss.locate(std::span<const Vec3f>(normal + begin, end - begin), std::span<std::uint32_t>(out + begin, end - begin),
                 kNoLabel);
  });
}

std::vector<std::uint32_t> compute_face_labels(const FaceNormals& normals, const GaussSphere& gauss) {
  std::vector<std::uint32_t> labels;
  compute_face_labels(normals, gauss, labels);
  return labels;
}

void compute_feature_edges(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                           std::vector<std::uint8_t>& feature) {
  const std::size_t nf = labels.size();
  feature.resize(nf);
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint32_t* l = labels.data();
  std::uint8_t* out = feature.data();
  for_faces(nf, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) out[f] = feature_bits(nb, l, f);
  });
}

std::vector<std::uint8_t> compute_feature_edges(const MeshAdjacency& adjacency,
                                                const std::vector<std::uint32_t>& labels) {
  std::vector<std::uint8_t> feature;
  compute_feature_edges(adjacency, labels, feature);
  return feature;
}

namespace {

struct VertexInputs {
  format::MeshView mesh;
  const MeshAdjacency& adjacency;
  const FaceNormals& normals;
  const std::uint32_t* labels;
  const std::uint8_t* feature;
  const GaussSphere& gauss;
  bool run_exact_test;
};

// Where evaluate_vertex reads a star's labels and feature bits. label(k, f): the label of face
// f at star slot k; feature(k, f, i): whether edge i of f (the one leaving the vertex at slot
// k) is a feature edge. load(sb, se, s) runs first for each vertex.
struct MeshLabels {  // the mesh's label and feature arrays
  const std::uint32_t* labels;
  const std::uint8_t* feature;
  void load(std::uint32_t, std::uint32_t, Scratch&) const {}
  std::uint32_t label(std::uint32_t, std::uint32_t f, const Scratch&) const { return labels[f]; }
  bool feature_bit(std::uint32_t, std::uint32_t f, std::uint32_t i, const Scratch&) const { return feature[f] >> i & 1; }
};

// The labels during the untriangulatable merge: face f's is its first patch's current label in
// the patch graph (read-only lookups, so several threads may evaluate at once), and a manifold
// edge is a feature edge iff its faces' labels differ (the other face of the edge leaving the
// vertex is in its star).
struct MergeLabels {
  const PatchMergeGraph& graph;
  const std::uint32_t* face_patch;  // of the first find_patches
  const std::uint32_t* corners;
  const std::uint32_t* nb;
  void load(std::uint32_t sb, std::uint32_t se, Scratch& s) const {
    s.star_labels.clear();
    for (std::uint32_t k = sb; k < se; ++k) s.star_labels.push_back(graph.current_label(face_patch[corners[k] / 3]));
    s.star_begin = sb;
  }
  std::uint32_t label(std::uint32_t k, std::uint32_t, const Scratch& s) const { return s.star_labels[k - s.star_begin]; }
  bool feature_bit(std::uint32_t k, std::uint32_t f, std::uint32_t i, const Scratch& s) const {
    const std::uint32_t g = nb[3 * f + i];
    return g == MeshAdjacency::kNoFace || graph.current_label(face_patch[g]) != s.star_labels[k - s.star_begin];
  }
};

constexpr std::size_t kSmallStar = 16;

// Writes the distinct values of labels[0 .. n) to out (n entries of room) and returns how many:
// in first-seen order for n <= kSmallStar (a value equal to its predecessor is skipped before
// the search), else sorted.
std::size_t distinct_labels(const std::uint32_t* labels, std::size_t n, std::uint32_t* out) {
  if (n > kSmallStar) {
    std::copy(labels, labels + n, out);
    std::sort(out, out + n);
    return static_cast<std::size_t>(std::unique(out, out + n) - out);
  }
  std::size_t count = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t l = labels[k];
    if (k > 0 && l == labels[k - 1]) continue;
    bool seen = false;
    for (std::size_t x = 0; x < count; ++x) seen |= out[x] == l;
    if (!seen) out[count++] = l;
  }
  return count;
}

// The first look at every vertex's star: its incident feature edges, its fans, and whether it
// carries more than one label; its labels go to the scratch array (slot k at k - sb) for
// evaluate_vertex. Each slot counts its outgoing edge; the incoming edges add the break edges
// among them, one per open fan (the last slot of an open fan is the only slot whose incoming
// edge is a break: MeshAdjacency), read from the slot flags instead of the faces' edge
// neighbours. Flags are kFanStart, or kFanStart | kFanClosed, or 0, so the open fans are the
// starts less the closed ones: starts = sum of (flag & 1), closed = (sum of flag - starts) / 2.
// Inlined into the vertex loop: most vertices stop here (no candidate), without the call and
// the frame of evaluate_vertex.
struct StarScan {
  std::uint32_t feature_edges = 0, fan_starts = 0;
  bool several_labels = false;
};
template <typename Labels>
[[gnu::always_inline]] inline StarScan scan_star(const Labels& labels, const std::uint32_t* corners,
                                                 const std::uint8_t* flags, std::uint32_t sb, std::uint32_t se,
                                                 Scratch& s) {
  static_assert(MeshAdjacency::kFanStart == 1 && MeshAdjacency::kFanClosed == 2);
  const std::uint32_t first_label = labels.label(sb, corners[sb] / 3, s);
  s.fit_star(se - sb);
  std::uint32_t* star_label = s.star_label.data() - sb;
  std::uint32_t feature_bits = 0, starts = 0, flag_sum = 0, differ = 0;
  for (std::uint32_t k = sb; k < se; ++k) {
    const std::uint32_t c = corners[k], f = c / 3, i = c % 3;
    const std::uint32_t l = labels.label(k, f, s);
    star_label[k] = l;
    feature_bits += labels.feature_bit(k, f, i, s);
    const std::uint32_t flag = flags[k] & 3u;
    flag_sum += flag;
    starts += flag & 1u;
    differ |= l ^ first_label;
  }
  const std::uint32_t closed = (flag_sum - starts) / 2;
  return {feature_bits + (starts - closed), starts, differ != 0};
}

// The per-vertex decisions of one vertex whose non-empty star [sb, se) scan_star read (docs/
// sampling.md); appends a record when the vertex is a candidate or an exact sample.
[[gnu::noinline]] void evaluate_vertex(const VertexInputs& in, std::uint32_t v, std::uint32_t sb, std::uint32_t se,
                                       StarScan scan, Scratch& s, std::vector<VertexRecord>& out) {
  const MeshAdjacency& adjacency = in.adjacency;
  const GaussSphere& gauss = in.gauss;
  const auto* tris = in.mesh.triangles.data();
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  const std::uint8_t* flags = adjacency.slot_flags.data();
  const std::uint32_t feature_count = scan.feature_edges, fan_starts = scan.fan_starts;
  const std::uint32_t* star_label = s.star_label.data() - sb;
  const bool is_candidate = feature_count >= 3;
  const bool test_exact = in.run_exact_test && scan.several_labels;
  if (!is_candidate && !test_exact) return;

  VertexRecord r;
  r.vertex = v;
  r.feature_edges = static_cast<std::uint16_t>(std::min<std::uint32_t>(feature_count, 0xFFFF));
  r.is_candidate = is_candidate;
  const Vec3d pv = to_d(in.mesh.positions[v]);
  auto neighbour_side = [&](const Vec3d& g) {
    double side = 0;
    for (std::uint32_t k = sb; k < se; ++k) {
      const std::uint32_t c = corners[k];
      side += dot(to_d(in.mesh.positions[tris[c / 3].v[(c % 3 + 1) % 3]]) - pv, g);
    }
    return side;
  };

  if (is_candidate) {
    bool has_unlabelled = false;
    for (std::uint32_t k = sb; k < se; ++k) has_unlabelled |= star_label[k] == kNoLabel;

    // Represented Gaussian vertex: the one corner every label is incident on.
    // Bit j of `on_all`: corner j of the first label's triangle is a corner of every label's.
    // The cover mask: bit k for the k-th triangle around it, read from each label's slot table
    // (G's vertices have at most 6 triangles). Repeated labels change neither.
    std::size_t gauss_degree = 0;
    if (!has_unlabelled) {
      const auto& first = gauss.triangle_vertices(star_label[sb]);
      const std::uint32_t a = first[0], b = first[1], c = first[2];
      unsigned on_all = 7;
      for (std::uint32_t k = sb + 1; k < se; ++k) {
        const auto& tv = gauss.triangle_vertices(star_label[k]);
        const std::uint32_t t0 = tv[0], t1 = tv[1], t2 = tv[2];
        on_all &= static_cast<unsigned>((a == t0) | (a == t1) | (a == t2)) |
                  static_cast<unsigned>((b == t0) | (b == t1) | (b == t2)) << 1 |
                  static_cast<unsigned>((c == t0) | (c == t1) | (c == t2)) << 2;
      }
      if (on_all == 1 || on_all == 2 || on_all == 4) {
        const std::uint32_t found = first[on_all == 1 ? 0 : (on_all == 2 ? 1 : 2)];
        r.gauss_vertex = found;
        gauss_degree = gauss.vertex_triangles(found).size();
        assert(gauss_degree <= 8);
        unsigned mask = 0;
        std::uint8_t* star_slot = s.star_slot.data() - sb;
        for (std::uint32_t k = sb; k < se; ++k) {
          const auto& tv = gauss.triangle_vertices(star_label[k]);
          const unsigned j = static_cast<unsigned>(tv[1] == found) + 2 * static_cast<unsigned>(tv[2] == found);
          star_slot[k] = gauss.vertex_triangle_slots(star_label[k])[j];
          mask |= 1u << star_slot[k];
        }
        r.cover_mask = static_cast<std::uint8_t>(mask);
      }
    }

    // Non-sample filter, fan by fan: consecutive labels equal or edge-adjacent, and the fan's
    // distinct labels a tree in G's dual graph.
    bool all_trees = !has_unlabelled;
    if (all_trees && fan_starts == 1 && gauss_degree > 0) {
      // One fan around a represented v_G: its labels are triangles around v_G, and two of those
      // are edge-adjacent iff they are neighbours around it (the link of a vertex of G is a
      // cycle), equal iff their slots are. So consecutive labels are equal or adjacent iff their
      // slots differ by 0 or +-1 modulo the degree; then the labels are a connected part of
      // the cycle (one cover bit each), a tree iff it is not all of it.
      const std::uint8_t* star_slot = s.star_slot.data() - sb;
      const int last = static_cast<int>(gauss_degree) - 1;
      bool adjacent = true;
      for (std::uint32_t k = sb; k < se; ++k) {
        const int step = static_cast<int>(star_slot[k + 1 == se ? sb : k + 1]) - static_cast<int>(star_slot[k]);
        adjacent &= (step >= -1 && step <= 1) | (step == last) | (step == -last);
      }
      all_trees = adjacent && static_cast<std::size_t>(std::popcount(static_cast<unsigned>(r.cover_mask))) < gauss_degree;
    }
    for (std::uint32_t k = sb; k < se && all_trees && !(fan_starts == 1 && gauss_degree > 0);) {
      std::uint32_t fan_end = k + 1;
      while (fan_end < se && !(flags[fan_end] & MeshAdjacency::kFanStart)) ++fan_end;
      const std::uint32_t* fan = star_label + k;
      const std::size_t m = fan_end - k;
      bool adjacent = true;
      for (std::size_t j = 0; j < m; ++j) {
        const std::uint32_t a = fan[j], b = fan[j + 1 == m ? 0 : j + 1];
        adjacent &= (a == b) | gauss.are_edge_adjacent(a, b);
      }
      all_trees = adjacent;
      if (all_trees) {
        s.labels.resize(m);
        const std::size_t count = distinct_labels(fan, m, s.labels.data());
        const std::uint32_t* fan_labels = s.labels.data();
        // A set of triangles whose adjacency graph has |L| - 1 edges and is connected; with
        // consecutive labels adjacent the set is connected, so count the edges.
        std::size_t edges = 0;
        for (std::size_t x = 0; x < count; ++x)
          for (std::size_t y = x + 1; y < count; ++y) edges += gauss.are_edge_adjacent(fan_labels[x], fan_labels[y]);
        if (edges + 1 != count) all_trees = false;
      }
      k = fan_end;
    }
    r.is_tree = all_trees;
  }

  // Windings fan by fan, over each fan's own (non-degenerate) normals. Only needed for a
  // represented v_G or the exact test.
  if (r.gauss_vertex == kNoGaussVertex && !test_exact) {
    if (r.is_candidate) out.push_back(r);
    return;
  }
  const Vec3d vg = r.gauss_vertex != kNoGaussVertex ? gauss.vertex(r.gauss_vertex) : Vec3d{};
  int winding_vg = 0;
  int exact_first = 0;
  std::uint32_t exact_g = kNoGaussVertex;
  std::uint32_t enclosed = 0;
  bool exact_fallback = false;
  const std::uint8_t* degenerate = in.normals.degenerate.data();
  const Vec3f* normal = in.normals.normal.data();
  Vec3d* poly = s.poly.data();
  for (std::uint32_t k = sb; k < se;) {
    std::uint32_t fan_end = k + 1;
    while (fan_end < se && !(flags[fan_end] & MeshAdjacency::kFanStart)) ++fan_end;
    std::size_t corners_in_poly = 0;
    for (std::uint32_t j = k; j < fan_end; ++j) {
      const std::uint32_t f = corners[j] / 3;
      // The star's triangles, for neighbour_side after a positive winding: few candidates need
      // them, but unprefetched those loads miss the cache (the triangles were last read by the
      // normals).
      __builtin_prefetch(tris + f);
      poly[corners_in_poly] = to_d(normal[f]);  // kept unless the face is degenerate
      corners_in_poly += !degenerate[f];
    }
    k = fan_end;
    if (corners_in_poly < 3) continue;
    if (!test_exact) {
      // Paper decisions only (v_G is set, the exact fallback is not read): the fan adds its
      // winding around v_G when it lies in a hemisphere and v_G in its cap (fan_decisions,
      // without fan_polygon's square root and division when the unnormalised sum decides,
      // else fan_polygon and winds_maybe), 0 otherwise. So a winding of 0, most fans', needs
      // neither verdict: the winding comes first (its signs are exact for any polygon).
      const int w = winding_number(poly, corners_in_poly, vg);
      if (w == 0) continue;
      const FanDecision d = fan_decisions(poly, corners_in_poly, vg);
      if (d == FanDecision::kWindsMaybe) winding_vg += w;
      if (d != FanDecision::kUndecided) continue;
      Vec3d c;
      double cos_theta;
      if (fan_polygon(poly, corners_in_poly, c, cos_theta) && winds_maybe(vg, c, cos_theta)) winding_vg += w;
      continue;
    }
    Vec3d c;
    double cos_theta;
    if (!fan_polygon(poly, corners_in_poly, c, cos_theta)) {
      exact_fallback = true;
      continue;
    }
    // The polygon lies in the cap {x : x·c >= cos_theta} (convex: cos_theta > 0), so it does not
    // wind around a direction outside the cap; by 1e-9 that is certain despite rounding, and
    // the exact winding would be 0.
    if (r.gauss_vertex != kNoGaussVertex && winds_maybe(vg, c, cos_theta))
      winding_vg += winding_number(poly, corners_in_poly, vg);
    if (test_exact) {
      // A cap narrower than G's vertex clearance holds no Gaussian vertex but the corners of the
      // triangle that holds c: test those (in the hemisphere around c). A vertex the cap search
      // would skip winds 0, so the windings found are the same.
      if (cos_theta > gauss.vertex_clearance_cos()) {
        s.gauss.clear();
        for (std::uint32_t g : gauss.triangle_vertices(gauss.locate(c)))
          if (dot(gauss.vertex(g), c) > kHemisphereMargin) s.gauss.push_back(g);
      } else {
        gauss_vertices_in_cap(gauss, c, cos_theta, s);
      }
      for (std::uint32_t g : s.gauss) {
        const int w = winding_number(poly, corners_in_poly, gauss.vertex(g));
        if (w == 0) continue;
        ++enclosed;
        if (exact_g == kNoGaussVertex || g < exact_g) {
          exact_g = g;
          exact_first = w;
        }
      }
    }
  }
  if (r.gauss_vertex != kNoGaussVertex) {
    r.winding = static_cast<std::int8_t>(std::clamp(winding_vg, -127, 127));
    r.characteristic = winding_vg > 0 ? classify(winding_vg, neighbour_side(vg)) : classify(winding_vg, 0);
  }
  if (test_exact) {
    // A fan whose normals do not fit in an open hemisphere has no exact verdict: it is a
    // sample when the vertex is a candidate (documented fallback).
    r.is_exact_sample = enclosed > 0 || (exact_fallback && is_candidate);
    r.enclosed = static_cast<std::uint8_t>(std::min<std::uint32_t>(enclosed, 255));
    if (exact_g != kNoGaussVertex) {
      r.exact_gauss_vertex = exact_g;
      r.exact_winding = static_cast<std::int8_t>(std::clamp(exact_first, -127, 127));
      r.exact_characteristic =
          exact_first > 0 ? classify(exact_first, neighbour_side(gauss.vertex(exact_g))) : classify(exact_first, 0);
    }
  }
  if (r.is_candidate || r.is_exact_sample) out.push_back(r);
}

// True when oneTBB would run one thread here (an arena of one, or a global limit of one).
bool single_thread() {
  return tbb::this_task_arena::max_concurrency() <= 1 ||
         tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism) <= 1;
}

// Evaluates the vertices get(0) .. get(n - 1) (increasing) and appends their records in that
// order: blocks in parallel, each into its own list, concatenated in block order.
template <typename VertexAt, typename Labels>
void evaluate_many(const VertexInputs& in, const Labels& labels, std::size_t n, const VertexAt& get,
                   std::vector<VertexRecord>& out) {
  const std::uint32_t* offsets = in.adjacency.vertex_offsets.data();
  const std::uint32_t* corners = in.adjacency.vertex_corners.data();
  const std::uint8_t* flags = in.adjacency.slot_flags.data();
  auto evaluate = [&](std::uint32_t v, Scratch& s, std::vector<VertexRecord>& records) {
    const std::uint32_t sb = offsets[v], se = offsets[v + 1];
    if (sb == se) return;
    labels.load(sb, se, s);
    const StarScan scan = scan_star(labels, corners, flags, sb, se, s);
    if (scan.feature_edges >= 3 || (in.run_exact_test && scan.several_labels))
      evaluate_vertex(in, v, sb, se, scan, s, records);
  };
  // One block, or one thread: straight into out (the same records in the same order as the
  // blocks below, without their lists and the copy).
  if (n <= kVertexBlock || single_thread()) {
    Scratch s;
    for (std::size_t k = 0; k < n; ++k) evaluate(get(k), s, out);
    return;
  }
  const std::size_t blocks = (n + kVertexBlock - 1) / kVertexBlock;
  std::vector<std::vector<VertexRecord>> parts(blocks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    Scratch s;
    for (std::size_t b = r.begin(); b < r.end(); ++b) {
      const std::size_t end = std::min(n, (b + 1) * kVertexBlock);
      for (std::size_t k = b * kVertexBlock; k < end; ++k) evaluate(get(k), s, parts[b]);
    }
  });
  std::size_t total = out.size();
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
}

}  // namespace

void evaluate_vertices(format::MeshView mesh, const MeshAdjacency& adjacency, const FaceNormals& normals,
                       const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                       const GaussSphere& gauss, bool run_exact_test, std::uint32_t begin, std::uint32_t end,
                       std::vector<VertexRecord>& out) {
  if (end <= begin) return;
  const VertexInputs in{mesh, adjacency, normals, labels.data(), feature.data(), gauss, run_exact_test};
  evaluate_many(in, MeshLabels{labels.data(), feature.data()}, end - begin,
                [begin](std::size_t k) { return static_cast<std::uint32_t>(begin + k); }, out);
}

void evaluate_vertex_list(format::MeshView mesh, const MeshAdjacency& adjacency, const FaceNormals& normals,
                          const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                          const GaussSphere& gauss, bool run_exact_test, std::span<const std::uint32_t> vertices,
                          std::vector<VertexRecord>& out) {
  if (vertices.empty()) return;
  const VertexInputs in{mesh, adjacency, normals, labels.data(), feature.data(), gauss, run_exact_test};
  const std::uint32_t* list = vertices.data();
  evaluate_many(in, MeshLabels{labels.data(), feature.data()}, vertices.size(), [list](std::size_t k) { return list[k]; },
                out);
}

namespace {

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace

SamplerWorkspace::SamplerWorkspace() = default;
SamplerWorkspace::~SamplerWorkspace() = default;

format::Status sample_mesh(format::MeshView mesh, const GaussSphere& gauss, const SamplerOptions& options,
                           SamplerWorkspace& ws, SamplingResult& result) {
  if (format::Status st = build_mesh_adjacency(mesh, ws.adjacency); !st.is_ok()) return st;
  const MeshAdjacency& adj = ws.adjacency;
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh.positions.size());
  const std::size_t nf = mesh.triangles.size();
  const bool exact = options.sample_test == SampleTest::kExact;

  result.candidates.clear();
  result.samples.clear();
  result.patch_adjacency.clear();
  result.stats = {};
  std::vector<std::uint32_t>& labels = result.face_label;
  std::vector<std::uint8_t>& feature = result.face_feature;
  compute_face_normals(mesh, adj, options.smooth_iterations, ws.normals, ws.area, ws.smoothed);
  const FaceNormals& normals = ws.normals;
  compute_face_labels(normals, gauss, labels);
  compute_feature_edges(adj, labels, feature);
  std::vector<VertexRecord>& records = ws.records;
  records.clear();
  evaluate_vertices(mesh, adj, normals, labels, feature, gauss, exact, 0, nv, records);

  result.stats.degenerate_faces = normals.degenerate_count;
  result.stats.unlabelled_faces = static_cast<std::size_t>(std::count(labels.begin(), labels.end(), kNoLabel));
  result.stats.break_edges = adj.break_edges;
  for (const VertexRecord& r : records) {
    result.stats.candidates_initial += r.is_candidate;
    result.stats.exact_samples += r.is_exact_sample;
  }

  // Untriangulatable patches (Fig. 6 a, b): merge into a neighbour, then re-evaluate the
  // vertices of the merged faces, which may lose feature edges and candidacy (Fig. 6 c, d).
  // The rounds run on the patch graph (PatchMergeGraph, stream/sampling/patch_filters.h), built
  // once from the first find_patches; the faces are relabelled once at the end.
  const double stage_wall = wall_seconds(), stage_cpu = thread_cpu_seconds();
  std::vector<std::uint8_t>& is_candidate = ws.is_candidate;
  is_candidate.assign(nv, 0);
  ws.candidate_vertex.clear();
  ws.candidate_record.clear();
  for (std::size_t k = 0; k < records.size(); ++k) {
    if (!records[k].is_candidate) continue;
    is_candidate[records[k].vertex] = 1;
    ws.candidate_vertex.push_back(records[k].vertex);
    ws.candidate_record.push_back(static_cast<std::uint32_t>(k));
  }
  Patches& patches = ws.patches;
  face_order_keys(mesh, ws.face_key);
  find_patches(adj, labels, feature, patches, ws.stack, ws.face_key);
  const double built_cpu = thread_cpu_seconds();
  ws.patch_seconds.find_patches = built_cpu - stage_cpu;
  build_patch_graph(mesh, adj, patches, feature, ws.candidate_vertex, ws.graph_input, ws.graph_scratch);
  const std::uint32_t* nb = adj.edge_neighbor.data();
  const std::uint32_t* corners = adj.vertex_corners.data();
  const std::uint32_t* face_patch0 = patches.face_patch.data();
  const VertexInputs relabelled{mesh, adj, normals, nullptr, nullptr, gauss, false};
  // Re-evaluates the touched candidates from their stars, with the labels of the patch graph
  // (MergeLabels; every face is relabelled once at the end). Records: a candidate that stays one
  // takes its fresh record with its old exact verdict (exact verdicts do not depend on labels);
  // one that does not is kept as exact-only if it is an exact sample, and is no candidate any
  // more either way.
  auto reevaluate = [&](PatchMergeGraph& graph, std::span<const std::uint32_t> touched,
                        std::vector<std::uint8_t>& still) {
    ws.touched.clear();
    for (std::uint32_t k : touched) ws.touched.push_back(ws.candidate_vertex[k]);
    const MergeLabels merge_labels{graph, face_patch0, corners, nb};
    ws.fresh.clear();
    const std::uint32_t* list = ws.touched.data();
    evaluate_many(relabelled, merge_labels, ws.touched.size(), [list](std::size_t k) { return list[k]; }, ws.fresh);
    std::size_t j = 0;
    for (std::size_t i = 0; i < touched.size(); ++i) {
      const std::uint32_t v = ws.touched[i];
      VertexRecord& old = records[ws.candidate_record[touched[i]]];
      if (j < ws.fresh.size() && ws.fresh[j].vertex == v) {
        VertexRecord r = ws.fresh[j++];
        r.is_exact_sample = old.is_exact_sample;
        r.enclosed = old.enclosed;
        r.exact_gauss_vertex = old.exact_gauss_vertex;
        r.exact_winding = old.exact_winding;
        r.exact_characteristic = old.exact_characteristic;
        old = r;
        still[i] = 1;
      } else {
        is_candidate[v] = 0;
        old.is_candidate = false;
        old.is_tree = false;
        old.gauss_vertex = kNoGaussVertex;
        old.characteristic = Characteristic::kNone;
        still[i] = 0;
      }
    }
  };
  const double rounds_cpu = thread_cpu_seconds();
  ws.patch_seconds.build = rounds_cpu - built_cpu;
  ws.graph.reset_taking_neighbors(ws.graph_input);
  ws.graph.merge(reevaluate);
  const double result_cpu = thread_cpu_seconds();
  ws.patch_seconds.rounds = result_cpu - rounds_cpu;
  PatchMergeResult& merged = ws.merge_result;
  ws.graph.finish(merged);
  result.stats.merged_patches = merged.merged_patches;
  result.stats.merge_rounds = merged.rounds;

  // Faces: merged patch (in place of the first patches), label and feature bits, once
  // (find_patches' numbering: by lowest face).
  if (merged.rounds > 0) {
    const std::uint32_t* patch_of = merged.patch_of.data();
    const std::uint32_t* merged_label = merged.patch_label.data();
    std::uint32_t* face_patch = patches.face_patch.data();
    std::uint32_t* out_label = labels.data();
    for_faces(nf, [&](std::size_t begin, std::size_t end) {
      for (std::size_t f = begin; f < end; ++f) {
        const std::uint32_t p = patch_of[face_patch[f]];
        face_patch[f] = p;
        out_label[f] = merged_label[p];
      }
    });
    compute_feature_edges(adj, labels, feature);
  }
  result.face_patch.swap(patches.face_patch);
  result.patch_label.swap(merged.patch_label);
  result.patch_count = result.patch_label.size();
  result.patch_adjacency.swap(merged.adjacency);
  ws.patch_seconds.result = thread_cpu_seconds() - result_cpu;
  ws.patch_seconds.wall = wall_seconds() - stage_wall;

  for (const VertexRecord& r : records)
    if (r.is_candidate) result.candidates.push_back(r);

  if (exact) {
    for (const VertexRecord& r : records)
      if (r.is_exact_sample) result.samples.push_back({r.vertex, r.exact_gauss_vertex, r.exact_characteristic});
  } else {
    // Non-sample filter, then the noisy-sample filter over the survivors.
    std::vector<NoisyFilterInput> survivors;
    for (const VertexRecord& r : result.candidates) {
      if (r.is_tree) {
        ++result.stats.tree_filtered;
        continue;
      }
      if (options.drop_unwinding_candidates && r.gauss_vertex != kNoGaussVertex &&
          r.characteristic == Characteristic::kNone) {
        ++result.stats.unwinding_filtered;
        continue;
      }
      survivors.push_back({r.vertex, r.gauss_vertex, static_cast<std::uint8_t>(r.characteristic), r.cover_mask});
    }
    const auto candidate_pairs = find_candidate_adjacency(mesh, adj, result.face_feature, is_candidate);
    const std::vector<std::uint8_t> keep = noisy_sample_filter(survivors, candidate_pairs);
    for (std::size_t k = 0; k < survivors.size(); ++k) {
      if (!keep[k]) {
        ++result.stats.noisy_filtered;
        continue;
      }
      result.samples.push_back({survivors[k].vertex, survivors[k].gauss_vertex,
                                static_cast<Characteristic>(survivors[k].characteristic)});
    }
  }
  return format::Status();
}

format::Result<SamplingResult> sample_mesh(format::MeshView mesh, const GaussSphere& gauss,
                                           const SamplerOptions& options) {
  SamplerWorkspace ws;
  SamplingResult result;
  if (format::Status st = sample_mesh(mesh, gauss, options, ws, result); !st.is_ok()) return st;
  return result;
}

format::Result<OrientedSampling> sample_mesh_best_orientation(format::MeshView mesh,
                                                              const std::vector<GaussSphereOptions>& spheres,
                                                              const SamplerOptions& options) {
  assert(!spheres.empty());
  OrientedSampling best;
  SamplerWorkspace ws;  // shared by the orientations: only the first pays for fresh memory
  SamplingResult result;
  for (std::size_t k = 0; k < spheres.size(); ++k) {
    auto gauss = GaussSphere::create(spheres[k]);
    if (!gauss) return gauss.status();
    if (format::Status st = sample_mesh(mesh, *gauss, options, ws, result); !st.is_ok()) return st;
    const std::size_t n = result.samples.size();
    best.samples_per_orientation.push_back(n);
    if (k == 0 || n < best.result.samples.size()) {
      best.gauss.emplace(std::move(gauss).value());
      std::swap(best.result, result);
      best.chosen = k;
    }
  }
  return best;
}

}  // namespace gaussmesh::stream
