#include "stream/finish/colour_quadrics.h"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

#include "stream/core/canonical_order.h"

namespace gaussmesh::stream {
namespace {

// Positions as map keys: the canonical position_hash, and equal when their ordered bits are (-0 is 0).
struct PositionHash {
  std::size_t operator()(const Vec3f& p) const { return std::size_t(position_hash(p)); }
};
struct SamePosition {
  bool operator()(const Vec3f& a, const Vec3f& b) const {
    return ordered_bits(a.x) == ordered_bits(b.x) && ordered_bits(a.y) == ordered_bits(b.y) &&
           ordered_bits(a.z) == ordered_bits(b.z);
  }
};

}  // namespace

ColourTerms colour_quadrics(MeshView coloured, MeshView mesh, const QuadricFrame& frame, double weight) {
  ColourTerms terms;
  if (coloured.colors.empty() || !(weight > 0)) return terms;
  terms.quadrics.resize(mesh.positions.size());
  terms.sums.resize(mesh.positions.size());
  std::unordered_map<Vec3f, std::uint32_t, PositionHash, SamePosition> at;
  at.reserve(mesh.positions.size());
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) at.try_emplace(mesh.positions[v], v);
  std::vector<std::uint32_t> target(coloured.positions.size(), UINT32_MAX);
  for (std::uint32_t v = 0; v < coloured.positions.size(); ++v) {
    auto it = at.find(coloured.positions[v]);
    if (it != at.end()) target[v] = it->second;
  }
  for (const Triangle& t : coloured.triangles) {
    const Vec3f &a = coloured.positions[t.v[0]], &b = coloured.positions[t.v[1]], &c = coloured.positions[t.v[2]];
    const Vec3dq p0 = frame.to_frame(a.x, a.y, a.z), p1 = frame.to_frame(b.x, b.y, b.z), p2 = frame.to_frame(c.x, c.y, c.z);
    const Vec3dq e1 = sub(p1, p0), e2 = sub(p2, p0), n = cross(e1, e2);
    const double n2 = norm2(n);
    if (!(n2 > 0) || !std::isfinite(n2)) continue;
    const double area = std::sqrt(n2) / 2;
    // The gradient of a linear function with values f0, f1, f2 at the corners, in the face's plane:
    // ((f1 - f0) e2 × n + (f2 - f0) n × e1) / |n|².
    const Vec3dq u = scale(cross(e2, n), 1 / n2), w = scale(cross(n, e1), 1 / n2);
    Vec3dq g[3];
    double d[3];
    double range = 0, m = 0;
    for (int k = 0; k < 3; ++k) {
      const float f0 = (&coloured.colors[t.v[0]].r)[k], f1 = (&coloured.colors[t.v[1]].r)[k], f2 = (&coloured.colors[t.v[2]].r)[k];
      range = std::max(range, double(std::max({f0, f1, f2}) - std::min({f0, f1, f2})));
      g[k] = add(scale(u, double(f1) - f0), scale(w, double(f2) - f0));
      d[k] = double(f0) - dot(g[k], p0);
      m += norm2(g[k]);
    }
    double s = weight * area;
    const double cap = 64 * weight * range * range;
    if (s * m > cap) s *= cap / (s * m);
    if (!(s > 0)) continue;
    Quadric q;
    ColourSum sum;
    sum.s = s;
    for (int k = 0; k < 3; ++k) {
      const Vec3dq& a = g[k];
      q.q[0] += s * a.x * a.x, q.q[1] += s * a.x * a.y, q.q[2] += s * a.x * a.z;
      q.q[3] += s * a.y * a.y, q.q[4] += s * a.y * a.z, q.q[5] += s * a.z * a.z;
      q.q[6] += s * d[k] * a.x, q.q[7] += s * d[k] * a.y, q.q[8] += s * d[k] * a.z, q.q[9] += s * d[k] * d[k];
      sum.g[k] = {s * a.x, s * a.y, s * a.z};
      sum.d[k] = s * d[k];
    }
    q.weight = 0;  // it adds cost, not surface: the mean distance to the planes stays theirs
    const FixedQuadric fixed = FixedQuadric::from(q);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = target[t.v[k]];
      if (v == UINT32_MAX) continue;
      terms.quadrics[v] += fixed;
      terms.sums[v] += sum;
    }
  }
  return terms;
}

}  // namespace gaussmesh::stream
