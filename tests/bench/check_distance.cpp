// check_distance: cross-checks stream::mesh_distance (what `gaussmesh compare` reports) against
// an independent implementation, CGAL's Polygon_mesh_processing (its own sampler, its own AABB
// tree, approximate_Hausdorff_distance), on real and analytic mesh pairs, and prints a table
// (docs/compare.md quotes it). CGAL's PMP/AABB packages are GPL: they are linked here, in a
// check program, and never in the shipped tool.
//
// Usage: check_distance [SAMPLES]   (area samples per mesh; default 200000)
#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Surface_mesh.h>
#include <meshoptimizer.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "stream/core/mesh.h"
#include "stream/core/stopwatch.h"
#include "stream/analysis/mesh_distance.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using gaussmesh::stream::Mesh;
using gaussmesh::stream::Clock;
using gaussmesh::stream::seconds_since;

// Our mesh as a CGAL Surface_mesh, through a repaired and oriented polygon soup (simplified or
// real meshes may have degenerate or non-manifold faces, which a soup tolerates).
SurfaceMesh to_surface_mesh(const Mesh& mesh) {
  std::vector<Point> points;
  points.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) points.emplace_back(p.x, p.y, p.z);
  std::vector<std::vector<std::size_t>> faces;  // resizable: repair may shorten polygons
  faces.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) faces.push_back({t.v[0], t.v[1], t.v[2]});
  PMP::repair_polygon_soup(points, faces);
  PMP::orient_polygon_soup(points, faces);
  SurfaceMesh out;
  PMP::polygon_soup_to_polygon_mesh(points, faces, out);
  return out;
}

double diagonal_of(const Mesh& mesh) {
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (const auto& t : mesh.triangles) {
    for (auto v : t.v) {
      const auto& p = mesh.positions[v];
      const float xyz[3] = {p.x, p.y, p.z};
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], xyz[k]);
        hi[k] = std::max(hi[k], xyz[k]);
      }
    }
  }
  return std::hypot(double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]);
}

double area_of(const SurfaceMesh& mesh) { return PMP::area(mesh); }

struct CgalOneSided {
  double hausdorff = 0;  // approximate_Hausdorff_distance (samples faces, edges, vertices)
  double rms = 0;        // RMS over CGAL's face samples, distances from CGAL's AABB tree
};

// From `from`'s samples to `to`, with `face_samples` random points on the faces of `from`.
CgalOneSided cgal_one_sided(const SurfaceMesh& from, const SurfaceMesh& to, double face_samples,
                            double diagonal) {
  CgalOneSided out;
  const auto n = static_cast<unsigned int>(face_samples);
  const double per_length = 2000.0 / diagonal;  // edge samples: 2000 per diagonal length
  out.hausdorff = PMP::approximate_Hausdorff_distance<CGAL::Sequential_tag>(
      from, to,
      PMP::parameters::number_of_points_on_faces(n).number_of_points_per_distance_unit(per_length),
      PMP::parameters::default_values());
  std::vector<Point> samples;
  PMP::sample_triangle_mesh(
      from, std::back_inserter(samples),
      PMP::parameters::number_of_points_on_faces(n).do_sample_vertices(false).do_sample_edges(false));
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
  Tree tree(faces(to).first, faces(to).second, to);
  tree.accelerate_distance_queries();
  double sum = 0;
  for (const Point& p : samples) sum += tree.squared_distance(p);
  out.rms = samples.empty() ? 0 : std::sqrt(sum / double(samples.size()));
  return out;
}

// CGAL's distance (its AABB tree) at our feature samples: every vertex and edge midpoint of
// `from`. Separates "the distances differ" from "the samples differ".
double cgal_at_features(const Mesh& from, const SurfaceMesh& to) {
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
  Tree tree(faces(to).first, faces(to).second, to);
  tree.accelerate_distance_queries();
  double best = 0;
  for (const auto& t : from.triangles) {
    for (int k = 0; k < 3; ++k) {
      const auto& p = from.positions[t.v[k]];
      const auto& q = from.positions[t.v[(k + 1) % 3]];
      best = std::max(best, tree.squared_distance(Point(p.x, p.y, p.z)));
      best = std::max(best, tree.squared_distance(Point((double(p.x) + q.x) / 2,
                                                        (double(p.y) + q.y) / 2,
                                                        (double(p.z) + q.z) / 2)));
    }
  }
  return std::sqrt(best);
}

// meshoptimizer's simplifier (another project's algorithm) makes a realistic "approximation".
Mesh simplified(const Mesh& mesh, double fraction) {
  std::vector<unsigned int> indices;
  for (const auto& t : mesh.triangles) indices.insert(indices.end(), t.v, t.v + 3);
  std::vector<unsigned int> out(indices.size());
  const std::size_t target = static_cast<std::size_t>(double(indices.size()) * fraction) / 3 * 3;
  float error = 0;
  out.resize(meshopt_simplify(out.data(), indices.data(), indices.size(),
                              &mesh.positions[0].x, mesh.positions.size(),
                              sizeof(gaussmesh::format::Vec3f), target, 1.0f, 0, &error));
  Mesh result;
  result.positions = mesh.positions;  // unreferenced vertices are ignored by both measures
  for (std::size_t i = 0; i + 2 < out.size(); i += 3) {
    result.triangles.push_back({{out[i], out[i + 1], out[i + 2]}});
  }
  return result;
}

Mesh load(const std::string& path) {
  auto mesh = gaussmesh::stream::load_mesh(path);
  if (!mesh) {
    std::fprintf(stderr, "check_distance: %s\n", mesh.status().to_string().c_str());
    std::exit(2);
  }
  return std::move(mesh).value();
}

struct Pair {
  std::string name;
  Mesh a, b;
  double analytic = -1;  // symmetric Hausdorff in the meshes' units, when known
};

}  // namespace

int main(int argc, char** argv) {
  using namespace gaussmesh;
  const std::size_t samples = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 200000;
  std::vector<Pair> pairs;
  {
    const stream::Mesh cow = load(testing::fixture("real/cow.off"));
    pairs.push_back({"cow vs meshopt 25%", cow, simplified(cow, 0.25)});
    pairs.push_back({"cow vs meshopt 5%", cow, simplified(cow, 0.05)});
    const stream::Mesh fandisk = load(testing::fixture("real/fandisk.off"));
    pairs.push_back({"fandisk vs meshopt 10%", fandisk, simplified(fandisk, 0.10)});
    const stream::Mesh knot = load(testing::fixture("real/knot1.off"));
    pairs.push_back({"knot1 vs meshopt 10%", knot, simplified(knot, 0.10)});
  }
  {
    testing::ShapeOptions shape;
    shape.vertices = 20000;
    const stream::Mesh sphere = testing::make_sphere(shape);
    testing::ShapeOptions noisy = shape;
    noisy.noise = 0.002;
    pairs.push_back({"sphere vs noisy sphere", sphere, testing::make_sphere(noisy)});
    pairs.push_back({"sphere vs ellipsoid", sphere, testing::make_ellipsoid(1.3, 1.1, 1.0, shape),
                     0.3});
  }

  std::printf("samples per mesh: %zu area samples (ours and CGAL's face samples)\n", samples);
  std::printf("%-24s %7s %7s | %8s %8s %8s | %8s %8s %8s | %9s %9s | %8s %8s | %6s %6s\n",
              "pair (A vs B)", "faces A", "faces B", "H(A>B)us", "cgal", "cgal@f", "H(B>A)us",
              "cgal", "cgal@f", "rms(A>B)u", "rms(A>B)c", "H us", "analytic", "t us", "t cgal");
  for (const Pair& pair : pairs) {
    const double diagonal = diagonal_of(pair.a);
    auto pct = [diagonal](double d) { return 100 * d / diagonal; };

    stream::DistanceOptions options;
    options.samples = samples;
    const auto start = Clock::now();
    auto ours = stream::mesh_distance(pair.a.view(), pair.b.view(), options);
    const double ours_s = seconds_since(start);
    if (!ours) {
      std::fprintf(stderr, "check_distance: %s: %s\n", pair.name.c_str(),
                   ours.status().to_string().c_str());
      return 3;
    }

    const SurfaceMesh a = to_surface_mesh(pair.a), b = to_surface_mesh(pair.b);
    // Same density on both meshes, as ours: B's face samples scale with its area.
    const double samples_b = double(samples) * area_of(b) / area_of(a);
    const auto cgal_start = Clock::now();
    const CgalOneSided ab = cgal_one_sided(a, b, double(samples), diagonal);
    const CgalOneSided ba = cgal_one_sided(b, a, samples_b, diagonal);
    const double cgal_s = seconds_since(cgal_start);

    char analytic[32] = "-";
    if (pair.analytic >= 0) std::snprintf(analytic, sizeof analytic, "%.4f", pct(pair.analytic));
    const double ab_features = cgal_at_features(pair.a, b), ba_features = cgal_at_features(pair.b, a);
    std::printf("%-24s %7zu %7zu | %8.4f %8.4f %8.4f | %8.4f %8.4f %8.4f | %9.4f %9.4f | %8.4f %8s | "
                "%6.2f %6.2f\n",
                pair.name.c_str(), pair.a.triangles.size(), pair.b.triangles.size(),
                pct(ours->a_to_b.max), pct(ab.hausdorff), pct(ab_features), pct(ours->b_to_a.max),
                pct(ba.hausdorff), pct(ba_features), pct(ours->a_to_b.rms), pct(ab.rms),
                ours->hausdorff_pct(), analytic, ours_s, cgal_s);
  }
  std::printf("all figures in %% of A's bounding-box diagonal. us: stream::mesh_distance; cgal: "
              "PMP::approximate_Hausdorff_distance (own samples on faces, edges, vertices); cgal@f: "
              "CGAL's AABB tree at our vertex + edge-midpoint samples; rms(A>B)c: CGAL face samples "
              "and AABB tree.\nt = seconds (ours: both directions, all threads; CGAL: sequential, "
              "both directions + the RMS pass)\n");
  return 0;
}
