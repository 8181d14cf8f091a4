// Exact orientation signs (paper §4, Fig. 5): a static floating-point filter, then CGAL's
// filtered exact predicate behind a CGAL-free header.
#include "stream/exact_predicates.h"

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
  // Static filter: det = a · (b × c) in doubles differs from the exact value by at most
  // 3 u (1 + u)^2 · perm, with perm the same expression over absolute values (u = 2^-53: each
  // product, difference and sum rounds once). Outside 8 u · perm the sign is certain; inside,
  // or with tiny (possibly underflowing) or non-finite terms, ask the exact predicate.
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
  return cgal_orientation_sign(a, b, c);
}

}  // namespace gaussmesh::stream
