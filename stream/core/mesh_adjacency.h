// Compact mesh adjacency for the sampler (paper §4: every per-vertex decision reads the 1-ring):
// vertex stars in fan order and the face across each edge, built from flat arrays with no
// hash maps. Handles boundaries, non-manifold edges and vertices, and collapsed faces.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"

namespace gaussmesh::stream {

// Decisions recorded by the adjacency (docs/sampling.md, "Mesh defects"):
// - A corner is 3 f + i: vertex i of face f. Edge i of face f runs (v[i], v[i+1 mod 3]).
// - An edge is *manifold* when exactly two faces hold it, with opposite directions. Every other
//   edge (boundary: one face; non-manifold: three or more; or two faces that disagree on
//   orientation) is a *break*: its faces get kNoFace across it, and the sampler treats it as a
//   feature edge, like the paper treats boundaries (Fig. 19).
// - A *collapsed* face (a repeated vertex index) is left out of every star: it has no area and
//   no fan position; its edges are not counted for its neighbours.
// - The faces around a vertex are split by break edges into *fans*, each ordered
//   counter-clockwise (next face = the one across edge (prev, v)). A vertex with one closed fan
//   is interior, with one open fan is on a boundary, with several fans is non-manifold: the
//   sampler handles each fan on its own. In an open fan the first slot's outgoing edge and the
//   last slot's incoming edge are breaks, and no other edge of the fan is: a vertex has as many
//   break edges leaving it, and as many arriving, as it has open fans (the sampler counts them
//   from slot_flags).
struct MeshAdjacency {
  static constexpr std::uint32_t kNoFace = 0xFFFFFFFFu;
  static constexpr std::uint8_t kFanStart = 1;   // this slot starts a fan
  static constexpr std::uint8_t kFanClosed = 2;  // (on a start slot) the fan is a closed cycle

  // Star of vertex v: corners vertex_corners[vertex_offsets[v] .. vertex_offsets[v+1]), fans
  // contiguous, each in counter-clockwise order; slot_flags is parallel to vertex_corners.
  std::vector<std::uint32_t> vertex_offsets;  // vertex count + 1
  std::vector<std::uint32_t> vertex_corners;
  std::vector<std::uint8_t> slot_flags;
  // Face across edge i of face f, at 3 f + i; kNoFace for break edges and collapsed faces.
  std::vector<std::uint32_t> edge_neighbor;
  std::size_t collapsed_faces = 0;
  std::size_t break_edges = 0;  // directed: a boundary edge counts once, a non-manifold k times

  std::size_t vertex_count() const { return vertex_offsets.empty() ? 0 : vertex_offsets.size() - 1; }
  std::uint32_t star_begin(std::uint32_t v) const { return vertex_offsets[v]; }
  std::uint32_t star_end(std::uint32_t v) const { return vertex_offsets[v + 1]; }
};

// Builds the adjacency of mesh. Memory: 4 (V + 1) + 9 × 3 F bytes (plus per-thread scratch
// of a few star sizes).
// Errors: kBadInput when a triangle refers to a vertex index >= positions.size() (naming the
// face); kResources when 3 F does not fit 32-bit corner ids.
format::Result<MeshAdjacency> build_mesh_adjacency(format::MeshView mesh);

// The same into `out`, reusing its arrays' capacity (a chunk loop keeps one MeshAdjacency per
// thread: refilling warm memory is several times faster than first-touching new pages). Runs
// the per-vertex pass in parallel (oneTBB) with results independent of the thread count. On
// error `out` holds no usable adjacency.
format::Status build_mesh_adjacency(format::MeshView mesh, MeshAdjacency& out);

}  // namespace gaussmesh::stream
