// The input's vertices with their attributes for the out-of-core transfer
// (vertex_attribute_spill.h).
#include "stream/attributes/vertex_attribute_spill.h"

#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "format/temp_registry.h"
#include "stream/core/thread_status.h"

namespace gaussmesh::stream {

// One vertex as the file holds it: its position, then its attributes.
struct VertexAttributeSpill::Record {
  format::Vec3f position;
  format::VertexAttributes attributes;
};

namespace {

constexpr std::uint32_t kVertexAttributeRecordKind = 0x41564D47u;  // "GMVA"

}  // namespace

format::Result<std::unique_ptr<VertexAttributeSpill>> VertexAttributeSpill::create(const std::string& dir,
                                                                                   const format::AttributeKinds& kinds) {
  static std::atomic<unsigned> counter{0};
  std::unique_ptr<VertexAttributeSpill> spill(new VertexAttributeSpill);
  spill->kinds_ = kinds;
  spill->path_ = (dir.empty() ? std::string(".") : dir) + "/" + kAttributeSpillPrefix + std::to_string(::getpid()) + "-" +
                 std::to_string(counter++) + ".rec";
  bool exists = false;
  auto owned = format::create_owned_file(spill->path_, exists);
  if (!owned) return format::Status::error(format::Code::kOutput, spill->path_, "cannot create: " + owned.status().message());
  spill->lock_ = std::move(*owned);
  spill->slot_ = format::register_temp_path(spill->path_, false);
  auto writer = format::RecordWriter::create(spill->path_, kVertexAttributeRecordKind, sizeof(Record));
  if (!writer) return writer.status();
  spill->writer_ = std::move(*writer);
  spill->frame_records_ = spill->writer_->frame_limit() / sizeof(Record);
  return spill;
}

VertexAttributeSpill::~VertexAttributeSpill() {
  writer_.reset();
  ::unlink(path_.c_str());
  if (slot_ >= 0) format::unregister_temp_path(slot_);
}

format::Status VertexAttributeSpill::add(std::span<const format::Vec3f> positions,
                                         std::span<const format::VertexAttributes> attributes) {
  if (positions.size() != attributes.size()) {
    return format::Status::error(format::Code::kProcessing, path_, "vertices and attributes of different counts");
  }
  Record records[256];
  for (std::size_t i = 0; i < positions.size();) {
    const std::size_t n = std::min<std::size_t>(256, positions.size() - i);
    for (std::size_t k = 0; k < n; ++k) {
      records[k] = {positions[i + k], attributes[i + k]};
      if (in_frame_++ == 0) frame_boxes_.emplace_back();
      frame_boxes_.back().add(positions[i + k]);
      if (in_frame_ == frame_records_) in_frame_ = 0;
    }
    GM_RETURN_IF_ERROR(writer_->append(std::as_bytes(std::span<const Record>(records, n))));
    i += n;
  }
  return {};
}

format::Status VertexAttributeSpill::finish() {
  GM_RETURN_IF_ERROR(writer_->finish());
  bytes_ = writer_->bytes_written();
  writer_.reset();
  return {};
}

format::Status VertexAttributeSpill::each(const VertexBatchFn& batch, bool ahead, const PositionBox* near) const {
  auto reader = format::RecordReader::open(path_, kVertexAttributeRecordKind, sizeof(Record));
  if (!reader) return reader.status();
  if (near && (*reader)->frame_count() != frame_boxes_.size()) {
    return format::Status::error(format::Code::kProcessing, path_, "the spill's frames are not the ones written");
  }
  std::size_t frame_index = 0;
  // One frame's vertices as the batch takes them; an empty one ends the pass.
  struct Frame {
    std::vector<format::Vec3f> positions;
    std::vector<format::VertexAttributes> attributes;
    format::Status status;
  };
  const auto read = [&](Frame& into) {
    into.positions.clear();
    into.attributes.clear();
    for (; near && frame_index < frame_boxes_.size() && !frame_boxes_[frame_index].meets(*near); ++frame_index) {
      auto skipped = (*reader)->skip();
      if (!skipped) {
        into.status = skipped.status();
        return;
      }
    }
    ++frame_index;
    auto frame = (*reader)->next();
    if (!frame) {
      into.status = frame.status();
      return;
    }
    const std::size_t n = frame->size() / sizeof(Record);
    into.positions.resize(n);
    into.attributes.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      Record r;
      std::memcpy(&r, frame->data() + i * sizeof(Record), sizeof(Record));
      into.positions[i] = r.position;
      into.attributes[i] = r.attributes;
    }
  };
  Frame current;
  if (!ahead) {
    for (;;) {
      read(current);
      GM_RETURN_IF_ERROR(current.status);
      if (current.positions.empty()) return {};
      GM_RETURN_IF_ERROR(batch(current.positions, current.attributes));
    }
  }
  // A single slot between the reading thread and this one.
  std::mutex mutex;
  std::condition_variable changed;
  Frame slot;
  bool full = false, stopping = false;
  std::thread reading([&] {
    Frame next;
    for (bool more = true; more;) {
      next.status = status_of_work("attribute spill", [&] {
        read(next);
        return next.status;
      });
      more = next.status.is_ok() && !next.positions.empty();
      std::unique_lock lock(mutex);
      changed.wait(lock, [&] { return !full || stopping; });
      if (stopping) return;
      std::swap(slot, next);
      full = true;
      changed.notify_all();
    }
  });
  format::Status status;
  for (;;) {
    {
      std::unique_lock lock(mutex);
      changed.wait(lock, [&] { return full; });
      std::swap(slot, current);
      full = false;
      changed.notify_all();
    }
    if (!current.status.is_ok() || current.positions.empty()) {
      status = current.status;
      break;
    }
    status = batch(current.positions, current.attributes);
    if (!status.is_ok()) break;
  }
  {
    std::lock_guard lock(mutex);
    stopping = true;
  }
  changed.notify_all();
  reading.join();
  return status;
}

}  // namespace gaussmesh::stream
