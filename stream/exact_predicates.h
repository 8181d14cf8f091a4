// Exact orientation signs on the Gaussian sphere: sign of det[a, b, c] for three vectors, the
// only predicate the exact sample test (paper §4, Fig. 5; DESIGN §1) and the sphere tests need.
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

}  // namespace gaussmesh::stream
