// Mesh-to-mesh distance (`gaussmesh compare`): seeded area-weighted surface samples, plus every
// vertex and edge midpoint, each measured exactly against an AABB tree of the other mesh's
// triangles, in parallel with a deterministic reduction (docs/compare.md).
#include "stream/analysis/mesh_distance.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::MeshView;
using format::Status;
using format::Triangle;
using format::Vec3f;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr std::size_t kLeafSize = 4;
// The most area samples one mesh may get (a limit on time, not memory: samples are not kept).
constexpr std::size_t kMaxSamples = std::size_t{1} << 32;

double length_squared(const Vec3d& v) { return dot(v, v); }

// Squared distance from p to segment [a, b], and the nearest point.
double point_segment_distance_squared(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                      Vec3d* closest) {
  const Vec3d ab = b - a;
  const double len2 = length_squared(ab);
  double t = len2 > 0 ? dot(p - a, ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  const Vec3d q = a + t * ab;
  if (closest) *closest = q;
  return length_squared(p - q);
}

}  // namespace

double point_triangle_distance_squared(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                       const Vec3d& c, Vec3d* closest) {
  // If the projection of p onto the triangle's plane falls inside the triangle, the plane
  // distance is the answer; otherwise the nearest point lies on one of the three sides.
  const Vec3d ab = b - a, ac = c - a;
  const Vec3d n = cross(ab, ac);
  const double n2 = length_squared(n);
  // Below this the normal's direction is rounding noise: treat as degenerate (sides only).
  const double degenerate = 1e-24 * length_squared(ab) * length_squared(ac);
  if (n2 > degenerate && n2 > 0) {
    const double height = dot(p - a, n);
    const Vec3d q = p - (height / n2) * n;
    const bool inside = dot(cross(b - q, c - q), n) >= 0 && dot(cross(c - q, a - q), n) >= 0 &&
                        dot(cross(a - q, b - q), n) >= 0;
    if (inside) {
      if (closest) *closest = q;
      return height * height / n2;
    }
  }
  Vec3d best_point, candidate;
  double best = point_segment_distance_squared(p, a, b, &best_point);
  const std::pair<const Vec3d*, const Vec3d*> sides[2] = {{&b, &c}, {&c, &a}};
  for (const auto& [from, to] : sides) {
    const double d = point_segment_distance_squared(p, *from, *to, &candidate);
    if (d < best) {
      best = d;
      best_point = candidate;
    }
  }
  if (closest) *closest = best_point;
  return best;
}

// --- TriangleTree ----------------------------------------------------------------------------

struct TriangleTree::Impl {
  struct Node {
    float lo[3], hi[3];
    std::uint32_t first;  // leaf: first triangle (leaf order); inner: index of the right child
    std::uint32_t count;  // leaf: triangle count; inner: 0 (the left child is the next node)
  };
  std::vector<Node> nodes;
  std::vector<std::array<float, 9>> corners;  // triangles in leaf order
  std::vector<std::uint32_t> triangles;       // the mesh's index of each, in leaf order

  struct Item {
    float lo[3], hi[3], centre[3];
    std::uint32_t triangle;
  };

  std::uint32_t build(std::vector<Item>& items, std::size_t begin, std::size_t end,
                      const std::vector<std::array<float, 9>>& input) {
    const auto index = static_cast<std::uint32_t>(nodes.size());
    nodes.push_back({});
    Node node;
    float centre_lo[3], centre_hi[3];
    for (int k = 0; k < 3; ++k) {
      node.lo[k] = centre_lo[k] = std::numeric_limits<float>::infinity();
      node.hi[k] = centre_hi[k] = -std::numeric_limits<float>::infinity();
    }
    for (std::size_t i = begin; i < end; ++i) {
      for (int k = 0; k < 3; ++k) {
        node.lo[k] = std::min(node.lo[k], items[i].lo[k]);
        node.hi[k] = std::max(node.hi[k], items[i].hi[k]);
        centre_lo[k] = std::min(centre_lo[k], items[i].centre[k]);
        centre_hi[k] = std::max(centre_hi[k], items[i].centre[k]);
      }
    }
    if (end - begin <= kLeafSize) {
      node.first = static_cast<std::uint32_t>(corners.size());
      node.count = static_cast<std::uint32_t>(end - begin);
      for (std::size_t i = begin; i < end; ++i) {
        corners.push_back(input[items[i].triangle]);
        triangles.push_back(items[i].triangle);
      }
      nodes[index] = node;
      return index;
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (centre_hi[k] - centre_lo[k] > centre_hi[axis] - centre_lo[axis]) axis = k;
    }
    const std::size_t middle = begin + (end - begin) / 2;
    std::nth_element(items.begin() + static_cast<std::ptrdiff_t>(begin),
                     items.begin() + static_cast<std::ptrdiff_t>(middle),
                     items.begin() + static_cast<std::ptrdiff_t>(end),
                     [axis](const Item& x, const Item& y) { return x.centre[axis] < y.centre[axis]; });
    build(items, begin, middle, input);
    node.first = build(items, middle, end, input);
    node.count = 0;
    nodes[index] = node;
    return index;
  }

  static double box_distance_squared(const Node& node, const Vec3d& p) {
    const double q[3] = {p.x, p.y, p.z};
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double below = double(node.lo[k]) - q[k], above = q[k] - double(node.hi[k]);
      const double d = std::max({below, above, 0.0});
      d2 += d * d;
    }
    return d2;
  }

  double triangle_distance_squared(std::uint32_t t, const Vec3d& p) const {
    const auto& c = corners[t];
    return point_triangle_distance_squared(p, {c[0], c[1], c[2]}, {c[3], c[4], c[5]},
                                           {c[6], c[7], c[8]});
  }
};

TriangleTree::TriangleTree(MeshView mesh) : impl_(std::make_unique<Impl>()) {
  const std::size_t n = mesh.triangles.size();
  std::vector<std::array<float, 9>> input(n);
  std::vector<Impl::Item> items(n);
  for (std::size_t t = 0; t < n; ++t) {
    const Triangle& tri = mesh.triangles[t];
    Impl::Item& item = items[t];
    item.triangle = static_cast<std::uint32_t>(t);
    for (int k = 0; k < 3; ++k) {
      item.lo[k] = std::numeric_limits<float>::infinity();
      item.hi[k] = -std::numeric_limits<float>::infinity();
      item.centre[k] = 0;
    }
    for (int corner = 0; corner < 3; ++corner) {
      const Vec3f& p = mesh.positions[tri.v[corner]];
      const float xyz[3] = {p.x, p.y, p.z};
      for (int k = 0; k < 3; ++k) {
        input[t][3 * corner + k] = xyz[k];
        item.lo[k] = std::min(item.lo[k], xyz[k]);
        item.hi[k] = std::max(item.hi[k], xyz[k]);
        item.centre[k] += xyz[k] / 3;
      }
    }
  }
  if (n == 0) return;
  impl_->nodes.reserve(2 * (n / kLeafSize + 1));
  impl_->corners.reserve(n);
  impl_->triangles.reserve(n);
  impl_->build(items, 0, n, input);
}

TriangleTree::~TriangleTree() = default;

std::size_t TriangleTree::triangle_count() const { return impl_->corners.size(); }

std::uint32_t TriangleTree::leaf_triangle(std::uint32_t leaf) const { return impl_->triangles.at(leaf); }

Vec3d TriangleTree::leaf_normal(std::uint32_t leaf) const {
  const auto& c = impl_->corners.at(leaf);
  const Vec3d a{c[0], c[1], c[2]}, b{c[3], c[4], c[5]}, d{c[6], c[7], c[8]};
  return cross(b - a, d - a);
}

double TriangleTree::nearest_distance_squared(const Vec3d& p, std::uint32_t* hint) const {
  const Impl& tree = *impl_;
  if (tree.corners.empty()) return kInfinity;
  std::uint32_t best_triangle = hint && *hint < tree.corners.size() ? *hint : 0;
  double best = tree.triangle_distance_squared(best_triangle, p);
  // Depth-first, nearer child first, pruning boxes no nearer than the best so far.
  std::uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Impl::Node& node = tree.nodes[stack[--top]];
    if (Impl::box_distance_squared(node, p) >= best) continue;
    if (node.count > 0) {
      for (std::uint32_t t = node.first; t < node.first + node.count; ++t) {
        const double d = tree.triangle_distance_squared(t, p);
        if (d < best) {
          best = d;
          best_triangle = t;
        }
      }
      continue;
    }
    const std::uint32_t left = static_cast<std::uint32_t>(&node - tree.nodes.data()) + 1;
    const std::uint32_t right = node.first;
    const double dl = Impl::box_distance_squared(tree.nodes[left], p);
    const double dr = Impl::box_distance_squared(tree.nodes[right], p);
    // Median splits keep the depth near log2(n / 4) < 64.
    if (dl <= dr) {
      if (dr < best) stack[top++] = right;
      if (dl < best) stack[top++] = left;
    } else {
      if (dl < best) stack[top++] = left;
      if (dr < best) stack[top++] = right;
    }
  }
  if (hint) *hint = best_triangle;
  return best;
}

// --- the measure ---------------------------------------------------------------------------------

namespace {

// SplitMix64 (Steele, Lea & Flood 2014): a counter-based stream per triangle, so the samples of
// a triangle do not depend on how the work is split between threads.
class TriangleRandom {
 public:
  TriangleRandom(std::uint64_t seed, std::uint64_t side, std::uint64_t triangle)
      : state_(seed * 0x9E3779B97F4A7C15ull ^ (side << 62) ^ (triangle * 0xD1B54A32D192ED03ull)) {
    next();
  }
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

Status validate(MeshView mesh, const char* name) {
  if (mesh.triangles.empty()) {
    return Status::error(Code::kBadInput, name, "the mesh has no triangles to measure");
  }
  const std::size_t n = mesh.positions.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (format::VertexIndex v : mesh.triangles[t].v) {
      if (v >= n) {
        return Status::error(Code::kBadInput, name,
                             "triangle " + std::to_string(t) + " uses vertex " +
                                 std::to_string(v) + " of " + std::to_string(n));
      }
      const Vec3f& p = mesh.positions[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        return Status::error(Code::kBadInput, name,
                             "vertex " + std::to_string(v) + " has a non-finite coordinate");
      }
    }
  }
  return {};
}

double triangle_area(MeshView mesh, const Triangle& t) {
  const Vec3d a = to_d(mesh.positions[t.v[0]]);
  const Vec3d n = cross(to_d(mesh.positions[t.v[1]]) - a, to_d(mesh.positions[t.v[2]]) - a);
  return 0.5 * std::sqrt(length_squared(n));
}

struct Accumulator {
  double max_squared = 0;
  Vec3d max_at{};          // where max_squared was sampled: the first such sample in triangle order
  double sum_squared = 0;  // area samples only
  double sum = 0;          // area samples only
  std::size_t area_samples = 0, feature_samples = 0;
  std::size_t facing_away = 0;
  double facing_away_area = 0;

  void add_max(double d2, const Vec3d& p) {
    if (d2 > max_squared) max_squared = d2, max_at = p;
  }
  void add_area(double d2, const Vec3d& p) {
    add_max(d2, p);
    sum_squared += d2;
    sum += std::sqrt(d2);
    ++area_samples;
  }
  void add_feature(double d2, const Vec3d& p) {
    add_max(d2, p);
    ++feature_samples;
  }
  // `other` covers the triangles after this one's (a deterministic reduction keeps that order).
  void join(const Accumulator& other) {
    add_max(other.max_squared, other.max_at);
    sum_squared += other.sum_squared;
    sum += other.sum;
    area_samples += other.area_samples;
    feature_samples += other.feature_samples;
    facing_away += other.facing_away;
    facing_away_area += other.facing_away_area;
  }
};

// Samples `from` (area samples at `density` per unit area, every referenced vertex, every
// triangle's edge midpoints) and measures each against `tree`; `area` is the sum of `areas`.
OneSidedDistance one_sided(MeshView from, const std::vector<double>& areas, double area, double density,
                           const TriangleTree& tree, std::uint64_t seed, std::uint64_t side) {
  // Each vertex is measured by the first triangle that uses it.
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> first_face(from.positions.size(), kUnused);
  for (std::size_t t = from.triangles.size(); t-- > 0;) {
    for (format::VertexIndex v : from.triangles[t].v) first_face[v] = static_cast<std::uint32_t>(t);
  }
  const std::size_t grain = 512;
  const Accumulator total = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, from.triangles.size(), grain), Accumulator{},
      [&](const tbb::blocked_range<std::size_t>& range, Accumulator acc) {
        std::uint32_t hint = 0;
        for (std::size_t t = range.begin(); t != range.end(); ++t) {
          const Triangle& tri = from.triangles[t];
          const Vec3d a = to_d(from.positions[tri.v[0]]);
          const Vec3d b = to_d(from.positions[tri.v[1]]);
          const Vec3d c = to_d(from.positions[tri.v[2]]);
          for (int k = 0; k < 3; ++k) {
            const format::VertexIndex v = tri.v[k];
            if (first_face[v] == t && (k == 0 || v != tri.v[0]) && (k < 2 || v != tri.v[1])) {
              const Vec3d p = to_d(from.positions[v]);
              acc.add_feature(tree.nearest_distance_squared(p, &hint), p);
            }
          }
          for (const Vec3d& p : {0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)})
            acc.add_feature(tree.nearest_distance_squared(p, &hint), p);
          // Facing away: against the normal of the other surface's triangle nearest the centroid.
          const Vec3d normal = cross(b - a, c - a);
          if (length_squared(normal) > 0) {
            tree.nearest_distance_squared((1.0 / 3) * (a + b + c), &hint);
            if (dot(normal, tree.leaf_normal(hint)) < 0) ++acc.facing_away, acc.facing_away_area += areas[t];
          }
          // floor(expected) samples, plus one with the fractional part's probability.
          TriangleRandom random(seed, side, t);
          const double expected = areas[t] * density;
          auto count = static_cast<std::size_t>(expected);
          if (random.uniform() < expected - static_cast<double>(count)) ++count;
          for (std::size_t i = 0; i < count; ++i) {
            // Uniform in the triangle: sqrt warps the first coordinate (Turk 1990).
            const double s = std::sqrt(random.uniform()), r = random.uniform();
            const Vec3d p = (1 - s) * a + (s * (1 - r)) * b + (s * r) * c;
            acc.add_area(tree.nearest_distance_squared(p, &hint), p);
          }
        }
        return acc;
      },
      [](Accumulator x, const Accumulator& y) {
        x.join(y);
        return x;
      });
  OneSidedDistance out;
  out.max = std::sqrt(total.max_squared);
  out.max_at = total.max_at;
  out.area_samples = total.area_samples;
  out.feature_samples = total.feature_samples;
  out.facing_away = total.facing_away;
  out.facing_away_area = total.facing_away_area;
  out.area = area;
  if (total.area_samples > 0) {
    out.rms = std::sqrt(total.sum_squared / static_cast<double>(total.area_samples));
    out.mean = total.sum / static_cast<double>(total.area_samples);
  }
  return out;
}

double referenced_diagonal(MeshView mesh) {
  Vec3d lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  for (const Triangle& t : mesh.triangles) {
    for (format::VertexIndex v : t.v) {
      const Vec3d p = to_d(mesh.positions[v]);
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
  }
  return std::sqrt(length_squared(hi - lo));
}

}  // namespace

format::Result<MeshDistance> mesh_distance(MeshView a, MeshView b, const DistanceOptions& options) {
  if (options.samples == 0 || options.samples > kMaxSamples) {
    return Status::error(Code::kUsage, "--samples",
                         "expected 1 to " + std::to_string(kMaxSamples) + " samples, got " +
                             std::to_string(options.samples));
  }
  GM_RETURN_IF_ERROR(validate(a, "A"));
  GM_RETURN_IF_ERROR(validate(b, "B"));
  MeshDistance result;
  result.diagonal = referenced_diagonal(a);
  if (!(result.diagonal > 0)) {
    return Status::error(Code::kBadInput, "A",
                         "all vertices coincide: the bounding-box diagonal is zero");
  }
  std::vector<double> areas_a(a.triangles.size()), areas_b(b.triangles.size());
  double area_a = 0, area_b = 0;
  for (std::size_t t = 0; t < a.triangles.size(); ++t) area_a += areas_a[t] = triangle_area(a, a.triangles[t]);
  for (std::size_t t = 0; t < b.triangles.size(); ++t) area_b += areas_b[t] = triangle_area(b, b.triangles[t]);
  const double samples = static_cast<double>(options.samples);
  // Same density on both; a B far larger than A is capped at 4x A's sample count.
  const double density_a = area_a > 0 ? samples / area_a : 0.0;
  const double density_b = area_b > 0 ? std::min(density_a, 4 * samples / area_b) : 0.0;
  const TriangleTree tree_a(a), tree_b(b);
  result.a_to_b = one_sided(a, areas_a, area_a, density_a, tree_b, options.seed, 0);
  result.b_to_a = one_sided(b, areas_b, area_b, density_b, tree_a, options.seed, 1);
  result.hausdorff = std::max(result.a_to_b.max, result.b_to_a.max);
  result.rms = std::sqrt((result.a_to_b.rms * result.a_to_b.rms +
                          result.b_to_a.rms * result.b_to_a.rms) / 2);
  return result;
}

}  // namespace gaussmesh::stream
