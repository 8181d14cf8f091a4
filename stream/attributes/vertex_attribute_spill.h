// The input's vertices with their attributes, written as the ingest reads them, so that an
// out-of-core run can give its output the input's attributes (transfer_nearest_vertex) after
// the passes that carry positions only. A record file of its own in the temporary directory,
// registered for signal cleanup and removed with the object (docs/attributes.md).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "format/mesh_sink.h"
#include "format/record_file.h"
#include "format/temp_ownership.h"
#include "stream/attributes/attribute_transfer.h"

namespace gaussmesh::stream {

// How a spill's file name starts (then the pid and a counter), so that a later run finds the
// file of a killed one (format::remove_dead_runs_temps).
inline constexpr char kAttributeSpillPrefix[] = "gaussmesh-run-attributes-";

class VertexAttributeSpill {
 public:
  // A new, empty spill in directory `dir` for an input with attributes `kinds`.
  static format::Result<std::unique_ptr<VertexAttributeSpill>> create(const std::string& dir,
                                                                      const format::AttributeKinds& kinds);
  ~VertexAttributeSpill();
  VertexAttributeSpill(const VertexAttributeSpill&) = delete;
  VertexAttributeSpill& operator=(const VertexAttributeSpill&) = delete;

  // The next vertices, in input order: positions and their attributes, as many of each.
  format::Status add(std::span<const format::Vec3f> positions, std::span<const format::VertexAttributes> attributes);
  format::Status finish();

  const format::AttributeKinds& kinds() const { return kinds_; }
  std::uint64_t bytes() const { return bytes_; }  // compressed, on disk (after finish)
  // Streams the vertices back in input order (a VertexPassFn). With `ahead`, the frames are
  // read and decompressed a frame ahead of `batch` on a thread of their own. With `near`, frames
  // whose vertices all lie outside it are passed over undecompressed (a NearVertexPassFn).
  format::Status each(const VertexBatchFn& batch, bool ahead = false, const PositionBox* near = nullptr) const;

 private:
  VertexAttributeSpill() = default;
  struct Record;
  std::string path_;
  format::TempOwnership lock_;  // held while the file exists
  int slot_ = -1;
  format::AttributeKinds kinds_;
  std::unique_ptr<format::RecordWriter> writer_;
  std::uint64_t bytes_ = 0;
  // The box of each frame's vertices (the writer cuts a frame every frame_records_ records).
  std::vector<PositionBox> frame_boxes_;
  std::uint64_t frame_records_ = 0, in_frame_ = 0;
};

}  // namespace gaussmesh::stream
