// Speed of the planar polygon triangulator (stream/meshing/polygon_triangulation.h) on random star
// polygons of growing size, with and without holes. Prints a table; asserts nothing.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "stream/meshing/polygon_triangulation.h"

using namespace gaussmesh::stream;

int main() {
  std::printf("| vertices | holes | triangles | ms |\n| --- | --- | --- | --- |\n");
  for (std::size_t n : {100u, 1000u, 10000u}) {
    for (std::size_t holes : {0u, 10u}) {
      std::mt19937_64 rng(n * 31 + holes);
      std::uniform_real_distribution<double> radius(0.7, 1.0);
      std::vector<PolygonPoint2> points;
      std::vector<std::vector<std::uint32_t>> loops(1);
      for (std::size_t i = 0; i < n; ++i) {
        double a = 2 * M_PI * double(i) / double(n), r = 10 * radius(rng);
        loops[0].push_back(static_cast<std::uint32_t>(points.size()));
        points.push_back({r * std::cos(a), r * std::sin(a)});
      }
      // Small square holes on a ring well inside the star's inner radius (7).
      for (std::size_t h = 0; h < holes; ++h) {
        double a = 2 * M_PI * double(h) / double(holes), cx = 4 * std::cos(a), cy = 4 * std::sin(a), s = 0.3;
        std::vector<std::uint32_t> loop;
        for (auto [dx, dy] : {std::pair{-s, -s}, {-s, s}, {s, s}, {s, -s}}) {
          loop.push_back(static_cast<std::uint32_t>(points.size()));
          points.push_back({cx + dx, cy + dy});
        }
        loops.push_back(loop);
      }
      auto start = std::chrono::steady_clock::now();
      auto result = triangulate_polygon_2d(points, loops);
      double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      if (!result) {
        std::fprintf(stderr, "%s\n", result.status().to_string().c_str());
        return 3;
      }
      std::printf("| %zu | %zu | %zu | %.1f |\n", n, holes, result->size(), ms);
    }
  }
  return 0;
}
