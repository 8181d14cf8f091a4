// The second half of the quadric finish: QEM edge collapses on the Gauss approximation, each
// vertex carrying the plane quadrics of the input faces it absorbed (face_quadrics.h), until the
// face target or the error bound is reached.
//
// Every collapse keeps the topology guarantee of the approximation: it passes the link
// condition (collapse_mesh.h), so a closed manifold of genus g stays one; it flips no
// remaining face (a face may turn by at most kMaxTurnDegrees, or kRelaxedTurnDegrees when the
// target cannot be reached otherwise) and makes none degenerate. The kept
// vertex moves to the point that minimises the summed quadric (the samples are then no longer
// input vertices), or when the quadric cannot place it to the best of the edge's ends, its
// midpoint and its least point along the edge.
// A collapse costs the geometric mean of the merged region's mean squared distance there and the
// worse of its two ends' own (quadric_decimation.cpp, collapse_cost).
// Boundary edges carry constraint planes at right angles to the surface, so rims stay in place.
// Deterministic: collapses go in (cost, edge number) order on data that is the same bits in and
// out of core. The mesh is copied in spatial order first (vertices by the Morton code of their
// position, faces by their corners' new numbers, edges in the order the faces first meet them),
// so the collapses depend on the surface and not on the input's vertex ids or face order; a
// collapse keeps the end that comes first in that order (or the locked one).
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "format/status.h"
#include "stream/core/mesh.h"
#include "stream/finish/quadric.h"

namespace gaussmesh::stream {

struct DecimationOptions {
  std::uint64_t target_faces = 0;  // stop at this many faces or fewer; 0: no face target
  // No collapse whose estimated error (decimation_error) passes this, in the frame's units (a
  // fraction of the approximation's bounding-box diagonal); infinity: no bound.
  double max_error = std::numeric_limits<double>::infinity();
  // One flag per vertex (empty: none locked). A locked vertex keeps its place: an edge between
  // two locked vertices is never collapsed, one with a locked end collapses onto it, and only
  // when no other locked vertex beside the free end could be joined to it outside this mesh
  // (the chunked finish locks what its piece shares with others, whose faces it cannot see).
  std::span<const std::uint8_t> locked;
  // Add constraint planes along the boundary edges; false when the quadrics already hold them
  // (the chunked finish adds them where it knows an edge is on the input's boundary).
  bool boundary_constraints = true;
  // Short of the target with every collapse refused, allow turns up to kRelaxedTurnDegrees for
  // the rest. The chunked finish does not: a piece short of its share leaves the rest to the
  // next round or to the other pieces rather than fold its faces.
  bool relax_turn_limit = true;
  // Before the queue, sweeps of cheap collapses bring the mesh down to this many faces (0, or
  // not above target_faces: none). A sweep moves each free vertex onto the neighbour where its
  // quadric and the neighbour's add up least, cheapest first, up to kSweepSlack × the cost of the
  // last collapse still needed, with no vertex taking two in one sweep: no minimiser to solve and
  // no queue to update, at the price of keeping input positions. For the first reductions of a
  // large input, which the queue then refines (docs/finish.md).
  std::uint64_t sweep_to_faces = 0;
  // Seams (empty: none): per face corner (three per face), which of its vertex's values it takes
  // (a wedge: texture coordinates, normals, colours; stream/attributes/seams.h). An edge whose
  // two faces take different wedges at an end is a seam, and seams are kept: a vertex with two
  // wedges on one seam (two seam edges, no boundary) stays where it is and goes only along its
  // seam; one with more wedges, or on a seam and a boundary, is fixed; a vertex with one wedge
  // collapses like any other, but not along a seam edge, and onto a vertex with more wedges only
  // to its place; an edge that is not a seam and joins two vertices with several wedges is not
  // collapsed. Seam edges carry constraint planes like boundary edges. So every output face lies
  // on one side of every seam, and vertices with several wedges keep their input positions.
  std::span<const std::uint32_t> corner_wedges;
  // Colour terms (empty: none), one per vertex (colour_quadrics.h): a collapse's quadric is then
  // ColourSum::effective of the ends' sums, so that the colour error of the merged region counts
  // beside its distance.
  std::span<const ColourSum> colours;
};

// Where sweeps go (sweep_goal): to kSweepShare × the face target, and only when that is at most
// half of the faces. At 1 % of the input they did better than the queue alone on most fixtures
// and on the refined cow, and they bring the cost of the bulk of the collapses down; at 10 %
// (a goal of 80 %) they gained little time and lost on fandisk and homer (docs/finish.md).
inline constexpr double kSweepShare = 8;
inline constexpr double kSweepMaxShareOfFaces = 0.5;
// The sweep goal for `faces` faces collapsed towards `target` (0: no sweeps): a target share of
// the faces (target / faces) times kSweepShare, when that is at most kSweepMaxShareOfFaces.
double sweep_share_of_faces(std::uint64_t faces, std::uint64_t target);

// A sweep takes collapses up to kSweepSlack × the cost of the last one it would need if none were
// refused or blocked by another (about half are, most by a neighbour's collapse in the same
// sweep); sweeps end when the faces above the goal are under kSweepRest of the mesh.
inline constexpr double kSweepSlack = 3;
inline constexpr double kSweepRest = 0.1;

struct DecimationResult {
  Mesh mesh;
  std::uint64_t collapses = 0;
  std::uint64_t swept = 0;       // of the collapses, those the sweeps made (sweep_to_faces)
  std::uint64_t refused = 0;     // collapses refused by the link condition or the geometry tests
  std::uint64_t over_error = 0;  // collapses left out for passing max_error
  double estimated_error = 0;    // largest decimation_error of a collapse made (frame units)
  bool reached_target = false;   // the face target was met (or there was none)
  std::vector<std::uint32_t> source;  // per output vertex: its vertex in the input mesh
  std::vector<Quadric> quadrics;      // per output vertex: its summed quadric (frame units)
  // With seams (DecimationOptions::corner_wedges): per output face corner its wedge, and per
  // input vertex the output vertex it was collapsed into (itself when it survives).
  std::vector<std::uint32_t> corner_wedges;
  std::vector<std::uint32_t> region;
};

// The estimated error of a vertex with quadric q at p: the root of the mean squared distance from
// p to the planes of the input faces it absorbed, sqrt(E(p) / weight). An estimate, not a bound:
// a Hausdorff distance can be larger (docs/finish.md).
double decimation_error(const Quadric& q, const Vec3dq& p);

// A collapse may turn a remaining face by at most kMaxTurnDegrees; when that leaves the face
// target out of reach, the rest of the run allows up to kRelaxedTurnDegrees (no face flips).
inline constexpr double kMaxTurnDegrees = 60;
inline constexpr double kRelaxedTurnDegrees = 89;

// The constraint plane of boundary edge a → b of a face with normal n (any length): through the
// edge, at right angles to the face, weighing kBoundaryWeight per squared edge length, with no
// surface weight (it does not dilute the mean distance). Zero for a degenerate edge or face.
inline constexpr double kBoundaryWeight = 1;
Quadric boundary_constraint(const Vec3dq& a, const Vec3dq& b, const Vec3dq& n);

// `sums` holds one fixed-point quadric per vertex of `approximation`, in `frame`.
// Errors: kProcessing when the approximation is not an oriented manifold (CollapseMesh::build).
format::Result<DecimationResult> decimate(MeshView approximation, const std::vector<FixedQuadric>& sums,
                                          const QuadricFrame& frame, const DecimationOptions& options);
// The same with the quadrics in double form.
format::Result<DecimationResult> decimate(MeshView mesh, std::vector<Quadric> quadrics, const QuadricFrame& frame,
                                          const DecimationOptions& options);

}  // namespace gaussmesh::stream
