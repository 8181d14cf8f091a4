// Pass 2 of the out-of-core pipeline for sampling: per-chunk steps 1-2 of the sampler for owned
// vertices, chunks in parallel. See chunk_sampler.h.
#include "stream/sampling/chunk_sampler.h"

#include "stream/pipeline/out_of_core_simplify.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <mutex>

#include <sys/resource.h>
#include <unistd.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace gaussmesh::stream {

void ChunkSamplingStats::add(const ChunkSamplingStats& o) {
  owned_vertices += o.owned_vertices;
  owned_faces += o.owned_faces;
  chunk_faces += o.chunk_faces;
  degenerate_faces += o.degenerate_faces;
  unlabelled_faces += o.unlabelled_faces;
  candidates_initial += o.candidates_initial;
  exact_samples += o.exact_samples;
}

format::Status sample_chunk(const ChunkMesh& chunk, const GaussSphere& gauss, const SamplerOptions& options,
                            ChunkSamplerWorkspace& ws, std::vector<GlobalSample>& samples, ChunkSamplingStats& stats) {
  const bool exact = options.sample_test == SampleTest::kExact;
  const format::MeshView mesh = chunk.view();
  GM_RETURN_IF_ERROR(build_mesh_adjacency(mesh, ws.adjacency));
  compute_face_normals(mesh, ws.adjacency, options.smooth_iterations, ws.normals, ws.area, ws.smoothed);
  compute_face_labels(ws.normals, gauss, ws.labels);
  compute_feature_edges(ws.adjacency, ws.labels, ws.feature);
  ws.owned.clear();
  for (std::uint32_t v = 0; v < chunk.owned_vertex.size(); ++v) {
    if (chunk.owned_vertex[v]) ws.owned.push_back(v);
  }
  ws.records.clear();
  evaluate_vertex_list(mesh, ws.adjacency, ws.normals, ws.labels, ws.feature, gauss, exact, ws.owned, ws.records);
  ChunkSamplingStats s;
  s.owned_vertices = ws.owned.size();
  s.chunk_faces = chunk.triangles.size();
  for (std::size_t f = 0; f < chunk.triangles.size(); ++f) {
    if (!chunk.owned_face[f]) continue;
    ++s.owned_faces;
    s.degenerate_faces += ws.normals.degenerate[f];
    s.unlabelled_faces += ws.labels[f] == kNoLabel;
  }
  for (const VertexRecord& r : ws.records) {
    s.candidates_initial += r.is_candidate;
    if (!exact || !r.is_exact_sample) continue;
    ++s.exact_samples;
    samples.push_back({chunk.global_vertex[r.vertex], chunk.positions[r.vertex], r.exact_gauss_vertex,
                       r.exact_characteristic});
  }
  stats.add(s);
  return format::Status();
}

namespace {

// Whether handing free pages back is worth a trim: the resident set is above 7/8 of the budget.
bool worth_releasing(std::uint64_t rss, std::uint64_t memory_bytes) { return rss > memory_bytes / 8 * 7; }

}  // namespace

format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const ChunkBody& body,
                              const std::function<void(std::size_t, std::size_t)>& progress,
                              std::uint64_t memory_bytes) {
  return for_each_chunk(
      partition.chunks.size(), [&](std::size_t c) { return partition.chunks[c]; }, threads, body, progress, memory_bytes);
}

format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of, std::uint32_t threads,
                              const ChunkBody& body, const std::function<void(std::size_t, std::size_t)>& progress,
                              std::uint64_t memory_bytes) {
  const std::size_t nc = count;
  std::vector<format::Status> errors(nc);
  std::atomic<bool> failed{false};
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex, release_mutex;
  std::uint64_t released_at = 0;  // resident bytes after the last release (under release_mutex)
  // Under small budgets the process's own working set is above 7/8 of the budget all along;
  // releasing after every 2 MiB of growth there cost 20x the page faults (10M triangles under
  // 16 MiB: 23k -> 250k-510k) for no lower peak.
  constexpr std::uint64_t kMinGrowth = std::uint64_t{8} << 20;
  tbb::enumerable_thread_specific<ChunkSamplerWorkspace> workspaces;
  tbb::task_arena arena(static_cast<int>(std::max<std::uint32_t>(threads, 1)));
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, nc, [&](std::size_t c) {
      if (failed) return;
      // Isolated: while the body waits in a nested parallel loop (the adjacency, the sampler),
      // this thread must not start another chunk, which would take the same thread's workspace
      // (and hold a second chunk).
      format::Status st;
      tbb::this_task_arena::isolate([&] {
        auto chunk = load_chunk(info_of(c));
        st = chunk ? body(c, *chunk, workspaces.local()) : chunk.status();
      });
      if (!st) {
        errors[c] = st;
        failed = true;
        return;
      }
      const std::size_t n = ++done;
      if (memory_bytes > 0) {
        std::unique_lock lock(release_mutex, std::try_to_lock);
        const std::uint64_t rss = lock ? current_rss() : 0;
        if (rss > released_at + std::max<std::uint64_t>(memory_bytes / 8, kMinGrowth) && worth_releasing(rss, memory_bytes)) {
          release_free_memory();
          released_at = current_rss();
        }
      }
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(n, nc);
      }
    });
  });
  workspaces.clear();
  release_free_memory();
  for (const format::Status& e : errors)
    if (!e) return e;
  return format::Status();
}

void release_free_memory() {
#ifdef __GLIBC__
  ::malloc_trim(0);
#endif
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

std::uint64_t current_rss() {
  std::uint64_t pages = 0, resident = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "re")) {
    if (std::fscanf(f, "%" SCNu64 " %" SCNu64, &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

std::uint64_t peak_rss() {
  rusage usage{};
  return ::getrusage(RUSAGE_SELF, &usage) == 0 ? static_cast<std::uint64_t>(usage.ru_maxrss) * 1024 : 0;
}

format::Result<Partition> partition_for_chunks(const std::string& input_path, const format::ReadOptions& read,
                                               const PartitionOptions& options, const SamplerOptions& sampler,
                                               std::uint32_t threads) {
  PartitionOptions o = options;
  o.rings = required_overlap_rings(sampler.smooth_iterations);
  o.threads = threads;
  if (o.max_chunk_faces == 0) o.max_chunk_faces = pass_two_chunk_faces(o.memory_bytes, threads, o.rings);
  return partition_mesh(input_path, read, o);
}

format::Status check_out_of_core_options(const char* command,
                                         const std::vector<GaussSphereOptions>& spheres, std::uint32_t threads) {
  if (spheres.empty() || threads == 0) return format::Status::error(format::Code::kUsage, command, "no orientation, or 0 threads");
  return format::Status();
}

std::uint64_t pass_two_chunk_faces(std::uint64_t memory_bytes, std::uint32_t threads, std::uint32_t rings) {
  constexpr std::uint64_t kReserve = std::uint64_t{20} << 20;
  const std::uint64_t bytes_per_face = 28 * (std::uint64_t{std::max<std::uint32_t>(rings, 3)} + 1);
  const std::uint64_t budget = memory_bytes > 2 * kReserve ? memory_bytes - kReserve : memory_bytes / 2;
  return std::max<std::uint64_t>(budget / std::max<std::uint32_t>(threads, 1) / bytes_per_face, 1024);
}

namespace {

// The paper test: its samples need the stitch (patch pieces, the untriangulatable merge,
// candidate chains across chunks), which simplify's passes run up to the samples.
format::Result<OutOfCoreSampling> sample_paper_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                           const OutOfCoreSamplingOptions& options) {
  OutOfCoreSimplifyOptions o;
  o.partition = options.partition;
  o.threads = options.threads;
  o.spheres = options.spheres;
  o.sampler = options.sampler;
  o.samples_only = true;
  if (options.progress) {
    o.progress = [&](const char*, std::size_t done, std::size_t total, std::uint64_t faces) {
      options.progress(done, total, faces);
    };
  }
  auto run = simplify_out_of_core(input_path, read, o);
  if (!run) return run.status();
  OutOfCoreSampling out;
  auto gauss = GaussSphere::create(options.spheres[run->chosen]);
  if (!gauss) return gauss.status();
  out.gauss.emplace(std::move(gauss).value());
  out.chosen = run->chosen;
  out.samples_per_orientation = run->samples_per_orientation;
  out.samples = std::move(run->sample_points);
  out.candidate_pairs = run->candidate_pairs;
  out.candidate_pairs_digest = run->candidate_pairs_digest;
  out.stats = run->sampling_stats;
  out.vertices = run->vertices;
  out.faces = run->faces;
  out.chunks = run->chunks;
  out.bytes_spilled = run->bytes_spilled;
  out.seconds_ingest = run->seconds_ingest;
  out.seconds_partition = run->seconds_partition;
  out.seconds_sample = run->seconds_sample + run->seconds_stitch;
  out.seconds_cleanup = run->seconds_cleanup;
  out.partition_steps = run->partition_steps;
  out.peak_rss_after_partition = run->peak_rss_after_partition;
  return out;
}

}  // namespace

format::Result<OutOfCoreSampling> sample_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                     const OutOfCoreSamplingOptions& options) {
  GM_RETURN_IF_ERROR(check_out_of_core_options("sample", options.spheres, options.threads));
  if (options.sampler.sample_test == SampleTest::kPaper) return sample_paper_out_of_core(input_path, read, options);
  auto spheres = create_spheres(options.spheres);
  if (!spheres) return spheres.status();
  auto partition = partition_for_chunks(input_path, read, options.partition, options.sampler, options.threads);
  if (!partition) return partition.status();

  OutOfCoreSampling out;
  record_partition(*partition, out);
  const auto start = std::chrono::steady_clock::now();

  // Per chunk and orientation: the chunk's samples and counts (output-sized).
  const std::size_t nc = partition->chunks.size(), no = spheres->size();
  std::vector<std::vector<GlobalSample>> samples(nc * no);
  std::vector<ChunkSamplingStats> stats(nc * no);
  GM_RETURN_IF_ERROR(for_each_chunk(
      *partition, options.threads,
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        for (std::size_t k = 0; k < no; ++k)
          GM_RETURN_IF_ERROR(sample_chunk(chunk, (*spheres)[k], options.sampler, ws, samples[c * no + k], stats[c * no + k]));
        return format::Status();
      },
      [&](std::size_t done, std::size_t total) {
        if (options.progress) options.progress(done, total, partition->faces);
      },
      options.partition.memory_bytes));
  out.bytes_spilled = partition->bytes_spilled;
  const auto cleanup = std::chrono::steady_clock::now();
  partition->remove_temp();
  out.seconds_cleanup = std::chrono::duration<double>(std::chrono::steady_clock::now() - cleanup).count();

  // The orientation with the fewest samples, then its samples in vertex order.
  for (std::size_t k = 0; k < no; ++k) {
    std::size_t n = 0;
    for (std::size_t c = 0; c < nc; ++c) n += samples[c * no + k].size();
    out.samples_per_orientation.push_back(n);
    if (n < out.samples_per_orientation[out.chosen]) out.chosen = k;
  }
  for (std::size_t c = 0; c < nc; ++c) {
    auto& part = samples[c * no + out.chosen];
    out.samples.insert(out.samples.end(), part.begin(), part.end());
    out.stats.add(stats[c * no + out.chosen]);
  }
  std::sort(out.samples.begin(), out.samples.end(),
            [](const GlobalSample& a, const GlobalSample& b) { return a.vertex < b.vertex; });
  out.gauss.emplace(std::move((*spheres)[out.chosen]));
  out.seconds_sample = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - out.seconds_cleanup;
  return out;
}

}  // namespace gaussmesh::stream
