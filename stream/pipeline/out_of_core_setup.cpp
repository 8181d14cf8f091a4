// Option checks, spheres and the partition of the out-of-core pipelines. See out_of_core_setup.h.
#include "stream/pipeline/out_of_core_setup.h"

#include <algorithm>
#include <utility>

namespace gaussmesh::stream {

format::Status check_out_of_core_options(const char* command, const std::vector<GaussSphereOptions>& spheres,
                                         std::uint32_t threads) {
  if (spheres.empty() || threads == 0) return format::Status::error(format::Code::kUsage, command, "no orientation, or 0 threads");
  return format::Status();
}

format::Result<std::vector<GaussSphere>> create_spheres(const std::vector<GaussSphereOptions>& options) {
  std::vector<GaussSphere> spheres;
  for (const auto& o : options) {
    auto g = GaussSphere::create(o);
    if (!g) return g.status();
    spheres.push_back(std::move(g).value());
  }
  return spheres;
}

std::uint64_t sample_pass_chunk_faces(const MemoryBudget& budget, std::uint32_t threads, std::uint32_t rings) {
  constexpr std::uint64_t kReserve = std::uint64_t{20} << 20;
  const std::uint64_t bytes_per_face = 28 * (std::uint64_t{std::max<std::uint32_t>(rings, 3)} + 1);
  const MemoryBudget chunks = MemoryBudget::of(budget.after_reserve(kReserve));
  return std::max<std::uint64_t>(chunks.per_part(threads) / bytes_per_face, 1024);
}

format::Result<Partition> partition_for_chunks(const std::string& input_path, const format::ReadOptions& read,
                                               const PartitionOptions& options, const MemoryBudget& budget,
                                               const SamplerOptions& sampler, std::uint32_t threads) {
  PartitionOptions o = options;
  o.memory_bytes = budget.bytes();
  o.rings = required_overlap_rings(sampler.smooth_iterations);
  o.threads = threads;
  if (o.max_chunk_faces == 0) o.max_chunk_faces = sample_pass_chunk_faces(budget, threads, o.rings);
  return partition_mesh(input_path, read, o);
}

}  // namespace gaussmesh::stream
