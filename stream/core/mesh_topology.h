// Topology statistics of an indexed triangle mesh (counts, boundaries, manifoldness, genus),
// computed on flat arrays in near-linear time; works on non-manifold and degenerate input.
#pragma once

#include <cstddef>
#include <optional>

#include "format/mesh_types.h"
#include "format/status.h"

namespace gaussmesh::stream {

// Definitions (docs/cli.md repeats them for `gaussmesh info`):
//  - A face whose three indices are not distinct is *degenerate*; it is counted and then left
//    out of every topological figure below. A face with distinct indices whose corners are
//    collinear or coincident (cross product exactly zero in double) is *zero-area*; it stays
//    in the topology (it is a valid combinatorial triangle).
//  - *Duplicate faces*: non-degenerate faces with the same vertex set as an earlier face, in
//    any order or orientation (extra copies only: two equal faces count 1).
//  - An *edge* is an unordered vertex pair joined by at least one non-degenerate face. It is a
//    *boundary edge* with one incident face, and *non-manifold* with more than two.
//  - The *fans* of a vertex: its incident faces, joined when they share an edge at the vertex
//    that has exactly two faces. A vertex is *non-manifold* when it lies on a non-manifold edge
//    or has more than one fan (e.g. two cones touching at their tips, a bow tie).
//  - *Boundary loops*: boundary edges joined when they meet at a vertex within one fan; on a
//    manifold mesh these are the usual boundary cycles, and a bow tie has two loops, not one.
//  - *Components*: vertex-connected sets of non-degenerate faces.
//  - χ = V − E + F with V the vertices of non-degenerate faces (unreferenced vertices do not
//    count), E the edges and F the non-degenerate faces.
//  - *Orientable*: the faces can be flipped so that every two-face edge is traversed in
//    opposite directions. Known only when there is no non-manifold edge.
//  - *Genus* g from χ = 2C − 2g − b (C components, b boundary loops), only for an orientable
//    mesh without non-manifold edges or vertices; absent otherwise.
struct MeshTopology {
  std::size_t vertices = 0;  // as delivered, referenced or not
  std::size_t faces = 0;     // triangles, degenerate ones included
  // Over all vertices; zero when there are none. diagonal = |max - min|.
  format::Vec3f bounds_min, bounds_max;
  double diagonal = 0;

  std::size_t unreferenced_vertices = 0;  // referenced by no face at all
  std::size_t degenerate_faces = 0;       // repeated index
  std::size_t zero_area_faces = 0;        // distinct indices, zero area
  std::size_t duplicate_faces = 0;

  std::size_t edges = 0;
  std::size_t boundary_edges = 0;
  std::size_t boundary_loops = 0;
  std::size_t non_manifold_edges = 0;
  std::size_t non_manifold_vertices = 0;
  std::size_t components = 0;
  long long euler_characteristic = 0;

  // Every two-face edge is traversed in opposite directions by its faces.
  bool consistently_oriented = true;
  std::optional<bool> orientable;  // empty when there are non-manifold edges
  std::optional<long long> genus;  // empty unless an orientable manifold (see above)

  bool is_manifold() const { return non_manifold_edges == 0 && non_manifold_vertices == 0; }
  bool is_closed() const { return boundary_edges == 0; }
};

// Analyses mesh. Memory: about 55 bytes per face and 26 per vertex, in a few flat arrays.
// Errors: kProcessing when a face refers to a vertex outside mesh.positions; kResources when
// the mesh has more than 2^32 / 3 - 1 faces (corner ids are 32-bit).
format::Result<MeshTopology> compute_topology(format::MeshView mesh);

}  // namespace gaussmesh::stream
