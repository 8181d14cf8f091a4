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

// Records of one type in a file that no path names (gone when closed, however the run ends),
// appended, then read back by index.
template <class Record>
class UnnamedRecordFile {
 public:
  UnnamedRecordFile() = default;
  UnnamedRecordFile(const UnnamedRecordFile&) = delete;
  UnnamedRecordFile& operator=(const UnnamedRecordFile&) = delete;
  ~UnnamedRecordFile();
  // An empty file in directory `dir`.
  format::Status create(const std::string& dir);
  format::Status append(std::span<const Record> records);
  // Replaces record `index` (appended before).
  format::Status replace(std::uint64_t index, const Record& record);
  // Records [first, first + out.size()): past the end is kProcessing.
  format::Status read(std::uint64_t first, std::span<Record> out) const;
  std::uint64_t count() const { return count_; }

 private:
  std::string dir_;
  int fd_ = -1;
  std::uint64_t count_ = 0;
};

class VertexValuesFile final : public format::VertexValuesReader {
 public:
  // An empty file in directory `dir`.
  static format::Result<std::unique_ptr<VertexValuesFile>> create(const std::string& dir);

  // The next vertices' values.
  format::Status append(std::span<const format::VertexAttributes> values) { return file_.append(values); }
  // Vertex `index`'s values, appended before.
  format::Status replace(std::uint64_t index, const format::VertexAttributes& value) { return file_.replace(index, value); }

  std::uint64_t count() const override { return file_.count(); }
  format::Status rewind() override;
  format::Status read(std::span<format::VertexAttributes> out) override;

 private:
  VertexValuesFile() = default;
  UnnamedRecordFile<format::VertexAttributes> file_;
  std::uint64_t at_ = 0;
};

// The fewest output vertices worth a run of their own: shorter runs cost more passes over the
// input than the output's attributes are worth (the output then goes without them).
inline constexpr std::uint64_t kMinAttributeRun = std::uint64_t{1} << 14;
// What the spill's reading holds beside a run's search: a frame read ahead and one searched, each
// compressed and decompressed with its vertices copied out (1 MiB frames).
inline constexpr std::uint64_t kSpillReadingBytes = std::uint64_t{8} << 20;

// nearest_vertex_values for an output that streams (its vertices in parts) within `budget` bytes
// of resident memory: the output's positions go to a file of their own in `dir` (one pass over
// its vertices), the vertices are then searched in runs of as many as fit beside what the
// process holds at that point (kNearestValuesBytesPerVertex each, and kSpillReadingBytes), in
// output order (a run is a few neighbouring pieces), each run with a pass of its own over the
// input's vertices (the search's first round), and their values appended to `into`; the few
// vertices a run leaves open are gathered and searched together (all rounds) once they are half
// a run, or at the end, their values put in place. A vertex's nearest input vertex does not
// depend on the others searched with it, so the values are those of one search over them all.
// The search grids are sized by the density of the first run's faces (one pass over the faces).
// A run's pass reads, through `near` when given, only the spill's frames that come within the
// first round's radius of the run's box (of an input in spatially coherent order, a few).
// The number of runs; 0, and nothing appended, when they would be shorter than kMinAttributeRun.
// `run`, when not 0, caps their length (tests).
format::Result<std::uint64_t> nearest_vertex_values_in_runs(const VertexPassFn& input, const NearVertexPassFn& near,
                                                            format::MeshParts& output, std::uint64_t budget,
                                                            const std::string& dir, VertexValuesFile& into,
                                                            std::uint64_t run = 0);

}  // namespace gaussmesh::stream
