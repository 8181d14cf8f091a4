// In-memory mesh filled from a streaming reader.
#include "stream/core/mesh.h"

namespace gaussmesh::stream {

format::Status MeshBuilder::on_header(const format::MeshHeader& header) {
  header_ = header;
  return {};
}

format::Status MeshBuilder::on_ignored(const std::string& what) {
  ignored_.push_back(what);
  return {};
}

format::Status MeshBuilder::on_warning(const std::string& message) {
  warnings_.push_back(message);
  return {};
}

// Keeps the attributes the header announced, each in its own array.
format::Status MeshBuilder::on_vertex_attributes(std::span<const format::VertexAttributes> batch) {
  const format::AttributeKinds& kinds = header_.attributes;
  for (const format::VertexAttributes& a : batch) {
    if (kinds.normals) mesh_.normals.push_back(a.normal);
    if (kinds.colors) mesh_.colors.push_back(a.color);
    if (kinds.texcoords) mesh_.texcoords.push_back(a.texcoord);
  }
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
