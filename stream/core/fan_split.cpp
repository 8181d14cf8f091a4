// One vertex per fan of faces (fan_split.h).
#include "stream/core/fan_split.h"

#include <cstdint>
#include <limits>

#include "stream/core/mesh_adjacency.h"

namespace gaussmesh::stream {

format::Result<FanSplit> split_vertex_fans(Mesh& mesh) {
  auto adjacency = build_mesh_adjacency(mesh.view());
  if (!adjacency) return adjacency.status();
  const MeshAdjacency& a = *adjacency;
  FanSplit split;
  const std::size_t vertices = a.vertex_count();
  for (std::uint32_t v = 0; v < vertices; ++v) {
    std::uint32_t copy = v;
    bool first_fan = true;
    for (std::uint32_t slot = a.star_begin(v); slot < a.star_end(v); ++slot) {
      if (a.slot_flags[slot] & MeshAdjacency::kFanStart) {
        if (first_fan) {
          first_fan = false;
        } else {
          if (mesh.positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
            return format::Status::error(format::Code::kResources, "",
                                         "splitting non-manifold vertices needs more than 2^32 - 1 vertices");
          }
          if (copy == v) ++split.split_vertices;
          copy = static_cast<std::uint32_t>(mesh.positions.size());
          mesh.positions.push_back(mesh.positions[v]);
          if (!mesh.normals.empty()) mesh.normals.push_back(mesh.normals[v]);
          if (!mesh.colors.empty()) mesh.colors.push_back(mesh.colors[v]);
          if (!mesh.texcoords.empty()) mesh.texcoords.push_back(mesh.texcoords[v]);
          ++split.added_vertices;
        }
      }
      if (copy != v) {
        const std::uint32_t corner = a.vertex_corners[slot];
        mesh.triangles[corner / 3].v[corner % 3] = copy;
      }
    }
  }
  return split;
}

}  // namespace gaussmesh::stream
