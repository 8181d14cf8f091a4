// Attribute transfer by nearest surface point (attribute_transfer.h).
#include "stream/attributes/attribute_transfer.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "stream/analysis/mesh_distance.h"

namespace gaussmesh::stream {
namespace {

using format::Color;
using format::Triangle;
using format::Vec2f;
using format::Vec3f;


// Barycentric weights of q, a point of triangle (a, b, c), by the sub-triangles' areas along
// the triangle's normal; a degenerate triangle gives its nearest corner all the weight.
std::array<double, 3> barycentric(const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d n = cross(b - a, c - a);
  const double area = dot(n, n);
  if (!(area > 0)) {
    const double d[3] = {dot(q - a, q - a), dot(q - b, q - b), dot(q - c, q - c)};
    const int k = d[0] <= d[1] && d[0] <= d[2] ? 0 : d[1] <= d[2] ? 1 : 2;
    std::array<double, 3> w{0, 0, 0};
    w[k] = 1;
    return w;
  }
  double wa = std::max(0.0, dot(cross(b - q, c - q), n) / area);
  double wb = std::max(0.0, dot(cross(c - q, a - q), n) / area);
  double wc = std::max(0.0, dot(cross(a - q, b - q), n) / area);
  const double sum = wa + wb + wc;
  return {wa / sum, wb / sum, wc / sum};
}

Vec3f normalised(double x, double y, double z) {
  const double length = std::sqrt(x * x + y * y + z * z);
  if (!(length > 0)) return {0, 0, 1};
  return {float(x / length), float(y / length), float(z / length)};
}

}  // namespace

std::vector<Vec3f> vertex_normals(format::MeshView mesh) {
  std::vector<double> sum(3 * mesh.positions.size(), 0.0);
  for (const Triangle& t : mesh.triangles) {
    const Vec3d n = cross(to_d(mesh.positions[t.v[1]]) - to_d(mesh.positions[t.v[0]]),
                          to_d(mesh.positions[t.v[2]]) - to_d(mesh.positions[t.v[0]]));  // twice the area
    for (format::VertexIndex v : t.v) {
      sum[3 * v] += n.x;
      sum[3 * v + 1] += n.y;
      sum[3 * v + 2] += n.z;
    }
  }
  std::vector<Vec3f> normals(mesh.positions.size());
  for (std::size_t v = 0; v < normals.size(); ++v) normals[v] = normalised(sum[3 * v], sum[3 * v + 1], sum[3 * v + 2]);
  return normals;
}

void transfer_attributes(format::MeshView input, Mesh& output, NormalsMode normals) {
  const bool take_normals = normals == NormalsMode::kKeep && !input.normals.empty();
  const bool take_colors = !input.colors.empty(), take_texcoords = !input.texcoords.empty();
  const std::size_t n = output.positions.size();
  output.normals.clear();
  output.colors.clear();
  output.texcoords.clear();
  if (take_normals) output.normals.resize(n);
  if (take_colors) output.colors.resize(n);
  if (take_texcoords) output.texcoords.resize(n);
  if ((take_normals || take_colors || take_texcoords) && !input.triangles.empty()) {
    const TriangleTree tree(input);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t v = range.begin(); v < range.end(); ++v) {
        const Vec3d p = to_d(output.positions[v]);
        // Every search starts from the same leaf, so that a tie goes the same way whatever the
        // split into threads (a hint from the last vertex would decide it by the split).
        std::uint32_t leaf = 0;
        tree.nearest_distance_squared(p, &leaf);
        const Triangle& t = input.triangles[tree.leaf_triangle(leaf)];
        const Vec3d a = to_d(input.positions[t.v[0]]), b = to_d(input.positions[t.v[1]]), c = to_d(input.positions[t.v[2]]);
        Vec3d q;
        point_triangle_distance_squared(p, a, b, c, &q);
        const std::array<double, 3> w = barycentric(q, a, b, c);
        if (take_normals) {
          double x = 0, y = 0, z = 0;
          for (int k = 0; k < 3; ++k) {
            const Vec3f& m = input.normals[t.v[k]];
            x += w[k] * m.x, y += w[k] * m.y, z += w[k] * m.z;
          }
          output.normals[v] = normalised(x, y, z);
        }
        if (take_colors) {
          double rgba[4] = {0, 0, 0, 0};
          for (int k = 0; k < 3; ++k) {
            const Color& m = input.colors[t.v[k]];
            rgba[0] += w[k] * m.r, rgba[1] += w[k] * m.g, rgba[2] += w[k] * m.b, rgba[3] += w[k] * m.a;
          }
          output.colors[v] = {float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3])};
        }
        if (take_texcoords) {
          double u = 0, s = 0;
          for (int k = 0; k < 3; ++k) {
            u += w[k] * input.texcoords[t.v[k]].u;
            s += w[k] * input.texcoords[t.v[k]].v;
          }
          output.texcoords[v] = {float(u), float(s)};
        }
      }
    });
  }
  if (normals == NormalsMode::kCompute) output.normals = vertex_normals(output.view());
}

}  // namespace gaussmesh::stream
