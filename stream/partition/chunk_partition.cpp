// The partition stage's entry: partition_mesh checks its options, makes the run's temporary
// directory and runs the partition; Partition owns the result and its files.
#include "stream/partition/chunk_partition.h"

#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>

#include "format/temp_ownership.h"
#include "format/temp_registry.h"
#include "stream/attributes/vertex_attribute_spill.h"
#include "stream/partition/cell_grid.h"
#include "stream/partition/partition_run.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream {
namespace {

using detail::errno_text;
using detail::Grid;
using detail::owner_in;
using detail::PartitionRun;
using format::Code;
using format::Status;
using format::Vec3f;

void remove_tree(const std::string& dir) {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

}  // namespace

Partition::~Partition() { remove_temp(); }

Partition::Partition(Partition&& other) noexcept { *this = std::move(other); }

Partition& Partition::operator=(Partition&& other) noexcept {
  if (this == &other) return *this;
  remove_temp();
  dir = std::move(other.dir);
  vertices = other.vertices;
  faces = other.faces;
  lo = other.lo;
  hi = other.hi;
  chunks = std::move(other.chunks);
  bytes_spilled = other.bytes_spilled;
  cache_misses = other.cache_misses;
  cache_bytes = other.cache_bytes;
  untagged_frames = other.untagged_frames;
  reordered = other.reordered;
  input_attributes = other.input_attributes;
  attribute_spill = std::move(other.attribute_spill);
  ignored_vertex_values = std::move(other.ignored_vertex_values);
  input_warnings = std::move(other.input_warnings);
  welded_vertices = other.welded_vertices;
  seconds_ingest = other.seconds_ingest;
  seconds_reorder = other.seconds_reorder;
  reorder_steps = other.reorder_steps;
  seconds_partition = other.seconds_partition;
  steps = other.steps;
  temp_slot = other.temp_slot;
  dir_lock = std::move(other.dir_lock);
  owner_map = std::move(other.owner_map);
  other.dir.clear();
  other.temp_slot = -1;
  return *this;
}

std::uint32_t Partition::owner_of(const Vec3f& p) const {
  if (owner_map.cell_chunk.empty()) return 0;
  Grid grid;
  for (int a = 0; a < 3; ++a) {
    grid.lo[a] = owner_map.lo[a];
    grid.scale[a] = owner_map.scale[a];
    grid.n[a] = owner_map.n[a];
  }
  return owner_in(grid, owner_map.cell_chunk, owner_map.splits, p);
}

void Partition::remove_temp() {
  if (!dir.empty()) remove_tree(dir);
  if (temp_slot >= 0) format::unregister_temp_path(temp_slot);
  dir_lock = {};
  dir.clear();
  temp_slot = -1;
}

format::Result<Partition> partition_mesh(const std::string& input_path, const format::ReadOptions& read,
                                         const PartitionOptions& options) {
  if (options.rings < 1 || options.rings > kMaxPartitionRings) {
    return Status::error(Code::kUsage, "", "overlap rings must be 1.." + std::to_string(kMaxPartitionRings) + ", not " +
                                               std::to_string(options.rings));
  }
  if (options.memory_bytes < kMinPartitionMemory) {
    return Status::error(Code::kUsage, "", "memory budget of " + std::to_string(options.memory_bytes) +
                                               " bytes is below the minimum of 16 MiB");
  }
  if (options.threads < 1) return Status::error(Code::kUsage, "", "threads must be at least 1");
  const std::string parent = format::temp_parent(options.tmp_dir);
  // What runs killed before their cleanup (SIGKILL, the OOM killer) left here goes first.
  format::remove_dead_runs_temps(parent, kPartitionDirPrefix);
  format::remove_dead_runs_temps(parent, kAttributeSpillPrefix);
  Partition partition;
  auto owned = format::create_owned_directory(parent, kPartitionDirPrefix, partition.dir);
  if (!owned) return owned.status();
  partition.dir_lock = std::move(*owned);
  partition.temp_slot = format::register_temp_path(partition.dir, true);
  PartitionRun run(options, partition);
  GM_RETURN_IF_ERROR(run.run(input_path, read));
  return partition;
}

}  // namespace gaussmesh::stream
