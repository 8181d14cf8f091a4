// The in-memory mesh the in-core algorithms work on: flat arrays at module boundaries.
// OpenMesh is used inside stream/ .cpp files where half-edge navigation pays off; it never
// appears in a public header (docs/design.md explains the choice).
#pragma once

#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/mesh_sink.h"
#include "format/mesh_types.h"

namespace gaussmesh::stream {

using format::MeshView;
using format::Triangle;
using format::Vec3f;

// The API's owning mesh: positions, triangles, and per-vertex attributes when present.
using gaussmesh::Mesh;

// A MeshSink that keeps everything. Grows with what is actually delivered, never by the
// header's declared counts.
class MeshBuilder final : public format::MeshSink {
 public:
  format::Status on_header(const format::MeshHeader& header) override;
  format::Status on_ignored(const std::string& what) override;
  format::Status on_warning(const std::string& message) override;
  format::Status on_vertex_attributes(std::span<const format::VertexAttributes> batch) override;
  format::Status on_vertices(std::span<const Vec3f> batch) override;
  format::Status on_triangles(std::span<const Triangle> batch) override;
  const format::MeshHeader& header() const { return header_; }
  // What the reader named as not delivered (format::MeshSink::on_ignored), in its order.
  const std::vector<std::string>& ignored() const { return ignored_; }
  // What the reader skipped (format::MeshSink::on_warning), in its order.
  const std::vector<std::string>& warnings() const { return warnings_; }
  Mesh take() { return std::move(mesh_); }

 private:
  format::MeshHeader header_;
  std::vector<std::string> ignored_, warnings_;
  Mesh mesh_;
};

// Reads a whole mesh file ("-" for stdin) into memory.
format::Result<Mesh> load_mesh(const std::string& path, const format::ReadOptions& options = {});

}  // namespace gaussmesh::stream
