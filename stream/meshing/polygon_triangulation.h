// Triangulation of one planar polygon with holes, for the per-patch mesher (paper §5: "each
// patch polygon is triangulated in the plane of its Gaussian triangle"): projection onto the
// plane, exact 2D orientation predicates, holes joined by verified bridges, best-shape ear
// clipping on the resulting weakly simple polygon, then Delaunay edge flips. The result is a
// pure function of the inputs (no hash or pointer order), so the same patch is triangulated
// identically in core and out of core.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "format/status.h"

namespace gaussmesh::stream {

using PolygonPoint3 = std::array<double, 3>;
using PolygonPoint2 = std::array<double, 2>;
using PolygonTriangle = std::array<std::uint32_t, 3>;

// forbidden(u, v), called with u < v (point indices): true when {u, v} must not become a new
// edge (a diagonal or a hole bridge). Polygon boundary edges are never asked about. An empty
// function forbids nothing.
using ForbiddenEdge = std::function<bool(std::uint32_t, std::uint32_t)>;

// Exact sign (-1, 0, +1) of the 2D orientation of (a, b, c): +1 when c lies to the left of the
// directed line a -> b (counter-clockwise turn). Exact for all finite doubles (CGAL's filtered
// predicate, LGPL kernel).
int orientation_2d(const PolygonPoint2& a, const PolygonPoint2& b, const PolygonPoint2& c);

// The plane coordinates triangulate_polygon works in: (p - origin) expressed in an orthonormal
// frame (u, v) with u x v = normal / |normal|, so counter-clockwise in 2D is counter-clockwise
// seen from the tip of `normal`. The frame is a fixed function of `normal` alone.
// Precondition: normal is finite and non-zero (asserted).
std::vector<PolygonPoint2> project_to_plane(std::span<const PolygonPoint3> points,
                                            const PolygonPoint3& normal, const PolygonPoint3& origin);
// The same into `out` (resized to points.size()), for callers that reuse one buffer.
void project_to_plane(std::span<const PolygonPoint3> points, const PolygonPoint3& normal,
                      const PolygonPoint3& origin, std::vector<PolygonPoint2>& out);

// Triangulates the polygon whose boundary loops index into `points`.
//
// loops[0] is the outer boundary, loops[1..] are holes; each loop is a cyclic list of point
// indices without a repeated closing index. Loop orientation is not trusted: the outer loop is
// made counter-clockwise and holes clockwise as seen from `normal` (pointing at the viewer).
// A loop may pass through one point twice (touching itself), and a hole may touch the outer
// loop or another hole at a vertex; collinear consecutive vertices are kept as real vertices.
// Points are projected with project_to_plane(points, normal, points[loops[0][0]]); every
// combinatorial decision is an exact predicate on those projected doubles.
//
// Returns triangles as indices into `points`, each strictly counter-clockwise (exactly, in the
// projected coordinates), using only loop vertices (no Steiner points). For n loop vertices
// (a repeated point counted each time it appears) and h holes there are exactly n + 2h - 2
// triangles when no loops touch; every hole that shares a vertex with another loop, and every
// loop pinch that splits the polygon, has 2 fewer. Every loop edge is in exactly one triangle,
// every new edge in exactly two; no new edge is forbidden or duplicates an existing one.
//
// Errors (code kProcessing, where "polygon triangulation"): bad arguments (no loop, a loop
// with fewer than 3 vertices, an index out of range, non-finite coordinates or normal), a
// zero-length edge, loops that cross or overlap in the projection, a hole that cannot be
// joined (outside the outer loop, or every bridge forbidden), or no valid ear left (degenerate
// remainder, or every remaining ear would need a forbidden or duplicate edge). The caller is
// expected to have a fallback. Work is bounded: O(n^2) time worst case, O(n) memory.
format::Result<std::vector<PolygonTriangle>> triangulate_polygon(
    std::span<const PolygonPoint3> points, std::span<const std::vector<std::uint32_t>> loops,
    const PolygonPoint3& normal, const ForbiddenEdge& forbidden = {});

// The same on points already in the plane (counter-clockwise = positive orientation_2d).
format::Result<std::vector<PolygonTriangle>> triangulate_polygon_2d(
    std::span<const PolygonPoint2> points, std::span<const std::vector<std::uint32_t>> loops,
    const ForbiddenEdge& forbidden = {});

// Scratch buffers for triangulating many polygons one after the other (one workspace per
// thread): once they have grown, a small polygon costs no allocation. Holds no result.
class PolygonWorkspace {
 public:
  PolygonWorkspace();
  ~PolygonWorkspace();
  PolygonWorkspace(const PolygonWorkspace&) = delete;
  PolygonWorkspace& operator=(const PolygonWorkspace&) = delete;
  struct Buffers;  // defined in polygon_triangulation.cpp
  Buffers& buffers() { return *buffers_; }

 private:
  std::unique_ptr<Buffers> buffers_;
};

// triangulate_polygon_2d with a workspace: the triangles (the same, in the same order) replace
// the contents of `triangles`; on an error `triangles` holds no meaningful result.
format::Status triangulate_polygon_2d(std::span<const PolygonPoint2> points,
                                      std::span<const std::vector<std::uint32_t>> loops,
                                      const ForbiddenEdge& forbidden, PolygonWorkspace& workspace,
                                      std::vector<PolygonTriangle>& triangles);

}  // namespace gaussmesh::stream
