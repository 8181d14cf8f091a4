#include "stream/finish/colour_quadrics.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <unordered_map>

namespace gaussmesh::stream {
namespace {

struct PositionHash {
  std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
    std::uint64_t h = 0x9E3779B97F4A7C15ull;
    for (const auto w : k) h = (h ^ w) * 0xBF58476D1CE4E5B9ull, h ^= h >> 29;
    return std::size_t(h);
  }
};

std::array<std::uint32_t, 3> bits(const Vec3f& p) {
  return {std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y), std::bit_cast<std::uint32_t>(p.z)};
}

}  // namespace

ColourTerms colour_quadrics(MeshView coloured, MeshView mesh, const QuadricFrame& frame, double weight) {
  ColourTerms terms;
  if (coloured.colors.empty() || !(weight > 0)) return terms;
  terms.quadrics.resize(mesh.positions.size());
  terms.sums.resize(mesh.positions.size());
  std::unordered_map<std::array<std::uint32_t, 3>, std::uint32_t, PositionHash> at;
  at.reserve(mesh.positions.size());
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) at.try_emplace(bits(mesh.positions[v]), v);
  std::vector<std::uint32_t> target(coloured.positions.size(), UINT32_MAX);
  for (std::uint32_t v = 0; v < coloured.positions.size(); ++v) {
    auto it = at.find(bits(coloured.positions[v]));
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
