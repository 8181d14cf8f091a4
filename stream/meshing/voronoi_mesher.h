// Shape approximation, first approach of paper §5 ("--mesher voronoi"): Voronoi cells of the
// samples over the input mesh in the L2,1 metric; an input triangle whose three corners lie in
// three different cells emits the triangle of those cells' centres (as in [CSAD04]).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "format/status.h"
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

struct VoronoiMesherResult {
  Mesh mesh;                         // vertices are the samples that own a cell, positions copied
  std::vector<std::uint32_t> birth;  // input vertex of every output vertex
  std::vector<std::uint32_t> cell;   // per input vertex: index into `samples` of its cell, or ~0u
  std::size_t duplicate_triangles = 0;  // triples emitted by more than one input triangle
  std::size_t unreached_vertices = 0;   // vertices in components without a sample
};

// samples: input vertex indices (distinct). The metric along an edge (u, v) is
// |n_u - n_v| (vertex normals, area-weighted) plus 1e-3 × the edge length over the bounding-box
// diagonal, so flat regions split by distance instead of by ties. Unlike the per-patch mesher
// this gives no topology guarantee: thin cells can leave holes or non-manifold edges (the
// paper's reason for the second approach). Errors: kProcessing for out-of-range samples.
format::Result<VoronoiMesherResult> mesh_voronoi(MeshView mesh, std::span<const std::uint32_t> samples);

}  // namespace gaussmesh::stream
