// Vertex attributes of a simplified mesh, taken from its input: every output vertex gets the
// values of the nearest point of the input's surface (docs/attributes.md).
#pragma once

#include <array>
#include <cstdint>
#include <algorithm>
#include <functional>
#include <limits>
#include <span>

#include "format/mesh_sink.h"
#include "format/mesh_types.h"
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

// What becomes of normals: interpolated from the input's (none when it has none), computed from
// the output's faces, or left out.
enum class NormalsMode { kKeep, kCompute, kNone };

// Fills output's colours and texture coordinates when the input has them, and its normals by
// `normals`. Each output vertex takes the input triangle nearest to it (the lowest index among
// equally near ones) and the corner values of that triangle interpolated at the nearest point
// (barycentric), so an output vertex that is an input vertex keeps that vertex's values, and a
// moved one gets the values of the surface under it; interpolated normals are renormalised.
// Computed normals are the area-weighted sums of the output's face normals, normalised. The
// search is a pass over the input's triangles against a grid of the output's vertices, so it
// holds memory of the output's size only (about 40 bytes a vertex) and the same answer comes
// whatever the order of the triangles or the threads.
void transfer_attributes(format::MeshView input, Mesh& output, NormalsMode normals);

// The values of input triangle t (corners: vertices of `input`) at its point nearest to p,
// interpolated (barycentric) and rounded once; normals renormalised. The kinds say which to take.
format::VertexAttributes values_at(format::MeshView input, const Triangle& t, const Vec3f& p,
                                   const format::AttributeKinds& kinds);
// Writes `values` (one per vertex of output) into output's arrays: the kinds given, normals by
// `normals` (kCompute: from output's faces).
void assign_attributes(const std::vector<format::VertexAttributes>& values, const format::AttributeKinds& kinds,
                       NormalsMode normals, Mesh& output);

// The input as batches of vertices with their attributes, in input order: a call streams it
// once through `batch`, stopping at the first error either returns.
using VertexBatchFn = std::function<format::Status(std::span<const format::Vec3f>, std::span<const format::VertexAttributes>)>;
using VertexPassFn = std::function<format::Status(const VertexBatchFn& batch)>;

// An axis-aligned box of positions; empty (lo above hi) until a position is added.
struct PositionBox {
  format::Vec3f lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                   std::numeric_limits<float>::infinity()};
  format::Vec3f hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                   -std::numeric_limits<float>::infinity()};
  void add(const format::Vec3f& p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  // Whether the two boxes share a point (never when either is empty).
  bool meets(const PositionBox& o) const {
    return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y && lo.z <= o.hi.z && o.lo.z <= hi.z;
  }
};
// A pass over at least the input vertices inside a box (whole frames of the spill that lie
// outside it may be left out), as VertexPassFn otherwise.
using NearVertexPassFn = std::function<format::Status(const PositionBox& near, const VertexBatchFn& batch)>;

// The same for an input that is streamed, not held (out of core): each output vertex takes the
// attributes of the nearest input vertex (the first in input order among equally near ones),
// so an output vertex that is an input vertex keeps that vertex's values, and a moved one gets
// those of the input vertex nearest to it. `kinds` are the input's; `pass` is called once per
// search round (each round doubles the radius for the vertices still without an input vertex
// within it; the first round finds every vertex that lies on an input vertex). Memory: the
// output's size.
format::Status transfer_nearest_vertex(const VertexPassFn& pass, const format::AttributeKinds& kinds, Mesh& output,
                                       NormalsMode normals);

// The search of transfer_nearest_vertex for an output held as positions only (its faces stream,
// out of core): each vertex's values from the nearest input vertex, normals unit length. `area`,
// the output's surface area (surface_area), sizes the search grid. With `left`, only the first
// round: the vertices it found get their values, the others are listed in `left` (one pass over
// the input, which finds all but a few of an output's vertices).
format::Result<std::vector<format::VertexAttributes>> nearest_vertex_values(const VertexPassFn& pass,
                                                                            const std::vector<format::Vec3f>& positions,
                                                                            double area,
                                                                            std::vector<std::uint32_t>* left = nullptr);
// The side of the search grid's cells for `count` output vertices over `area` (about their
// spacing); the first round's radius is a quarter of it.
double search_cell(std::uint64_t count, double area);
// What that search holds per output vertex at its peak, with the vertex's position: the position
// (12 B), its values (36 B), the best distance (8 B) and the grid as it is built (up to 64 B:
// the vertices keyed by cell, then the cells' table at up to four slots a cell, when every vertex
// has a cell of its own).
inline constexpr std::uint64_t kNearestValuesBytesPerVertex = 12 + 36 + 8 + 64;
// An input triangle as an out-of-core pass gives it: its corners' positions and its index in the
// input (the lowest index wins among equally near triangles).
struct IndexedTriangle {
  std::array<format::Vec3f, 3> corners;
  std::uint64_t index = 0;
};
// Streams the input's triangles once through `batch`, which it may call from several threads at
// once; stops at the first error either returns.
using TriangleBatchFn = std::function<format::Status(std::span<const IndexedTriangle>)>;
using TrianglePassFn = std::function<format::Status(const TriangleBatchFn& batch)>;

// transfer_attributes for an input that is streamed, not held (out of core), for an output held
// as positions: each vertex takes its nearest input triangle from passes of `triangles` (one per
// search round, as transfer_attributes' rounds), then the corners' values from one pass of
// `vertices`, each corner from the first input vertex at its exact position (±0 alike), and the
// values at its nearest point of that triangle, interpolated as values_at does. So the values are
// transfer_attributes' whenever no two input vertices share a position with different values and
// the triangles' indices are the input's. `area` (surface_area) sizes the search grid. Memory:
// kSurfaceValuesBytesPerVertex per output vertex, beside `positions`. A corner found at no
// input vertex is kProcessing.
format::Result<std::vector<format::VertexAttributes>> surface_values(const TrianglePassFn& triangles,
                                                                     const VertexPassFn& vertices,
                                                                     const format::AttributeKinds& kinds,
                                                                     const std::vector<format::Vec3f>& positions,
                                                                     double area);
// What surface_values holds per output vertex at its peak, the pass over the input's vertices:
// the winning triangle's corners (36 B) and their values (108 B), the corners' lookup by
// position (entries, ranges and table: up to 112 B), whether it found a triangle (1 B).
inline constexpr std::uint64_t kSurfaceValuesBytesPerVertex = 36 + 108 + 112 + 1;

double surface_area(const std::vector<format::Vec3f>& positions, std::span<const format::Triangle> triangles);
// vertex_normals for faces that stream: each face's area-weighted normal added to its corners'
// `normal` (in float, in face order); normalise_normals once every face has been added.
void add_face_normals(const std::vector<format::Vec3f>& positions, std::span<const format::Triangle> faces,
                      std::vector<format::VertexAttributes>& values);
void normalise_normals(std::vector<format::VertexAttributes>& values);

// Area-weighted vertex normals of a mesh, normalised ((0, 0, 1) for a vertex without area).
std::vector<format::Vec3f> vertex_normals(format::MeshView mesh);

}  // namespace gaussmesh::stream
