// The out-of-core sampling pipeline: partition, then sample every chunk. See out_of_core_sample.h.
#include "stream/pipeline/out_of_core_sample.h"

#include <algorithm>
#include <utility>

#include "stream/core/stopwatch.h"
#include "stream/pipeline/chunk_scheduler.h"
#include "stream/pipeline/out_of_core_setup.h"
#include "stream/pipeline/out_of_core_simplify.h"

namespace gaussmesh::stream {
namespace {

// The paper test: its samples need the stitch (patch pieces, the untriangulatable merge,
// candidate chains across chunks), which simplify's passes run up to the samples.
format::Result<OutOfCoreSampling> sample_paper_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                           const OutOfCoreSamplingOptions& options) {
  OutOfCoreSimplifyOptions o;
  o.partition = options.partition;
  o.memory = options.memory;
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
  auto partition =
      partition_for_chunks(input_path, read, options.partition, options.memory, options.sampler, options.threads);
  if (!partition) return partition.status();

  OutOfCoreSampling out;
  record_partition(*partition, out);
  const auto start = Clock::now();

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
      options.memory));
  out.bytes_spilled = partition->bytes_spilled;
  const auto cleanup = Clock::now();
  partition->remove_temp();
  out.seconds_cleanup = seconds_since(cleanup);

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
  out.seconds_sample = seconds_since(start) - out.seconds_cleanup;
  return out;
}

}  // namespace gaussmesh::stream
