// The ingest pass: the input mesh read once into the position files and the face spill, with
// its counts and bounds.
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "format/mesh_reader.h"
#include "stream/attributes/vertex_attribute_spill.h"
#include "stream/partition/face_spill.h"
#include "stream/partition/input_positions.h"
#include "stream/partition/partition_run.h"
#include "stream/partition/spill_thread.h"
#include "stream/partition/spatial_order.h"
#include "stream/partition/spill_writer.h"

namespace gaussmesh::stream::detail {
namespace {

// Positions of stripes in file 0 go to the spill thread, those in file 1 are written here, on
// the reader's thread: two threads copy into the page cache at once, each into its own file.
class IngestSink final : public format::MeshSink {
 public:
  // input_is_file: the input can be opened again by name, so its own vertex records (when the
  // reader says where they are) stand in for the position files.
  // attribute_dir: where the vertex attribute spill goes when the input has attributes (it
  // outlives the partition's own directory: the transfer comes after the passes).
  IngestSink(SpillThread& spills, SpillWriter& positions_here,
             const std::function<void(const char*, std::uint64_t, std::uint64_t)>& progress, bool input_is_file,
             bool spill_attributes, std::string attribute_dir)
      : spills_(spills), positions_here_(positions_here), progress_(progress), input_is_file_(input_is_file),
        spill_attributes_(spill_attributes), attribute_dir_(std::move(attribute_dir)) {}
  Status on_header(const format::MeshHeader& header) override {
    declared_faces_ = header.declared_faces.value_or(0);
    attributes_ = header.attributes;
    if (input_is_file_) raw_vertices_ = header.raw_vertices;
    if (attributes_.any() && spill_attributes_) {
      auto spill = VertexAttributeSpill::create(attribute_dir_, attributes_);
      if (!spill) return spill.status();
      attribute_spill_ = std::move(*spill);
    }
    return {};
  }
  Status on_vertex_attributes(std::span<const format::VertexAttributes> batch) override {
    pending_attributes_.assign(batch.begin(), batch.end());
    return {};
  }
  // The input's vertices with their attributes (null when it has none), finished.
  Result<std::shared_ptr<VertexAttributeSpill>> take_attribute_spill() {
    if (attribute_spill_) GM_RETURN_IF_ERROR(attribute_spill_->finish());
    return std::shared_ptr<VertexAttributeSpill>(std::move(attribute_spill_));
  }
  Status on_ignored(const std::string& what) override {
    ignored_.push_back(what);
    return {};
  }
  Status on_warning(const std::string& message) override {
    warnings_.push_back(message);
    return {};
  }
  // The input's vertex values that the streaming engine does not carry.
  const format::AttributeKinds& attributes() const { return attributes_; }
  const std::vector<std::string>& ignored() const { return ignored_; }
  const std::vector<std::string>& warnings() const { return warnings_; }
  // Where the input holds the positions, when no copy is written.
  const std::optional<format::MeshHeader::RawVertices>& raw_vertices() const { return raw_vertices_; }
  Status on_vertices(std::span<const Vec3f> batch) override {
    if (vertices_ + batch.size() > format::kMaxVertices) {
      return Status::error(Code::kResources, "", "more than " + std::to_string(format::kMaxVertices) +
                                                     " vertices: chunk records hold 32-bit vertex ids");
    }
    for (const Vec3f& p : batch) bounds_.add(p);
    if (attribute_spill_) GM_RETURN_IF_ERROR(attribute_spill_->add(batch, pending_attributes_));
    if (raw_vertices_) {
      vertices_ += batch.size();
      return {};
    }
    while (!batch.empty()) {
      const auto v = static_cast<std::uint32_t>(vertices_);  // below kMaxVertices (checked above)
      const std::size_t part = std::min<std::size_t>(batch.size(), kPositionStripeVertices - v % kPositionStripeVertices);
      const std::span<const Vec3f> stripe = batch.first(part);
      GM_RETURN_IF_ERROR(position_file(v) == 0 ? spills_.vertices(stripe)
                                               : positions_here_.write(stripe.data(), stripe.size_bytes()));
      vertices_ += part;
      batch = batch.subspan(part);
    }
    return {};
  }
  Status on_triangles(std::span<const Triangle> batch) override {
    faces_count_ += batch.size();
    probe_.add(batch);
    if (progress_) progress_("ingest", faces_count_, std::max(declared_faces_, faces_count_));
    return spills_.triangles(batch);
  }
  std::uint64_t vertices() const { return vertices_; }
  std::uint64_t faces() const { return faces_count_; }
  const OrderProbe& probe() const { return probe_; }
  void bounds(Vec3f& lo, Vec3f& hi) const { bounds_.get(lo, hi); }

 private:
  SpillThread& spills_;
  SpillWriter& positions_here_;
  const std::function<void(const char*, std::uint64_t, std::uint64_t)>& progress_;
  const bool input_is_file_;
  std::optional<format::MeshHeader::RawVertices> raw_vertices_;
  OrderProbe probe_;
  std::uint64_t vertices_ = 0, faces_count_ = 0;
  std::uint64_t declared_faces_ = 0;  // the header's count (polygons): untrusted, for progress only
  format::AttributeKinds attributes_;
  std::vector<std::string> ignored_, warnings_;
  bool spill_attributes_;
  std::string attribute_dir_;
  std::unique_ptr<VertexAttributeSpill> attribute_spill_;
  std::vector<format::VertexAttributes> pending_attributes_;
  FiniteBounds bounds_;
};

}  // namespace

Status PartitionRun::ingest(const std::string& input_path, const format::ReadOptions& read) {
  vertex_files_ = std::make_shared<VertexFiles>();
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) vertex_files_->positions[i] = out_.dir + "/positions-" + std::to_string(i) + ".bin";
  faces_path_ = out_.dir + "/faces.gmr";
  SpillWriter positions[kPositionFiles];
  FaceSpill faces;
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) GM_RETURN_IF_ERROR(positions[i].open(vertex_files_->positions[i], std::size_t{1} << 20));
  GM_RETURN_IF_ERROR(faces.open(faces_path_));
  SpillThread spills(positions[0], faces, options_.threads > 1);
  struct stat input{};
  const bool input_is_file = input_path != "-" && ::stat(input_path.c_str(), &input) == 0 && S_ISREG(input.st_mode);
  IngestSink sink(spills, positions[1], options_.progress, input_is_file, options_.spill_attributes,
                  out_.dir.substr(0, out_.dir.rfind('/')));
  Status status = format::read_mesh_file(input_path, read, sink);
  // A write error stops the reader (the sink returns it) and is the run's error.
  if (Status written = spills.finish(); !written.is_ok()) return written;
  if (!status.is_ok()) {
    // A sink error has no place of its own: name the input.
    if (status.where().empty()) return Status::error(status.code(), input_path == "-" ? "<stdin>" : input_path, status.message());
    return status;
  }
  for (SpillWriter& p : positions) {
    GM_RETURN_IF_ERROR(p.close());
    bytes_spilled_ += p.bytes();
  }
  GM_RETURN_IF_ERROR(faces.close());
  if (const auto& raw = sink.raw_vertices()) {
    VertexFiles::InputPositions in;
    in.path = input_path;
    in.first_byte = raw->first_byte;
    in.stride = raw->stride;
    for (int a = 0; a < 3; ++a) in.xyz[a] = raw->xyz[a];
    in.size = static_cast<std::uint64_t>(input.st_size);  // as before the read: a change during it counts too
    in.modified_ns = modified_ns(input);
    if (in.first_byte + sink.vertices() * std::uint64_t{in.stride} > in.size)
      return Status::error(Code::kBadInput, input_path, "the input changed during the run");
    vertex_files_->input = std::move(in);
  }
  out_.vertices = sink.vertices();
  out_.faces = sink.faces();
  out_.input_attributes = sink.attributes();
  auto attribute_spill = sink.take_attribute_spill();
  if (!attribute_spill) return attribute_spill.status();
  out_.attribute_spill = std::move(*attribute_spill);
  if (out_.attribute_spill) bytes_spilled_ += out_.attribute_spill->bytes();
  out_.ignored_vertex_values = sink.ignored();
  out_.input_warnings = sink.warnings();
  scattered_ = sink.probe().scattered(sink.vertices());
  sink.bounds(out_.lo, out_.hi);
  bytes_spilled_ += faces.bytes();
  return {};
}

}  // namespace gaussmesh::stream::detail
