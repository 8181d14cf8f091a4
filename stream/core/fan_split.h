// Splits the vertices of a non-manifold mesh so that every face can be kept: each fan of faces
// around a vertex (MeshAdjacency's fans: faces joined across manifold edges) gets a vertex of its
// own. A bow tie's shared vertex becomes two, a fin's face comes loose from the edge it shared
// with two others, two faces that disagree on an edge's orientation come apart along it. The
// in-core engine's non-manifold policy (docs/cli.md, "Non-manifold input").
#pragma once

#include <cstddef>

#include "format/status.h"
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

struct FanSplit {
  std::size_t split_vertices = 0;  // vertices with more than one fan
  std::size_t added_vertices = 0;  // copies made: one per fan after a vertex's first
};

// Gives every fan after the first of each vertex a copy of the vertex (position and attributes,
// appended in vertex order, fans in the order MeshAdjacency lists them) and points the fan's
// corners at it. Faces with a repeated corner are left as they are. A mesh without a second fan
// anywhere is not changed. Errors: those of build_mesh_adjacency; kResources past 2^32 - 1
// vertices.
format::Result<FanSplit> split_vertex_fans(Mesh& mesh);

}  // namespace gaussmesh::stream
