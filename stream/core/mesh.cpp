// In-memory mesh filled from a streaming reader.
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

format::Status MeshBuilder::on_header(const format::MeshHeader& header) {
  header_ = header;
  return {};
}

format::Status MeshBuilder::on_vertices(std::span<const Vec3f> batch) {
  mesh_.positions.insert(mesh_.positions.end(), batch.begin(), batch.end());
  return {};
}

format::Status MeshBuilder::on_triangles(std::span<const Triangle> batch) {
  mesh_.triangles.insert(mesh_.triangles.end(), batch.begin(), batch.end());
  return {};
}

format::Result<Mesh> load_mesh(const std::string& path, const format::ReadOptions& options) {
  MeshBuilder builder;
  GM_RETURN_IF_ERROR(format::read_mesh_file(path, options, builder));
  return builder.take();
}

}  // namespace gaussmesh::stream
