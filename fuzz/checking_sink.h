// The reader contract of format/mesh_sink.h as a check: a MeshSink that records the first
// breach, and a whole read under the limits the fuzz targets use. Shared by the reader fuzz
// targets (which abort on a breach, so libFuzzer reports the input) and by the regression test
// over fixtures/fuzz/ (which fails on one).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "format/mesh_sink.h"

namespace gaussmesh::fuzz {

// Keeps counts only, never the mesh, so its memory does not grow with the input.
class CheckingSink : public format::MeshSink {
 public:
  format::Status on_header(const format::MeshHeader& header) override;
  format::Status on_ignored(const std::string& what) override;
  format::Status on_vertex_attributes(std::span<const format::VertexAttributes> batch) override;
  format::Status on_vertices(std::span<const format::Vec3f> batch) override;
  format::Status on_triangles(std::span<const format::Triangle> batch) override;
  format::Status on_end() override;

  // The first breach of the contract, empty while there is none.
  const std::string& broken() const { return broken_; }
  bool ended() const { return ended_; }
  std::uint64_t triangles() const { return triangles_; }
  const format::MeshHeader& header() const { return header_; }

 private:
  void breach(const char* what);
  bool is_open(const char* call);

  std::string broken_;
  bool started_ = false, ended_ = false;
  format::MeshHeader header_;
  // The size of the attribute batch that must come with the next on_vertices, if any.
  std::optional<size_t> pending_attributes_;
  std::uint64_t vertices_ = 0, triangles_ = 0;
};

struct ReadCheck {
  format::Status status;
  std::string broken;  // empty: the reader kept its contract, whatever the status
};

// Reads bytes with the reader of `format` forced, from memory, in small batches, under a 256 MiB
// memory limit (a lying header must be refused, not allocated). Besides the sink's checks: a
// success must have ended the mesh, and an error must be kBadInput or kResources with a message.
// OBJ: the census the engine choice counts with (format/obj_census.h) errs towards more: never
// fewer triangles than a successful read delivers, and corner values wherever it delivers them.
ReadCheck read_and_check(std::string_view bytes, format::MeshFormat format);

}  // namespace gaussmesh::fuzz
