// Collects a reader's vertices and triangles into fixed-size batches for a MeshSink, keeping
// the sink contract (format/mesh_sink.h) that a triangle arrives only after its vertices.
// Internal to format/: used by the OFF, OBJ and STL readers.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <vector>

#include "format/mesh_sink.h"

namespace gaussmesh::format {

class MeshBatcher {
 public:
  // Memory: batch_size vertices and batch_size triangles, whatever the input.
  // with_attributes: the header announced attributes; every vertex then comes with its own (an
  // add_vertex with attributes when there are none drops them).
  MeshBatcher(MeshSink& sink, size_t batch_size, bool with_attributes = false)
      : sink_(sink), batch_size_(std::max<size_t>(batch_size, 1)), with_attributes_(with_attributes) {
    vertices_.reserve(batch_size_);
    triangles_.reserve(batch_size_);
    if (with_attributes_) attributes_.reserve(batch_size_);
  }

  // For a reader that learns from its header whether there are attributes: before any vertex.
  void set_with_attributes(bool with_attributes) {
    assert(vertex_count() == 0);
    with_attributes_ = with_attributes;
    if (with_attributes_) attributes_.reserve(batch_size_);
  }

  // Vertices added so far (delivered or pending); the next vertex gets this index.
  uint64_t vertex_count() const { return delivered_vertices_ + vertices_.size(); }
  uint64_t triangle_count() const { return delivered_triangles_ + triangles_.size(); }

  Status add_vertex(const Vec3f& p) {
    assert(!with_attributes_);
    vertices_.push_back(p);
    if (vertices_.size() >= batch_size_) return flush_vertices();
    return {};
  }
  Status add_vertex(const Vec3f& p, const VertexAttributes& attributes) {
    if (with_attributes_) attributes_.push_back(attributes);
    vertices_.push_back(p);
    if (vertices_.size() >= batch_size_) return flush_vertices();
    return {};
  }

  // Precondition: every index < vertex_count(). The triangle may use pending vertices: they
  // are always delivered before the triangles (flush_triangles delivers them first), so
  // interleaved vertices and faces (OBJ, STL) still travel in full batches.
  Status add_triangle(VertexIndex a, VertexIndex b, VertexIndex c) {
    assert(a < vertex_count() && b < vertex_count() && c < vertex_count());
    triangles_.push_back(Triangle{{a, b, c}});
    if (triangles_.size() >= batch_size_) return flush_triangles();
    return {};
  }

  Status flush_vertices() {
    if (vertices_.empty()) return {};
    if (with_attributes_) {
      GM_RETURN_IF_ERROR(sink_.on_vertex_attributes(attributes_));
      attributes_.clear();
    }
    Status s = sink_.on_vertices(vertices_);
    delivered_vertices_ += vertices_.size();
    vertices_.clear();
    return s;
  }
  // Delivers pending vertices, then pending triangles.
  Status flush_triangles() {
    GM_RETURN_IF_ERROR(flush_vertices());
    if (triangles_.empty()) return {};
    Status s = sink_.on_triangles(triangles_);
    delivered_triangles_ += triangles_.size();
    triangles_.clear();
    return s;
  }
  // Delivers everything pending (vertices first); the reader then calls sink.on_end().
  Status finish() { return flush_triangles(); }

 private:
  MeshSink& sink_;
  size_t batch_size_;
  bool with_attributes_;
  std::vector<Vec3f> vertices_;
  std::vector<VertexAttributes> attributes_;
  std::vector<Triangle> triangles_;
  uint64_t delivered_vertices_ = 0;
  uint64_t delivered_triangles_ = 0;
};

}  // namespace gaussmesh::format
