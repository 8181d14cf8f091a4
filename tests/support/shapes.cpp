// Analytic test shapes (paper Figs. 2-4, genus 2): convex ones as exact convex hulls of
// well-spread surface points, the others as structured meshes whose edges follow the sign of
// the surface's curvature (convex where it is convex, concave where it is concave).
//
// Convex hull: randomized incremental construction with a bipartite conflict graph (Clarkson &
// Shor; de Berg et al., "Computational Geometry", ch. 11), expected O(n log n). Every geometric
// decision is CGAL::orientation on the input floats (exact, from the LGPL kernel), so the hull
// is a closed, manifold, outward-oriented convex polyhedron whatever the input's coplanarities.
//
// Why edge convexity matters: for a quadratic surface patch z = -(k1 x^2 + k2 y^2)/2, the
// convex triangulation of points on it is the Delaunay triangulation in the metric of the
// second fundamental form diag(k1, k2). A mesh that is not that triangulation has reflex edges
// on a convex surface, and each adds a saddle to the Gauss map (spurious samples).
#include "tests/support/shapes.h"

#include "stream/core/exact_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <unordered_map>
#include <vector>

namespace gaussmesh::testing {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using format::Triangle;
using format::VertexIndex;

constexpr double kPi = std::numbers::pi;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// ---------------------------------------------------------------------------------------------
// Small double-precision vector algebra for the generators.

// stream::Vec3d and its operators, dot and cross (stream/core/exact_predicates.h).
using stream::Vec3d;
double norm(Vec3d a) { return std::sqrt(dot(a, a)); }
Vec3f to_float(Vec3d p) {
  return {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
}
Point to_point(const Vec3f& p) { return Point(p.x, p.y, p.z); }

// Rotates v by the unit quaternion q = (w, x, y, z): v + 2w (u x v) + 2 u x (u x v).
Vec3d rotate(const std::array<double, 4>& q, Vec3d v) {
  const Vec3d u{q[1], q[2], q[3]};
  const Vec3d t = 2.0 * cross(u, v);
  return v + q[0] * t + cross(u, t);
}

std::array<double, 4> normalized(const std::array<double, 4>& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  assert(n > 0 && "rotation quaternion must be non-zero");
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

// Deterministic random numbers: mt19937_64's sequence is fixed by the standard, and the
// conversions below are ours (std:: distributions differ between library implementations).
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double normal() {  // Box-Muller
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * kPi * u2);
  }
  std::uint64_t bits() { return engine_(); }

 private:
  std::mt19937_64 engine_;
};

// n points of the spherical Fibonacci lattice: near-uniform, and (unlike latitude rings)
// without systematic coplanar quadruples.
std::vector<Vec3d> fibonacci_sphere(std::size_t n) {
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Vec3d> points(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * static_cast<double>(i) + 1.0) / static_cast<double>(n);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * static_cast<double>(i);
    points[i] = {r * std::cos(phi), r * std::sin(phi), z};
  }
  return points;
}

// ---------------------------------------------------------------------------------------------
// Convex hull.

class ConvexHullBuilder {
 public:
  explicit ConvexHullBuilder(std::span<const Vec3f> input) : input_(input) {
    points_.reserve(input.size());
    for (const Vec3f& p : input) points_.push_back(to_point(p));
  }

  Mesh build() {
    std::array<std::uint32_t, 4> simplex;
    if (!find_simplex(simplex)) return {};
    make_simplex(simplex);
    processed_.assign(points_.size(), false);
    for (std::uint32_t s : simplex) processed_[s] = true;
    std::vector<std::uint32_t> order;
    order.reserve(points_.size());
    for (std::uint32_t i = 0; i < points_.size(); ++i) {
      if (!processed_[i]) order.push_back(i);
    }
    // Biased randomized insertion order (Amenta, Choi & Rote 2003): rounds of doubling size,
    // a point joining round k with probability 2^-(k+1), input order within a round. Keeps the
    // expected O(n log n) of a random order, and the cache locality of spatially sorted input
    // (a Fibonacci lattice is a spiral). A fixed seed makes the hull reproducible.
    Random random(0x5eed);
    std::vector<std::pair<int, std::uint32_t>> keyed;
    keyed.reserve(order.size());
    for (std::uint32_t p : order) {
      const int round = std::countr_zero(random.bits() | (std::uint64_t(1) << 40));
      keyed.push_back({-round, p});
    }
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = keyed[i].second;
    faces_.reserve(2 * points_.size() + 64);
    face_visit_.reserve(2 * points_.size() + 64);
    point_faces_.assign(points_.size(), {});
    point_stamp_.assign(points_.size(), 0);
    vertex_new_face_.assign(points_.size(), kNone);
    for (std::uint32_t p : order) {
      for (std::uint32_t f = 0; f < 4; ++f) add_conflict_if_visible(f, p);
    }
    for (std::uint32_t p : order) insert(p);
    return extract();
  }

 private:
  struct Face {
    std::uint32_t v[3];
    std::uint32_t adjacent[3];  // adjacent[k] shares edge (v[k], v[k+1])
    bool alive = true;
    std::vector<std::uint32_t> conflicts;  // unprocessed points strictly outside this face
  };

  bool is_visible(std::uint32_t f, std::uint32_t p) const {
    const Face& face = faces_[f];
    return CGAL::orientation(points_[face.v[0]], points_[face.v[1]], points_[face.v[2]],
                             points_[p]) == CGAL::POSITIVE;
  }

  void add_conflict_if_visible(std::uint32_t f, std::uint32_t p) {
    if (is_visible(f, p)) {
      faces_[f].conflicts.push_back(p);
      point_faces_[p].push_back(f);
    }
  }

  bool find_simplex(std::array<std::uint32_t, 4>& simplex) const {
    const std::size_t n = points_.size();
    std::size_t i1 = 1;
    while (i1 < n && points_[i1] == points_[0]) ++i1;
    if (i1 >= n) return false;
    std::size_t i2 = i1 + 1;
    while (i2 < n && CGAL::collinear(points_[0], points_[i1], points_[i2])) ++i2;
    if (i2 >= n) return false;
    std::size_t i3 = i2 + 1;
    while (i3 < n &&
           CGAL::orientation(points_[0], points_[i1], points_[i2], points_[i3]) == CGAL::COPLANAR) {
      ++i3;
    }
    if (i3 >= n) return false;
    simplex = {0, static_cast<std::uint32_t>(i1), static_cast<std::uint32_t>(i2),
               static_cast<std::uint32_t>(i3)};
    return true;
  }

  void make_simplex(const std::array<std::uint32_t, 4>& s) {
    // Face k omits s[k]; orient it so that s[k] lies on its negative (inner) side.
    for (int k = 0; k < 4; ++k) {
      std::uint32_t v[3];
      int m = 0;
      for (int j = 0; j < 4; ++j) {
        if (j != k) v[m++] = s[j];
      }
      if (CGAL::orientation(points_[v[0]], points_[v[1]], points_[v[2]], points_[s[k]]) ==
          CGAL::POSITIVE) {
        std::swap(v[1], v[2]);
      }
      Face face;
      std::copy(v, v + 3, face.v);
      std::fill(face.adjacent, face.adjacent + 3, kNone);
      faces_.push_back(std::move(face));
    }
    // Adjacency by brute force over the four faces.
    for (std::uint32_t f = 0; f < 4; ++f) {
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = faces_[f].v[k], b = faces_[f].v[(k + 1) % 3];
        for (std::uint32_t g = 0; g < 4; ++g) {
          for (int j = 0; j < 3; ++j) {
            if (faces_[g].v[j] == b && faces_[g].v[(j + 1) % 3] == a) faces_[f].adjacent[k] = g;
          }
        }
      }
    }
  }

  void insert(std::uint32_t p) {
    processed_[p] = true;
    ++visit_;
    visible_.clear();
    for (std::uint32_t f : point_faces_[p]) {
      if (faces_[f].alive) {
        visible_.push_back(f);
        face_visit_[f] = visit_;
      }
    }
    std::vector<std::uint32_t>().swap(point_faces_[p]);
    if (visible_.empty()) return;  // inside or on the current hull

    // Horizon: edges of visible faces whose other face is not visible. The visible region
    // is a topological disk (exact predicates), so each horizon vertex starts one edge.
    horizon_.clear();
    for (std::uint32_t f : visible_) {
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t g = faces_[f].adjacent[k];
        if (face_visit_[g] != visit_) {
          horizon_.push_back({faces_[f].v[k], faces_[f].v[(k + 1) % 3], f, g});
        }
      }
    }
    // New faces reuse the slots of faces deleted by earlier insertions: the working set stays
    // near the hull's size (2n faces) instead of every face ever made (~6n), which matters
    // where first-touching memory is slow.
    new_faces_.clear();
    for (const auto& [a, b, visible, hidden] : horizon_) {
      std::uint32_t nf;
      if (free_faces_.empty()) {
        nf = static_cast<std::uint32_t>(faces_.size());
        faces_.emplace_back();
        face_visit_.push_back(0);
      } else {
        nf = free_faces_.back();
        free_faces_.pop_back();
      }
      Face& face = faces_[nf];
      face.v[0] = a;
      face.v[1] = b;
      face.v[2] = p;
      face.adjacent[0] = hidden;
      face.adjacent[1] = face.adjacent[2] = kNone;
      face.alive = true;
      for (std::uint32_t& adjacent : faces_[hidden].adjacent) {
        if (adjacent == visible) adjacent = nf;
      }
      vertex_new_face_[a] = nf;
      new_faces_.push_back(nf);
    }
    for (std::uint32_t nf : new_faces_) {
      const std::uint32_t next = vertex_new_face_[faces_[nf].v[1]];
      faces_[nf].adjacent[1] = next;
      faces_[next].adjacent[2] = nf;
    }
    // Conflicts of a new face come from the two old faces of its horizon edge.
    for (std::size_t i = 0; i < horizon_.size(); ++i) {
      const std::uint32_t nf = new_faces_[i];
      ++point_visit_;
      for (std::uint32_t old : {horizon_[i].visible, horizon_[i].hidden}) {
        for (std::uint32_t q : faces_[old].conflicts) {
          if (processed_[q] || point_stamp_[q] == point_visit_) continue;
          point_stamp_[q] = point_visit_;
          add_conflict_if_visible(nf, q);
        }
      }
    }
    // Delete the visible faces, and their entries in their points' lists, so that a reused
    // slot is never mistaken for the face a point once saw.
    for (std::uint32_t f : visible_) {
      Face& face = faces_[f];
      for (std::uint32_t q : face.conflicts) {
        if (processed_[q]) continue;
        auto& list = point_faces_[q];
        const auto it = std::find(list.begin(), list.end(), f);
        assert(it != list.end());
        *it = list.back();
        list.pop_back();
      }
      face.alive = false;
      face.conflicts.clear();  // keeps its capacity for the slot's next face
      free_faces_.push_back(f);
    }
  }

  Mesh extract() const {
    Mesh mesh;
    std::vector<std::uint32_t> remap(points_.size(), kNone);
    for (const Face& face : faces_) {
      if (!face.alive) continue;
      for (std::uint32_t v : face.v) remap[v] = 0;
    }
    for (std::uint32_t i = 0; i < points_.size(); ++i) {
      if (remap[i] == kNone) continue;
      remap[i] = static_cast<std::uint32_t>(mesh.positions.size());
      mesh.positions.push_back(input_[i]);
    }
    for (const Face& face : faces_) {
      if (!face.alive) continue;
      mesh.triangles.push_back({{remap[face.v[0]], remap[face.v[1]], remap[face.v[2]]}});
    }
    return mesh;
  }

  std::span<const Vec3f> input_;
  std::vector<Point> points_;
  std::vector<Face> faces_;
  std::vector<std::uint64_t> face_visit_ = std::vector<std::uint64_t>(4, 0);
  std::vector<std::vector<std::uint32_t>> point_faces_;
  std::vector<std::uint64_t> point_stamp_;
  std::vector<bool> processed_;
  std::vector<std::uint32_t> vertex_new_face_;
  std::vector<std::uint32_t> visible_, new_faces_, free_faces_;
  struct HorizonRecord {
    std::uint32_t a, b, visible, hidden;
  };
  std::vector<HorizonRecord> horizon_;
  std::uint64_t visit_ = 0, point_visit_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Shared finishing steps.

std::vector<Vec3f> rotated_floats(const std::vector<Vec3d>& points, const std::array<double, 4>& q) {
  const auto unit = normalized(q);
  std::vector<Vec3f> out;
  out.reserve(points.size());
  for (const Vec3d& p : points) out.push_back(to_float(rotate(unit, p)));
  return out;
}

void add_noise(Mesh& mesh, const ShapeOptions& options) {
  if (options.noise <= 0 || mesh.positions.empty()) return;
  Vec3d lo = stream::to_d(mesh.positions[0]), hi = lo;
  for (const Vec3f& p : mesh.positions) {
    lo = {std::min(lo.x, double(p.x)), std::min(lo.y, double(p.y)), std::min(lo.z, double(p.z))};
    hi = {std::max(hi.x, double(p.x)), std::max(hi.y, double(p.y)), std::max(hi.z, double(p.z))};
  }
  const double sigma = options.noise * norm(hi - lo);
  Random random(options.seed ^ 0x9e3779b97f4a7c15ull);
  for (Vec3f& p : mesh.positions) {
    const double dx = random.normal(), dy = random.normal(), dz = random.normal();
    p = to_float(stream::to_d(p) + sigma * Vec3d{dx, dy, dz});
  }
}

// Convex shape from surface points given in the unrotated frame: rotate first, then take the
// hull of the float positions, so the hull is exactly convex in the coordinates delivered.
Mesh convex_shape(const std::vector<Vec3d>& points, const ShapeOptions& options) {
  const std::vector<Vec3f> rotated = rotated_floats(points, options.rotation);
  Mesh mesh = convex_hull(rotated);
  add_noise(mesh, options);
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// Curvature-driven edge flips for the non-convex shapes.

// The sign structure of the second fundamental form of f = 0 at p, f < 0 inside, from central
// differences of f. "Flat" means too close to parabolic to decide.
LocalShape classify_implicit(const std::function<double(Vec3d)>& f, Vec3d p) {
  constexpr double h = 1e-4;
  const double f0 = f(p);
  const Vec3d ex{h, 0, 0}, ey{0, h, 0}, ez{0, 0, h};
  const Vec3d e[3] = {ex, ey, ez};
  double grad[3], hess[3][3];
  for (int i = 0; i < 3; ++i) {
    const double fp = f(p + e[i]), fm = f(p - e[i]);
    grad[i] = (fp - fm) / (2 * h);
    hess[i][i] = (fp - 2 * f0 + fm) / (h * h);
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      const double v = (f(p + e[i] + e[j]) - f(p + e[i] - e[j]) - f(p - e[i] + e[j]) +
                        f(p - e[i] - e[j])) / (4 * h * h);
      hess[i][j] = hess[j][i] = v;
    }
  }
  const Vec3d g{grad[0], grad[1], grad[2]};
  const double g_norm = norm(g);
  if (g_norm == 0) return LocalShape::kFlat;
  const Vec3d n = (1 / g_norm) * g;
  const Vec3d helper = std::abs(n.x) < 0.6 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  Vec3d t1 = cross(n, helper);
  t1 = (1 / norm(t1)) * t1;
  const Vec3d t2 = cross(n, t1);
  auto form = [&](Vec3d a, Vec3d b) {
    const double av[3] = {a.x, a.y, a.z}, bv[3] = {b.x, b.y, b.z};
    double s = 0;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) s += av[i] * hess[i][j] * bv[j];
    }
    return s / g_norm;
  };
  // Shape operator in the tangent basis; positive definite where the surface is convex.
  const double a = form(t1, t1), b = form(t1, t2), c = form(t2, t2);
  const double mean = (a + c) / 2, gap = std::sqrt((a - c) * (a - c) / 4 + b * b);
  const double k1 = mean + gap, k2 = mean - gap;
  constexpr double kMinCurvature = 0.05;  // shapes are of unit size
  if (k2 > kMinCurvature) return LocalShape::kConvex;
  if (k1 < -kMinCurvature) return LocalShape::kConcave;
  if (k1 > kMinCurvature && k2 < -kMinCurvature) return LocalShape::kSaddle;
  return LocalShape::kFlat;
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }

// Flips edges that bend against the surface: reflex edges where the surface is convex, convex
// ones where it is concave (saddle and near-parabolic regions are left alone). `shape_at` is
// evaluated in the unrotated frame at the midpoint of the unrotated edge. Convexity is decided
// exactly on the delivered float positions. Each flip makes the local surface closer to the
// convex (resp. concave) hull of its points, as Lawson flips lower the lifted Delaunay surface.
void align_edges_with_curvature(Mesh& mesh, const std::vector<Vec3d>& unrotated,
                                const std::function<LocalShape(Vec3d)>& shape_at) {
  std::unordered_map<std::uint64_t, std::uint32_t> face_of;  // directed edge -> face
  face_of.reserve(mesh.triangles.size() * 3);
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f].v;
    for (int k = 0; k < 3; ++k) face_of[edge_key(t[k], t[(k + 1) % 3])] = f;
  }
  auto point = [&](std::uint32_t v) { return to_point(mesh.positions[v]); };
  auto third = [&](std::uint32_t f, std::uint32_t a, std::uint32_t b) {
    for (std::uint32_t v : mesh.triangles[f].v) {
      if (v != a && v != b) return v;
    }
    return kNone;
  };
  auto normal = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const Vec3d pa = stream::to_d(mesh.positions[a]);
    return cross(stream::to_d(mesh.positions[b]) - pa, stream::to_d(mesh.positions[c]) - pa);
  };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> queue;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      if (t.v[k] < t.v[(k + 1) % 3]) queue.push_back({t.v[k], t.v[(k + 1) % 3]});
    }
  }
  const std::size_t max_steps = 20 * queue.size();
  for (std::size_t step = 0; step < queue.size() && step < max_steps; ++step) {
    const auto [a, b] = queue[step];
    const auto f1_it = face_of.find(edge_key(a, b)), f2_it = face_of.find(edge_key(b, a));
    if (f1_it == face_of.end() || f2_it == face_of.end()) continue;  // flipped away
    const std::uint32_t f1 = f1_it->second, f2 = f2_it->second;
    const std::uint32_t c = third(f1, a, b), d = third(f2, a, b);  // f1 = (a,b,c), f2 = (b,a,d)
    const LocalShape want = shape_at(0.5 * (unrotated[a] + unrotated[b]));
    if (want != LocalShape::kConvex && want != LocalShape::kConcave) continue;
    const CGAL::Orientation bend = CGAL::orientation(point(a), point(b), point(c), point(d));
    const CGAL::Orientation good = want == LocalShape::kConvex ? CGAL::NEGATIVE : CGAL::POSITIVE;
    if (bend == good || bend == CGAL::COPLANAR) continue;
    if (face_of.count(edge_key(c, d)) || face_of.count(edge_key(d, c))) continue;
    // New faces (a,d,c) and (d,b,c); refuse flips that would fold the surface over.
    const Vec3d old_normal = normal(a, b, c) + normal(b, a, d);
    if (dot(normal(a, d, c), old_normal) <= 0 || dot(normal(d, b, c), old_normal) <= 0) continue;
    face_of.erase(edge_key(a, b));
    face_of.erase(edge_key(b, a));
    mesh.triangles[f1] = {{a, d, c}};
    mesh.triangles[f2] = {{d, b, c}};
    for (std::uint32_t f : {f1, f2}) {
      const auto& t = mesh.triangles[f].v;
      for (int k = 0; k < 3; ++k) face_of[edge_key(t[k], t[(k + 1) % 3])] = f;
    }
    queue.push_back({std::min(c, d), std::max(c, d)});
    for (auto [u, v] : {std::pair{a, d}, std::pair{d, b}, std::pair{b, c}, std::pair{c, a}}) {
      queue.push_back({std::min(u, v), std::max(u, v)});
    }
  }
}

// Non-convex shapes: unrotated positions and triangles in, rotated and aligned mesh out.
Mesh finish_shape(const std::vector<Vec3d>& unrotated, std::vector<Triangle> triangles,
                  const std::function<LocalShape(Vec3d)>& shape_at, const ShapeOptions& options) {
  Mesh mesh;
  mesh.positions = rotated_floats(unrotated, options.rotation);
  mesh.triangles = std::move(triangles);
  align_edges_with_curvature(mesh, unrotated, shape_at);
  add_noise(mesh, options);
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// Implicit surfaces (negative inside).

double torus_distance(Vec3d p, double major, double minor) {
  const double rho = std::sqrt(p.x * p.x + p.y * p.y) - major;
  return std::sqrt(rho * rho + p.z * p.z) - minor;
}

// make_genus2's geometry: two tori (R = 1, r = 0.4) centred at x = +-kGenus2Offset, fused by a
// C2 cubic smooth minimum of their signed distances (blend width kGenus2Blend).
constexpr double kGenus2Major = 1.0, kGenus2Minor = 0.4, kGenus2Offset = 1.15, kGenus2Blend = 0.25;

double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * h * k / 6.0;
}

double genus2_function(Vec3d p) {
  const double d1 = torus_distance(p - Vec3d{kGenus2Offset, 0, 0}, kGenus2Major, kGenus2Minor);
  const double d2 = torus_distance(p + Vec3d{kGenus2Offset, 0, 0}, kGenus2Major, kGenus2Minor);
  return smooth_min(d1, d2, kGenus2Blend);
}

// Dented sphere: radius 1 - depth * (1 - t^2)^3 with t = angle to +z / kDentRadius (C2 bump).
constexpr double kDentRadius = 0.7;  // radians

double dent_radius(Vec3d direction, double depth) {
  const double angle = std::acos(std::clamp(direction.z / norm(direction), -1.0, 1.0));
  const double t = angle / kDentRadius;
  if (t >= 1) return 1.0;
  const double s = 1 - t * t;
  return 1.0 - depth * s * s * s;
}

// Moves p onto f = 0 along the gradient (f is close to a distance function near its zero set).
Vec3d project_to_surface(const std::function<double(Vec3d)>& f, Vec3d p) {
  constexpr double h = 1e-6;
  for (int iteration = 0; iteration < 8; ++iteration) {
    const double value = f(p);
    const Vec3d g{(f(p + Vec3d{h, 0, 0}) - f(p - Vec3d{h, 0, 0})) / (2 * h),
                  (f(p + Vec3d{0, h, 0}) - f(p - Vec3d{0, h, 0})) / (2 * h),
                  (f(p + Vec3d{0, 0, h}) - f(p - Vec3d{0, 0, h})) / (2 * h)};
    const double g2 = dot(g, g);
    if (g2 == 0) break;
    p = p - (value / g2) * g;
    if (std::abs(value) < 1e-12) break;
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// Surface nets (a dual contouring without normals) for make_genus2: one vertex per grid cell
// the surface crosses, one quad per grid edge it crosses, split along the diagonal that bends
// the way the surface does. Manifold when the grid resolves the surface (each cell meets one
// sheet); the caller checks and retries with a shifted grid otherwise.
struct GridSurface {
  std::vector<Vec3d> positions;
  std::vector<Triangle> triangles;
};

GridSurface surface_nets(const std::function<double(Vec3d)>& f, Vec3d lo, Vec3d hi, double cell) {
  const int nx = static_cast<int>(std::ceil((hi.x - lo.x) / cell)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y - lo.y) / cell)) + 1;
  const int nz = static_cast<int>(std::ceil((hi.z - lo.z) / cell)) + 1;
  auto node_index = [&](int i, int j, int k) { return (std::size_t(k) * ny + j) * nx + i; };
  auto node_point = [&](int i, int j, int k) {
    return Vec3d{lo.x + i * cell, lo.y + j * cell, lo.z + k * cell};
  };
  std::vector<double> value(std::size_t(nx) * ny * nz);
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        double v = f(node_point(i, j, k));
        if (v == 0) v = 1e-300;  // strictly signed: zero counts as outside
        value[node_index(i, j, k)] = v;
      }
    }
  }
  GridSurface out;
  std::unordered_map<std::size_t, std::uint32_t> cell_vertex;  // cell (by its low node) -> vertex
  auto vertex_of_cell = [&](int i, int j, int k) -> std::uint32_t {
    const std::size_t key = node_index(i, j, k);
    if (auto it = cell_vertex.find(key); it != cell_vertex.end()) return it->second;
    // Average of the crossings on the cell's 12 edges, then onto the surface.
    Vec3d sum;
    int count = 0;
    static constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0},
                                          {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
    for (int a = 0; a < 8; ++a) {
      for (int b = a + 1; b < 8; ++b) {
        const int* ca = kCorner[a];
        const int* cb = kCorner[b];
        if (std::abs(ca[0] - cb[0]) + std::abs(ca[1] - cb[1]) + std::abs(ca[2] - cb[2]) != 1) continue;
        const double va = value[node_index(i + ca[0], j + ca[1], k + ca[2])];
        const double vb = value[node_index(i + cb[0], j + cb[1], k + cb[2])];
        if ((va < 0) == (vb < 0)) continue;
        const double t = va / (va - vb);
        const Vec3d pa = node_point(i + ca[0], j + ca[1], k + ca[2]);
        const Vec3d pb = node_point(i + cb[0], j + cb[1], k + cb[2]);
        sum = sum + (pa + t * (pb - pa));
        ++count;
      }
    }
    const auto id = static_cast<std::uint32_t>(out.positions.size());
    out.positions.push_back(project_to_surface(f, (1.0 / count) * sum));
    cell_vertex.emplace(key, id);
    return id;
  };
  auto emit_quad = [&](std::uint32_t q0, std::uint32_t q1, std::uint32_t q2, std::uint32_t q3) {
    // Counter-clockwise seen from outside. Split along q0-q2 or q1-q3.
    const Vec3d centre = 0.25 * (out.positions[q0] + out.positions[q1] + out.positions[q2] +
                                 out.positions[q3]);
    const LocalShape shape = classify_implicit(f, project_to_surface(f, centre));
    const Point p0 = Point(out.positions[q0].x, out.positions[q0].y, out.positions[q0].z);
    const Point p1 = Point(out.positions[q1].x, out.positions[q1].y, out.positions[q1].z);
    const Point p2 = Point(out.positions[q2].x, out.positions[q2].y, out.positions[q2].z);
    const Point p3 = Point(out.positions[q3].x, out.positions[q3].y, out.positions[q3].z);
    // Diagonal q0-q2 is a convex edge iff q3 lies below the plane of (q0, q1, q2).
    const bool q02_convex = CGAL::orientation(p0, p1, p2, p3) == CGAL::NEGATIVE;
    bool use_q02;
    if (shape == LocalShape::kConvex) {
      use_q02 = q02_convex;
    } else if (shape == LocalShape::kConcave) {
      use_q02 = !q02_convex;
    } else {
      use_q02 = norm(out.positions[q0] - out.positions[q2]) <=
                norm(out.positions[q1] - out.positions[q3]);
    }
    if (use_q02) {
      out.triangles.push_back({{q0, q1, q2}});
      out.triangles.push_back({{q0, q2, q3}});
    } else {
      out.triangles.push_back({{q0, q1, q3}});
      out.triangles.push_back({{q1, q2, q3}});
    }
  };
  // Each grid edge along axis `axis` that changes sign gives a quad of its 4 cells, ordered
  // counter-clockwise around the axis and reversed when the edge points inwards.
  for (int k = 1; k + 1 < nz; ++k) {
    for (int j = 1; j + 1 < ny; ++j) {
      for (int i = 1; i + 1 < nx; ++i) {
        const bool inside = value[node_index(i, j, k)] < 0;
        for (int axis = 0; axis < 3; ++axis) {
          const int di = axis == 0, dj = axis == 1, dk = axis == 2;
          if (i + di >= nx - 1 || j + dj >= ny - 1 || k + dk >= nz - 1) continue;
          const bool next_inside = value[node_index(i + di, j + dj, k + dk)] < 0;
          if (inside == next_inside) continue;
          // Cells around the edge: offsets in the two other axes (u, v), cyclic u -> v.
          std::uint32_t q[4];
          static constexpr int kAround[4][2] = {{-1, -1}, {0, -1}, {0, 0}, {-1, 0}};
          for (int c = 0; c < 4; ++c) {
            int ci = i, cj = j, ck = k;
            const int du = kAround[c][0], dv = kAround[c][1];
            if (axis == 0) { cj += du; ck += dv; }       // (y, z)
            else if (axis == 1) { ck += du; ci += dv; }  // (z, x)
            else { ci += du; cj += dv; }                 // (x, y)
            q[c] = vertex_of_cell(ci, cj, ck);
          }
          if (inside) {
            emit_quad(q[0], q[1], q[2], q[3]);
          } else {
            emit_quad(q[0], q[3], q[2], q[1]);
          }
        }
      }
    }
  }
  return out;
}

// Closed two-manifold check used by the genus-2 retry loop: every directed edge once, its
// reverse once, and one fan per vertex.
bool is_closed_manifold(std::size_t vertex_count, const std::vector<Triangle>& triangles) {
  std::unordered_map<std::uint64_t, std::uint32_t> next_around;  // directed edge (a,b) -> c
  for (const Triangle& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      if (!next_around.emplace(edge_key(t.v[k], t.v[(k + 1) % 3]), t.v[(k + 2) % 3]).second) {
        return false;
      }
    }
  }
  std::vector<std::uint32_t> degree(vertex_count, 0);
  for (const auto& [key, c] : next_around) {
    if (!next_around.count(edge_key(std::uint32_t(key), std::uint32_t(key >> 32)))) return false;
    ++degree[key >> 32];
  }
  // Walk one fan per vertex: around a, (a,b) -> (a,c) where c follows b; count its edges.
  std::vector<bool> seen(vertex_count, false);
  for (const auto& [key, c] : next_around) {
    const auto a = std::uint32_t(key >> 32);
    if (seen[a]) continue;
    seen[a] = true;
    std::uint32_t b = std::uint32_t(key), steps = 0;
    do {
      b = next_around.at(edge_key(a, b));
      ++steps;
    } while (b != std::uint32_t(key) && steps <= degree[a]);
    if (steps != degree[a]) return false;
  }
  return true;
}

std::size_t at_least(std::size_t value, std::size_t minimum) { return std::max(value, minimum); }

}  // namespace

// ---------------------------------------------------------------------------------------------

std::array<double, 4> random_rotation(std::uint64_t seed) {
  // Shoemake, "Uniform random rotations" (Graphics Gems III).
  Random random(seed);
  const double u1 = random.uniform(), u2 = random.uniform(), u3 = random.uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  return {b * std::cos(2 * kPi * u3), a * std::sin(2 * kPi * u2), a * std::cos(2 * kPi * u2),
          b * std::sin(2 * kPi * u3)};
}

int exact_orientation(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  return static_cast<int>(CGAL::orientation(to_point(a), to_point(b), to_point(c), to_point(d)));
}

Mesh convex_hull(std::span<const Vec3f> points) {
  if (points.size() < 4) return {};
  return ConvexHullBuilder(points).build();
}

Mesh make_sphere(const ShapeOptions& options) {
  return convex_shape(fibonacci_sphere(at_least(options.vertices, 4)), options);
}

Mesh make_ellipsoid(double a, double b, double c, const ShapeOptions& options) {
  assert(a > 0 && b > 0 && c > 0);
  // The linear image of a uniform sphere lattice: the normal density stays within a factor
  // (max axis / min axis)^2 of uniform, so every region of G is resolved.
  std::vector<Vec3d> points = fibonacci_sphere(at_least(options.vertices, 4));
  for (Vec3d& p : points) p = {a * p.x, b * p.y, c * p.z};
  return convex_shape(points, options);
}

Mesh make_rounded_cube(double exponent, const ShapeOptions& options) {
  assert(exponent >= 2);
  // Signed power map x_i = sign(u_i) |u_i|^(2/p) of sphere points u: lands exactly on
  // |x|^p + |y|^p + |z|^p = 1, and its normal is n_i ~ sign(u_i) |u_i|^(2 - 2/p), a bounded
  // distortion of u for every p, so points crowd where the curvature is high.
  std::vector<Vec3d> points = fibonacci_sphere(at_least(options.vertices, 4));
  const double e = 2.0 / exponent;
  auto power = [e](double u) { return std::copysign(std::pow(std::abs(u), e), u); };
  for (Vec3d& p : points) p = {power(p.x), power(p.y), power(p.z)};
  return convex_shape(points, options);
}

Mesh make_torus(double major_radius, double minor_radius, const ShapeOptions& options) {
  assert(major_radius > minor_radius && minor_radius > 0);
  const double R = major_radius, r = minor_radius;
  // Staggered grid: ring j (angle v around the tube) holds nu points at angles u = (i + j%2/2)
  // du around the axis, so neighbouring rings form isosceles triangles. A non-staggered grid of
  // a surface of revolution has exactly planar quads, whose diagonals rounding then bends at
  // random. With du/dv chosen for near-equilateral triangles at radius R, the lattice is
  // Delaunay in the second fundamental form (r dv^2 >= (R + r) du^2 / 4), so edges on the
  // outer, convex half are convex; the flip pass checks what the second-order argument misses.
  const double ratio = std::sqrt(3.0) / 2.0 * R / r;  // nu / nv
  const double n = static_cast<double>(at_least(options.vertices, 36));
  std::size_t nv = static_cast<std::size_t>(std::lround(std::sqrt(n / ratio) / 2)) * 2;
  nv = at_least(nv, 6);
  const std::size_t nu = at_least(static_cast<std::size_t>(std::lround(n / nv)), 6);
  std::vector<Vec3d> points(nu * nv);
  for (std::size_t j = 0; j < nv; ++j) {
    const double v = 2 * kPi * double(j) / double(nv);
    for (std::size_t i = 0; i < nu; ++i) {
      const double u = 2 * kPi * (double(i) + 0.5 * double(j % 2)) / double(nu);
      const double rho = R + r * std::cos(v);
      points[j * nu + i] = {rho * std::cos(u), rho * std::sin(u), r * std::sin(v)};
    }
  }
  auto id = [nu, nv](std::size_t i, std::size_t j) {
    return static_cast<VertexIndex>((j % nv) * nu + (i % nu));
  };
  std::vector<Triangle> triangles;
  triangles.reserve(2 * nu * nv);
  for (std::size_t j = 0; j < nv; ++j) {
    for (std::size_t i = 0; i < nu; ++i) {
      // (u, v) counter-clockwise is outward: d/du x d/dv points away from the tube's core.
      if (j % 2 == 0) {
        triangles.push_back({{id(i, j), id(i + 1, j), id(i, j + 1)}});
        triangles.push_back({{id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)}});
      } else {
        triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
        triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
      }
    }
  }
  auto f = [R, r](Vec3d p) { return torus_distance(p, R, r); };
  return finish_shape(points, std::move(triangles),
                      [&f](Vec3d p) { return classify_implicit(f, project_to_surface(f, p)); },
                      options);
}

Mesh make_dented_sphere(double dent_depth, const ShapeOptions& options) {
  assert(dent_depth >= 0 && dent_depth < 1);
  // The connectivity of the unit sphere's hull (the spherical Delaunay triangulation of a
  // Fibonacci lattice), with each point moved radially to 1 - depth * bump(angle to +z); the
  // flip pass then makes edges in the dent concave and in the rim region convex.
  const std::vector<Vec3d> sphere = fibonacci_sphere(at_least(options.vertices, 4));
  std::vector<Vec3f> sphere_floats;
  for (const Vec3d& p : sphere) sphere_floats.push_back(to_float(p));
  Mesh hull = convex_hull(sphere_floats);
  std::vector<Vec3d> points;
  points.reserve(hull.positions.size());
  for (const Vec3f& p : hull.positions) {
    const Vec3d d = stream::to_d(p);
    points.push_back((dent_radius(d, dent_depth) / norm(d)) * d);
  }
  auto f = [dent_depth](Vec3d p) { return norm(p) - dent_radius(p, dent_depth); };
  return finish_shape(points, std::move(hull.triangles),
                      [&f](Vec3d p) { return classify_implicit(f, project_to_surface(f, p)); },
                      options);
}

Mesh make_genus2(const ShapeOptions& options) {
  const std::function<double(Vec3d)> f = genus2_function;
  const double margin = 0.1;
  const Vec3d lo{-(kGenus2Offset + kGenus2Major + kGenus2Minor) - margin,
                 -(kGenus2Major + kGenus2Minor) - margin, -kGenus2Minor - margin};
  const Vec3d hi = -1.0 * lo;
  // Surface nets make about 1.5 vertices per cell^2 of area; the area is about 2 tori minus
  // the fused part. One calibration run corrects the estimate.
  const double area = 2 * 4 * kPi * kPi * kGenus2Major * kGenus2Minor * 0.85;
  const double wanted = static_cast<double>(at_least(options.vertices, 200));
  double cell = std::sqrt(1.5 * area / wanted);
  GridSurface grid = surface_nets(f, lo - Vec3d{cell, cell, cell}, hi + Vec3d{cell, cell, cell}, cell);
  cell *= std::sqrt(static_cast<double>(grid.positions.size()) / wanted);
  for (int attempt = 0; attempt < 8; ++attempt) {
    const double shift = cell * (1 + 0.37 * attempt / 8.0);  // shifted grids if one fails
    grid = surface_nets(f, lo - Vec3d{shift, shift, shift}, hi + Vec3d{cell, cell, cell}, cell);
    if (is_closed_manifold(grid.positions.size(), grid.triangles)) break;
  }
  return finish_shape(grid.positions, std::move(grid.triangles),
                      [&f](Vec3d p) { return classify_implicit(f, project_to_surface(f, p)); },
                      options);
}

LocalShape genus2_local_shape(const Vec3f& unrotated_point) {
  const std::function<double(Vec3d)> f = genus2_function;
  return classify_implicit(f, project_to_surface(f, stream::to_d(unrotated_point)));
}

Mesh make_wavy_sheet(int n) {
  Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = float(i) / float(n), y = float(j) / float(n);
      m.positions.push_back({x, y, 0.1f * std::sin(6 * x) * std::cos(5 * y)});
    }
  auto id = [n](int i, int j) { return std::uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      m.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  return m;
}

}  // namespace gaussmesh::testing
