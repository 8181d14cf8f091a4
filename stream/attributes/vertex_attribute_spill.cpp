// The input's vertices with their attributes for the out-of-core transfer
// (vertex_attribute_spill.h).
#include "stream/attributes/vertex_attribute_spill.h"

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <vector>

#include "format/temp_registry.h"

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
    for (std::size_t k = 0; k < n; ++k) records[k] = {positions[i + k], attributes[i + k]};
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

format::Status VertexAttributeSpill::each(const VertexBatchFn& batch) const {
  auto reader = format::RecordReader::open(path_, kVertexAttributeRecordKind, sizeof(Record));
  if (!reader) return reader.status();
  std::vector<format::Vec3f> positions;
  std::vector<format::VertexAttributes> attributes;
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) return {};
    const std::size_t n = frame->size() / sizeof(Record);
    positions.resize(n);
    attributes.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      Record r;
      std::memcpy(&r, frame->data() + i * sizeof(Record), sizeof(Record));
      positions[i] = r.position;
      attributes[i] = r.attributes;
    }
    GM_RETURN_IF_ERROR(batch(positions, attributes));
  }
}

}  // namespace gaussmesh::stream
