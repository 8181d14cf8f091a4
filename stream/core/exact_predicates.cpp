// Exact orientation signs (paper §4, Fig. 5): a static floating-point filter, then CGAL's
// filtered exact predicate behind a CGAL-free header.
#include "stream/core/exact_predicates.h"

#include <cmath>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace gaussmesh::stream {
namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;

int cgal_orientation_sign(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  // CGAL::orientation(p, q, r, s) is the sign of det[q - p, r - p, s - p]; with p = O the
  // subtractions are exact, so this is exactly sign(det[a, b, c]).
  static const Point kOrigin(0, 0, 0);
  const CGAL::Orientation o =
      CGAL::orientation(kOrigin, Point(a.x, a.y, a.z), Point(b.x, b.y, b.z), Point(c.x, c.y, c.z));
  return o == CGAL::POSITIVE ? 1 : (o == CGAL::NEGATIVE ? -1 : 0);
}

}  // namespace

int orientation_sign(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  if (const int sign = orientation_sign_filter(a, b, c)) return sign;
  return cgal_orientation_sign(a, b, c);
}

}  // namespace gaussmesh::stream
