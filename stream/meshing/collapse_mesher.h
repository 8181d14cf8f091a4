// The collapse mesher: the fallback beside the default polygon mesher (polygon_mesher.h), for
// the inputs and patches that the polygon mesher cannot triangulate by itself. It runs
//  - in core, on the whole input, when mesh_patch_polygons refuses it (its output would not be a
//    valid mesh): simplify_mesh then reports mesher_fallback and the reason;
//  - inside the polygon mesher, on the faces of one patch whose loops are simple in no plane;
//  - as the polygon mesher's last step (corners_only): the collapses of non-sample corners on
//    its output-sized mesh.
// Per-patch shape approximation (paper §5) by edge collapses on the input mesh itself: it builds
// the patch graph (corners, chains, patches), turns every chain into straight edges between
// kept vertices, triangulates every patch over its boundary, then removes non-sample corners by
// collapses that keep the mesh manifold and flip no face. docs/meshing.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "format/status.h"
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

// What the sampler tells the mesher about one input vertex.
enum class VertexRole : std::uint8_t {
  kNone = 0,    // not a candidate: removed
  kCorner = 1,  // candidate that is not a sample: a patch corner, removed last if possible
  kSample = 2,  // sample: always kept
  kGuard = 3,   // not a sample, but kept (topology guard, or a vertex the polygon mesher needed)
};

struct PatchMesherInput {
  MeshView mesh;
  // Patch id of every face (size = triangles). Faces with equal ids are one patch; a patch is
  // expected to be edge-connected, but the mesher does not rely on it.
  std::span<const std::uint32_t> face_patch;
  // Role of every vertex (size = positions).
  std::span<const VertexRole> vertex_role;
  // Optional: the plane normal to triangulate each patch in, indexed by patch id (the centre of
  // the patch's Gaussian triangle). Empty, or an id beyond it: the patch's mean face normal.
  std::span<const format::Vec3f> patch_plane_normal = {};
  // Phase 2 only: the mesh is already one triangulation per patch over kept vertices (the
  // polygon mesher's output); only kCorner vertices may go, by collapses along feature edges.
  bool corners_only = false;
};

// Counts of the patch graph the mesher built: corners, the chains between them, and patches
// bounded by chains.
struct PatchGraphStats {
  std::size_t feature_edges = 0;   // boundary, non-manifold, or between two patches
  std::size_t corners = 0;         // vertices where the feature graph branches, plus candidates on it
  std::size_t chains = 0;          // maximal feature-edge paths between corners
  std::size_t closed_loops = 0;    // feature loops with no corner at all
  std::size_t boundary_loops = 0;  // loops of boundary edges of the input
};

struct PatchMesherResult {
  Mesh mesh;  // positions are copies of input positions: never moved
  // Input vertex index of every output vertex ("birth index").
  std::vector<std::uint32_t> birth;
  PatchGraphStats graph;
  std::size_t kept_samples = 0;         // samples present in the output
  std::size_t kept_corners = 0;         // non-sample corners no legal collapse could remove
  std::size_t kept_chain_vertices = 0;  // chain vertices kept to preserve topology
  std::size_t kept_interior_vertices = 0;  // patch-interior vertices kept (no legal collapse)
  std::size_t skipped_input_faces = 0;  // degenerate or non-manifold faces the mesher could not use
  // Patches whose polygon was triangulated in its plane (stream/meshing/polygon_triangulation.h), and
  // those that kept the triangulation the collapses left (polygon not simple in its plane,
  // interior vertices left, or no triangulation without a duplicate edge).
  std::size_t planar_patches = 0;
  std::size_t collapse_patches = 0;
};

// Preconditions: face_patch.size() == mesh.triangles.size(), vertex_role.size() ==
// mesh.positions.size(), every index in range. Output: a manifold mesh with no degenerate or
// duplicate faces whose every vertex is an input vertex; a closed manifold input yields a
// closed manifold output of the same Euler characteristic. Memory: O(input) (OpenMesh).
// Errors: kProcessing if the preconditions do not hold.
format::Result<PatchMesherResult> mesh_patches_by_collapse(const PatchMesherInput& input);

}  // namespace gaussmesh::stream
