// Seams of an input whose vertices are split where their values differ: a texture seam (two
// texture coordinates at one position), a hard edge (two normals), a colour edge. The collapses
// run on the surface welded by position, each face corner remembering which of its vertex's
// values (its wedge) it takes, so that seams are kept (DecimationOptions::corner_wedges); the
// output is split again at the seams it kept (docs/attributes.md, "Seams").
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "stream/attributes/attribute_transfer.h"
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

struct Seams {
  // The input welded by exact position: a vertex per distinct position its faces use, numbered
  // in input order; its faces in input order, those with a repeated corner once welded left out.
  Mesh welded;
  std::vector<std::uint32_t> corner_wedges;  // per face corner of `welded`: its wedge
  // Per wedge: an input vertex with its position and values (the first in input order).
  std::vector<std::uint32_t> wedge_vertex;
  std::uint64_t seam_vertices = 0;  // welded vertices with more than one wedge
};

// The seams of `input` (its positions, faces and per-vertex values): nullopt when no position
// has two different values, so that there is nothing to keep (the input is then simplified as
// it is).
std::optional<Seams> find_seams(MeshView input);

// The output of collapsing seams.welded (`welded_output`: its faces in output order, with
// `corner_wedges` per face corner, `source` per vertex its welded input vertex, `region` per
// welded input vertex its output vertex) split at the seams: a vertex per (output vertex, wedge)
// its faces use. A vertex at its input place keeps its wedge's values exactly; a moved one takes
// the values of the nearest input face found by walking, across edges that are not seams, from
// the nearest face around the vertices it absorbed: the surface under it, on its side of every
// seam. Normals by `normals`. A vertex whose wedge has two fans of faces
// gets a copy per fan.
Mesh split_at_seams(MeshView input, const Seams& seams, const Mesh& welded_output,
                    const std::vector<std::uint32_t>& corner_wedges, const std::vector<std::uint32_t>& source,
                    const std::vector<std::uint32_t>& region, NormalsMode normals);

}  // namespace gaussmesh::stream
