// Exact orientation signs on the Gaussian sphere: sign of det[a, b, c] for three vectors, the
// only predicate the exact sample test (paper §4, Fig. 5; docs/sampling.md) and the sphere tests
// need.
// Wraps CGAL's filtered exact predicate (LGPL kernel, header-only); CGAL stays in the .cpp.
#pragma once

#include <cmath>

#include "format/mesh_types.h"

namespace gaussmesh::stream {

// A double-precision 3-vector: normals and Gaussian vertices, never positions.
struct Vec3d {
  double x = 0, y = 0, z = 0;
};

inline Vec3d operator+(const Vec3d& a, const Vec3d& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3d operator-(const Vec3d& a, const Vec3d& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3d operator*(double s, const Vec3d& a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// A float position or normal widened exactly to double.
inline Vec3d to_d(const format::Vec3f& v) { return {v.x, v.y, v.z}; }

// The unit vector along v rounded to float; the zero vector when v has no direction.
inline format::Vec3f unit_f(const Vec3d& v) {
  const double len = std::sqrt(dot(v, v));
  if (!(len > 0)) return {};
  const double s = 1.0 / len;
  return {static_cast<float>(v.x * s), static_cast<float>(v.y * s), static_cast<float>(v.z * s)};
}

// Exact sign (-1, 0, +1) of det[a, b, c] = (a × b) · c, i.e. CGAL::orientation(O, a, b, c):
// +1 when c lies on the side of the plane through the origin, a and b that a × b points to.
// Exact for all finite double inputs (a static filter answers most calls; exact arithmetic the
// rest). Non-finite inputs are a precondition violation.
int orientation_sign(const Vec3d& a, const Vec3d& b, const Vec3d& c);

// orientation_sign's static filter, inline for hot loops: +1 or -1 when doubles decide the sign,
// 0 when they cannot (then ask orientation_sign). det = a · (b × c) in doubles differs from the
// exact value by at most 3 u (1 + u)^2 · perm, with perm the same expression over absolute values
// (u = 2^-53: each product, difference and sum rounds once). Outside 8 u · perm the sign is
// certain; inside, or with tiny (possibly underflowing) or non-finite terms, it is not.
inline int orientation_sign_filter(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const double m1 = b.y * c.z - b.z * c.y, m2 = b.z * c.x - b.x * c.z, m3 = b.x * c.y - b.y * c.x;
  const double det = a.x * m1 + a.y * m2 + a.z * m3;
  const double perm = std::abs(a.x) * (std::abs(b.y * c.z) + std::abs(b.z * c.y)) +
                      std::abs(a.y) * (std::abs(b.z * c.x) + std::abs(b.x * c.z)) +
                      std::abs(a.z) * (std::abs(b.x * c.y) + std::abs(b.y * c.x));
  constexpr double kBound = 8 * 0x1.0p-53;
  if (perm > 1e-150 && perm < 1e150) {
    if (det > kBound * perm) return 1;
    if (det < -kBound * perm) return -1;
  }
  return 0;
}

}  // namespace gaussmesh::stream
