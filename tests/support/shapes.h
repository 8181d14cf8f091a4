// Generators of the paper's analytic test shapes (Figs. 2-4, genus 2), at any resolution,
// rotation and noise. Convex shapes are triangulated as convex hulls: a grid with fixed
// diagonals leaves slightly reflex edges whose saddles add genuine Gauss preimages.
// Non-convex shapes are structured meshes whose edges bend with the surface: convex where the
// surface is convex, concave where it is concave (saddle regions: whatever the grid gives).
// Rotation is applied before triangulating convex shapes, so hulls are exactly convex in the
// float coordinates delivered; noise is applied last (it breaks convexity, by design).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "stream/core/mesh.h"

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

// Convex hull of points (exact orientation predicates); faces oriented outward, counter-
// clockwise seen from outside, none degenerate. Output vertices are a subset of the points in
// input order, each used: points inside the hull are dropped; points on its boundary (on a
// face or an edge of the true polytope) may stay as vertices joined by coplanar triangles.
// Returns an empty mesh when fewer than 4 points are not coplanar. Expected O(n log n).
Mesh convex_hull(std::span<const Vec3f> points);

// Exact sign of det[b - a, c - a, d - a]: +1 when d lies on the side that a, b, c (counter-
// clockwise) face, i.e. outside an outward face; 0 when coplanar. The generators' predicate.
int exact_orientation(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d);

// Closed convex genus-0 shapes (convex hulls of well-spread surface points: a spherical
// Fibonacci lattice, mapped linearly for the ellipsoid and by x_i = sign(u_i)|u_i|^(2/p) for
// the rounded cube). Vertex count = options.vertices unless rounding makes points non-extreme.
Mesh make_sphere(const ShapeOptions& options);
Mesh make_ellipsoid(double a, double b, double c, const ShapeOptions& options);
// Superellipsoid |x|^p + |y|^p + |z|^p = 1: p = 2 is the sphere, larger p rounds a cube
// (the Fig. 2 morph). Precondition: p >= 2.
Mesh make_rounded_cube(double exponent, const ShapeOptions& options);
// Torus with major radius R and minor radius r (thin: r/R small; thick: r/R near 1), around
// the z axis: a staggered (u, v) grid of near-equilateral triangles, nu x nv vertices.
Mesh make_torus(double major_radius, double minor_radius, const ShapeOptions& options);
// A unit sphere with a smooth inward dent of the given depth around +z (angular radius 0.7
// rad, C2 profile) (Fig. 4): concave in the middle, a saddle ring, convex elsewhere.
// Precondition: 0 <= dent_depth < 1.
Mesh make_dented_sphere(double dent_depth, const ShapeOptions& options);
// A closed genus-2 surface: two tori (R = 1, r = 0.4) centred at x = -1.15 and +1.15, fused
// by a C2 smooth minimum of their signed distances, polygonised by surface nets (vertices
// projected onto the surface), about options.vertices vertices.
Mesh make_genus2(const ShapeOptions& options);
// An open sheet with one boundary loop: an n x n grid of squares over the unit square, each cut
// into two triangles, over the height field z = 0.1 sin(6x) cos(5y).
Mesh make_wavy_sheet(int n);

// Sign structure of a surface's curvature at a point (kFlat: too close to parabolic to say).
enum class LocalShape { kConvex, kConcave, kSaddle, kFlat };
// make_genus2's surface near a point given in its unrotated frame (for tests).
LocalShape genus2_local_shape(const Vec3f& unrotated_point);

}  // namespace gaussmesh::testing
