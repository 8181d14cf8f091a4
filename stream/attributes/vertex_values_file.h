// The attributes of an output too large to hold them (out of core, an explicit budget): its
// vertices' values found run by run and kept in vertex order in a temporary file that no path
// names, which the PLY and OBJ writers read back as the vertices stream
// (format::VertexValuesReader).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "format/mesh_sink.h"
#include "format/mesh_writer.h"
#include "format/status.h"
#include "stream/attributes/attribute_transfer.h"

namespace gaussmesh::stream {

class VertexValuesFile final : public format::VertexValuesReader {
 public:
  // An empty file in directory `dir` (made there, gone when closed, however the run ends).
  static format::Result<std::unique_ptr<VertexValuesFile>> create(const std::string& dir);
  ~VertexValuesFile() override;
  VertexValuesFile(const VertexValuesFile&) = delete;
  VertexValuesFile& operator=(const VertexValuesFile&) = delete;

  // The next vertices' values.
  format::Status append(std::span<const format::VertexAttributes> values);

  std::uint64_t count() const override { return count_; }
  format::Status rewind() override;
  format::Status read(std::span<format::VertexAttributes> out) override;

 private:
  VertexValuesFile() = default;
  std::string dir_;
  int fd_ = -1;
  std::uint64_t count_ = 0, at_ = 0;
};

// The fewest output vertices worth a run of their own: shorter runs cost more passes over the
// input than the output's attributes are worth (the output then goes without them).
inline constexpr std::uint64_t kMinAttributeRun = std::uint64_t{1} << 14;

// nearest_vertex_values for an output that streams (its vertices in parts), `run` vertices at a
// time in output order (a run is a few neighbouring pieces), each run with passes of its own over
// the input's vertices, appended to `into`. A vertex's nearest input vertex does not depend on
// the others searched with it, so the values are those of one search over them all. A run's
// search grid is sized by the area of the faces whose corners all lie in it. Memory: a run's
// positions and search (about 90 B a vertex), whatever the output's size.
format::Status nearest_vertex_values_in_runs(const VertexPassFn& input, format::MeshParts& output, std::uint64_t run,
                                             VertexValuesFile& into);

}  // namespace gaussmesh::stream
