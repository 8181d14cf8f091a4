// Generators of the paper's analytic test shapes (Figs. 2-4, genus 2), at any resolution,
// rotation and noise. Convex shapes are triangulated as convex hulls (DESIGN §3.2): a grid with
// fixed diagonals leaves slightly reflex edges whose saddles add genuine Gauss preimages.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "stream/mesh.h"

namespace gaussmesh::testing {

using stream::Mesh;
using format::Vec3f;

struct ShapeOptions {
  // Roughly the number of vertices wanted; generators pick the nearest they can make.
  std::size_t vertices = 5000;
  // Rotation as a unit quaternion (w, x, y, z); identity by default.
  std::array<double, 4> rotation = {1, 0, 0, 0};
  // Gaussian noise on positions, as a fraction of the bounding-box diagonal (0 = none).
  double noise = 0;
  std::uint64_t seed = 1;
};

// A uniformly random unit quaternion from seed (for "random orientations").
std::array<double, 4> random_rotation(std::uint64_t seed);

// Convex hull of points (exact orientation predicates); faces oriented outward.
// Precondition: at least 4 points not all coplanar.
Mesh convex_hull(std::span<const Vec3f> points);

// Closed convex genus-0 shapes (convex hulls of well-spread surface points).
Mesh make_sphere(const ShapeOptions& options);
Mesh make_ellipsoid(double a, double b, double c, const ShapeOptions& options);
// Superellipsoid |x|^p + |y|^p + |z|^p = 1: p = 2 is the sphere, larger p rounds a cube
// (the Fig. 2 morph). Precondition: p >= 2.
Mesh make_rounded_cube(double exponent, const ShapeOptions& options);
// Torus with major radius R and minor radius r (thin: r/R small; thick: r/R near 1).
Mesh make_torus(double major_radius, double minor_radius, const ShapeOptions& options);
// A sphere with a smooth inward dent (Fig. 4): concave region, so more samples.
Mesh make_dented_sphere(double dent_depth, const ShapeOptions& options);
// A closed genus-2 surface (two fused tori, smooth).
Mesh make_genus2(const ShapeOptions& options);

}  // namespace gaussmesh::testing
