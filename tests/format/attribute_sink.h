// A MeshSink for the attribute tests: keeps the header, the names of the values not kept, the
// attributes, the positions and the triangles as a reader delivers them.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "format/mesh_sink.h"

namespace gaussmesh::format {

struct AttributeSink final : MeshSink {
  MeshHeader header;
  std::vector<std::string> ignored;
  std::vector<VertexAttributes> attributes;
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  Status on_header(const MeshHeader& h) override {
    header = h;
    return {};
  }
  Status on_ignored(const std::string& what) override {
    ignored.push_back(what);
    return {};
  }
  Status on_vertex_attributes(std::span<const VertexAttributes> b) override {
    attributes.insert(attributes.end(), b.begin(), b.end());
    return {};
  }
  Status on_vertices(std::span<const Vec3f> b) override {
    positions.insert(positions.end(), b.begin(), b.end());
    return {};
  }
  Status on_triangles(std::span<const Triangle> b) override {
    triangles.insert(triangles.end(), b.begin(), b.end());
    return {};
  }
};

}  // namespace gaussmesh::format
