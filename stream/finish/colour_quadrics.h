// Colour as a feature of the quadric finish (docs/attributes.md, "Colour edges"): beside the
// planes of the faces, each vertex carries the colour ramps of the faces it absorbs, so that a
// collapse joining regions whose colours no single ramp fits (the two sides of a colour edge)
// costs, and one within a ramp does not.
#pragma once

#include <span>
#include <vector>

#include "stream/core/mesh.h"
#include "stream/finish/quadric.h"

namespace gaussmesh::stream {

// The colour terms of the faces of `coloured` (positions, faces and per-vertex colours) for the
// vertices of `mesh` at the same positions (a corner with none is left out), in `frame` units:
// over each face the colour is a linear ramp g·x + d per channel (red, green, blue), of weight
// `weight` × the face's area, capped at 64 × weight × the face's colour range² in all (a sliver's
// steep ramp cannot dominate). Each corner gets Σ s (g·x + d)² in `quadrics` (fixed point, added
// to its planes) and the sums of ColourSum in `sums` (quadric.h): together, the squared colour
// error of the best colour for all the faces a vertex absorbs, which the collapses count beside
// the distance to the planes.
struct ColourTerms {
  std::vector<FixedQuadric> quadrics;
  std::vector<ColourSum> sums;
};
ColourTerms colour_quadrics(MeshView coloured, MeshView mesh, const QuadricFrame& frame, double weight);

}  // namespace gaussmesh::stream
