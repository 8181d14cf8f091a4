// Shape approximation, polygon first (paper §5; docs/meshing.md): the
// per-patch mesher whose output is a pure function of the patch graph — kept vertices, patch
// boundary loops, plane normals — so that the out-of-core stitch, which sees records and never
// the input mesh, can reach the same triangles.
//
//   1. patch boundary loops are walked on the input (feature edges: patch borders and breaks);
//   2. kept vertices = samples ∪ corners (role kCorner, feature degree 1 or >= 3, boundary
//      turns > 30°) ∪ guards chosen by canonical rules on the chains between them (a closed
//      loop keeps 3 vertices spread from its lowest id, a loop through one corner 2 more, and
//      each of several chains joining the same two corners its middle vertex);
//   3. each patch's loops, reduced to kept vertices, are triangulated in the plane of its
//      Gaussian triangle (stream/meshing/polygon_triangulation.h) — else in the plane of its
//      mean normal —, patches in id order, never making an edge that already exists; samples
//      inside a patch are inserted into its triangulation;
//   4. a patch that cannot be triangulated gets the middle vertex of every stretch of its loops
//      between kept vertices (so do its neighbours along the shared chains), up to 6 times,
//      and the whole triangulation is redone each time; one that still fails is meshed by the
//      collapse mesher on its own faces (kept loop vertices fixed), then — failing that — keeps
//      every vertex of its loops, then its input triangles (all its vertices);
//   5. non-sample corners are removed by collapses along feature edges on the output-sized mesh
//      (stream/meshing/collapse_mesher.h, corners_only).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "format/status.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/meshing/collapse_mesher.h"

namespace gaussmesh::stream {

struct PolygonMesherStats {
  std::size_t rounds = 0;             // triangulation rounds (1 when no patch had to be densified)
  std::size_t mean_plane_patches = 0;  // triangulated in the plane of their mean normal instead
  std::size_t refined_patches = 0;    // patches whose loops got middle vertices to triangulate
  std::size_t densified_patches = 0;  // patches that kept every vertex of their loops
  std::size_t collapsed_patches = 0;  // patches meshed by collapses on their own faces
  std::size_t original_patches = 0;   // patches that kept their input triangles
  std::size_t interior_samples = 0;   // samples inside a patch (inserted into its triangulation)
  std::size_t guards = 0;             // vertices kept by the chain rules and by refinement
};

// Whether a boundary turns by more than 30° at `at` (coming from prev, going to next): such a
// boundary vertex is a corner (normals cannot see how a boundary curves within its surface).
bool turns_at_boundary(const format::Vec3f& prev, const format::Vec3f& at, const format::Vec3f& next);

// The input faces the mesher leaves out, as the collapse mesher does: collapsed faces (a
// repeated index), and repeats of an earlier face's vertex set (which would make their edges
// non-manifold). any_repeat (optional): whether there was a repeat. Its adjacency is the mesh's
// with those faces collapsed (in no star). adjacency is the whole mesh's (build_mesh_adjacency):
// two faces on one vertex set meet across a break edge or across each other, so only faces
// with a break edge or a neighbour on their own vertex set are compared.
std::vector<std::uint8_t> faces_the_mesher_skips(std::span<const format::Triangle> triangles,
                                                 const MeshAdjacency& adjacency, bool* any_repeat = nullptr);

// The half-edge after (f, i) on a loop: turn around its end vertex through the faces across
// edges that are not on the loop until a half-edge leaving it is (is_on_loop(g, j)); a patch's
// border loops and the input's break loops are both walked this way. {kNoFace, 0} when the
// star gives none.
template <class IsOnLoop>
std::pair<std::uint32_t, int> next_loop_half_edge(const MeshAdjacency& adjacency, const format::Triangle* tris,
                                                  std::uint32_t f, int i, IsOnLoop&& is_on_loop) {
  const std::uint32_t b = tris[f].v[(i + 1) % 3];
  std::uint32_t g = f;
  int j = (i + 1) % 3;
  const std::size_t bound = adjacency.star_end(b) - adjacency.star_begin(b) + 2;
  for (std::size_t step = 0; step < bound; ++step) {
    if (is_on_loop(g, j)) return {g, j};
    const std::uint32_t h = adjacency.edge_neighbor[3 * std::size_t{g} + j];
    int k = 0;
    while (k < 3 && tris[h].v[k] != b) ++k;
    if (k == 3) break;
    g = h;
    j = k;
  }
  return {MeshAdjacency::kNoFace, 0};
}

struct PolygonMesherResult {
  PatchMesherResult mesh;  // planar_patches: triangulated in their plane; collapse_patches: 0
  PolygonMesherStats stats;
  // mesh_patch_loops only: patches that need their input faces (the collapse / original steps)
  // and were given none. When not empty, `mesh` is empty: fetch those patches' faces into
  // PolygonGraphInput::patch_faces and run again.
  std::vector<std::uint32_t> needs_faces;
};

// The default mesher. Same input and preconditions as mesh_patches_by_collapse (patch ids are
// expected to be the sampler's: edge-connected, numbered by lowest face). Output: a manifold
// mesh with no degenerate or duplicate faces whose vertices are input vertices; a closed
// manifold input gives a closed manifold output of the same Euler characteristic. Memory:
// O(patch boundaries + output) on top of the input's adjacency. Errors: kProcessing when the
// preconditions do not hold, or when the result would not be a valid mesh (the caller may fall
// back to mesh_patches_by_collapse).
format::Result<PolygonMesherResult> mesh_patch_polygons(const PatchMesherInput& input);

// The same mesher fed from records (the out-of-core stitch): what mesh_patch_polygons builds
// from the mesh in its steps 1-2, given instead. Vertex ids are dense (0 .. positions - 1) and
// must be numbered in increasing input id (the canonical rules compare ids); `global` maps them
// back to input ids for the output's birth indices (empty: they are input ids).
struct PatchLoop {
  std::uint32_t patch = 0;
  std::vector<std::uint32_t> vertices;  // the loop's half-edges' start vertices, patch on the left
  std::vector<std::uint8_t> is_break;   // per half-edge: a break edge (boundary, non-manifold); may be empty
};
// A patch's input faces (non-collapsed, ascending global face id), in the graph's vertex ids.
struct PatchFaces {
  std::uint32_t patch = 0;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};
// Positions of a graph's vertices fetched on demand (out of core: from a file the stitch wrote),
// so the mesher holds positions only for the vertices it uses. A read that fails returns a zero
// position and sets failed(); the mesher then ends with the source's error.
class VertexPositionSource {
 public:
  virtual ~VertexPositionSource() = default;
  virtual format::Vec3f position(std::uint32_t v) = 0;
  // The positions of `ids` (ascending, no repeats) into `out` (out.size() == ids.size()), as
  // position() gives them one by one, which is what this default does. The mesher asks for each
  // round's new vertices this way: a source that reads a file should read the ranges they fall
  // in with a few large reads (one read per vertex costs a system call each).
  virtual void positions(std::span<const std::uint32_t> ids, std::span<format::Vec3f> out) {
    for (std::size_t i = 0; i < ids.size() && i < out.size(); ++i) out[i] = position(ids[i]);
  }
  virtual format::Status status() const = 0;
};

// The loops of a graph kept in a file (out of core: the loop stitch writes them), read one loop
// at a time, so the mesher holds the loops' kept vertices and never all their vertices. A read
// that fails returns false; the mesher then ends with the source's error.
class LoopVertexSource {
 public:
  virtual ~LoopVertexSource() = default;
  // Entries first .. first + out.size() - 1 of the file (one vertex id each) into out.
  virtual bool read(std::uint64_t first, std::span<std::uint32_t> out) = 0;
  virtual format::Status status() const = 0;
};

struct PolygonGraphInput {
  // Every vertex a loop or a sample names: in memory, or (positions empty) from position_source.
  std::vector<format::Vec3f> positions;
  std::shared_ptr<VertexPositionSource> position_source;
  std::size_t vertex_count = 0;  // with position_source: the number of vertices
  std::vector<std::uint32_t> global;
  std::size_t patches = 0;
  // Loops of every patch, patches in id order, each patch's loops in walk order: a loop starts
  // at the lowest unwalked half-edge id (3 × face + edge) of its patch.
  std::vector<PatchLoop> loops;
  // Or (loops empty) in loop_source: loop l, of patch loop_patch[l], is its entries
  // loop_offset[l] .. loop_offset[l + 1] - 1, in the order loops would have; no break flags.
  std::shared_ptr<LoopVertexSource> loop_source;
  std::vector<std::uint32_t> loop_patch;
  std::vector<std::uint64_t> loop_offset;
  // Distinct feature edges per vertex. May be empty: then every loop vertex with a degree other
  // than 2 must have role kCorner, and graph.corners must be given.
  std::vector<std::uint32_t> degree;
  // kSample, kCorner (a candidate after the merge, feature degree 1 or >= 3, or a boundary turn
  // of more than 30°), or kNone; per vertex.
  std::vector<VertexRole> role;
  std::vector<std::vector<std::uint32_t>> interior_samples;  // per patch, ascending: samples off every feature edge
  std::vector<format::Vec3f> plane_normal;                    // per patch; zero: use patch_area
  std::vector<std::array<double, 3>> patch_area;              // per patch: sum of its faces' cross products
  std::vector<std::uint8_t> patch_has_faces;  // per patch: it has a face that is not collapsed (else it is skipped)
  PatchGraphStats graph;                                      // feature edges, chains, loops (for the report)
  std::vector<PatchFaces> patch_faces;                         // fetched after a needs_faces answer
};

// Steps 3-5 of mesh_patch_polygons on records. A patch that reaches the steps needing its input
// faces (the collapse and original steps) without them ends the run with needs_faces set.
// Memory with loop_source and position_source: one byte per vertex (what it keeps), the longest
// loop, and the output-sized tables of the rounds (kept loop vertices, edges made, positions used).
// Takes graph by value: its loops are moved into the mesher.
format::Result<PolygonMesherResult> mesh_patch_loops(PolygonGraphInput graph);

}  // namespace gaussmesh::stream
