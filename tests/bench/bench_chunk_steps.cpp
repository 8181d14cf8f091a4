// Benchmark of the sample pass's per-chunk steps on real chunks: partitions MESH as `simplify --memory`
// does (2 threads' chunk size), then, on one thread, times for each of the first CHUNKS chunks:
//   load    load_chunk (once per chunk: its reads go through the page cache)
//   sample  sample_chunk: adjacency, face normals, labels, feature edges, the exact test
//   pieces  find_chunk_pieces
//   skips   faces_the_mesher_skips
//   loop    write_loop_chunk (its own skips, the core faces, piece areas, the segment written)
// and prints nanoseconds per chunk face of each, after REPS repetitions (the first sample_chunk
// of a chunk, which warms the workspace, is not counted). Figures on this shared VM drift by
// 10-20 % from minute to minute: compare two builds by alternating them (docs/benchmarks.md). The check line sums what the steps produced, so two builds that must agree
// print the same checks.
//
//   bench_chunk_steps MESH [REPS (5)] [CHUNKS (8)] [MEMORY_MIB (64)]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "format/record_file.h"
#include "stream/partition/chunk_partition.h"
#include "stream/stitch/chunk_pieces.h"
#include "stream/sampling/chunk_sampler.h"
#include "stream/pipeline/out_of_core_setup.h"
#include "stream/stitch/loop_chunks.h"
#include "stream/core/gauss_sphere.h"
#include "stream/meshing/polygon_mesher.h"

namespace {

using namespace gaussmesh;
using namespace gaussmesh::stream;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_chunk_steps MESH [REPS] [CHUNKS] [MEMORY_MIB]\n");
    return 1;
  }
  const int reps = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const std::size_t chunks = argc > 3 ? std::max(1, std::atoi(argv[3])) : 8;
  const std::uint64_t memory = (argc > 4 ? std::max(16, std::atoi(argv[4])) : 64) * (std::uint64_t{1} << 20);
  PartitionOptions po;
  po.memory_bytes = memory;
  po.rings = required_overlap_rings(0);
  po.threads = 2;
  po.max_chunk_faces = sample_pass_chunk_faces(MemoryBudget(memory), 2);
  auto part = partition_mesh(argv[1], {}, po);
  if (!part) {
    std::fprintf(stderr, "bench_chunk_steps: %s\n", part.status().to_string().c_str());
    return 1;
  }
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  GaussSphereOptions go;
  go.frequency = 4;  // simplify's default
  auto gauss = GaussSphere::create(go);
  auto segments = format::RecordSegmentFile::create(part->dir + "/bench-loop.rec");
  if (!gauss || !segments) return 1;
  const SamplerOptions sampler;
  double load = 0, sample = 0, pieces = 0, skips = 0, loop = 0;
  std::size_t faces = 0;
  for (std::size_t c = 0; c < std::min(part->chunks.size(), chunks); ++c) {
    auto t = Clock::now();
    auto chunk = load_chunk(part->chunks[c]);
    load += since(t);
    if (!chunk) {
      std::fprintf(stderr, "bench_chunk_steps: %s\n", chunk.status().to_string().c_str());
      return 1;
    }
    ChunkSamplerWorkspace ws;
    std::vector<GlobalSample> samples;
    ChunkSamplingStats stats;
    if (!sample_chunk(*chunk, *gauss, sampler, ws, samples, stats)) return 1;
    t = Clock::now();
    for (int r = 0; r < reps; ++r) {
      samples.clear();
      if (!sample_chunk(*chunk, *gauss, sampler, ws, samples, stats)) return 1;
    }
    sample += since(t);
    std::vector<std::uint32_t> piece_index;
    std::uint64_t check = samples.size();
    t = Clock::now();
    for (int r = 0; r < reps; ++r) {
      ChunkPieces out;
      std::vector<std::uint32_t> candidates;  // as the sample pass hands them over
      for (const VertexRecord& rec : ws.records)
        if (rec.is_candidate) candidates.push_back(rec.vertex);
      find_chunk_pieces(*part, *chunk, ws.adjacency, ws.labels, ws.feature, out, &piece_index, &candidates);
      check += out.pieces.size() + 3 * out.border.size() + 7 * out.border_faces.size() + 11 * out.star.size() +
               13 * out.adjacency.size() + 17 * out.candidates.size();
    }
    pieces += since(t);
    t = Clock::now();
    for (int r = 0; r < reps; ++r) {
      bool repeats = false;
      const auto skip = faces_the_mesher_skips(chunk->triangles, ws.adjacency, &repeats);
      check += std::count(skip.begin(), skip.end(), std::uint8_t{1});
    }
    skips += since(t);
    t = Clock::now();
    for (int r = 0; r < reps; ++r) {
      ChunkInfo loop_info;
      std::vector<std::array<double, 3>> area;
      auto written = write_loop_chunk(*chunk, part->chunks[c], ws.adjacency, piece_index, ws.feature, samples, **segments, loop_info, area);
      if (!written) return 1;
      check += *written ? loop_info.faces : 0;
    }
    loop += since(t);
    faces += chunk->triangles.size();
    std::printf("chunk %zu: %zu faces, check %llu\n", c, chunk->triangles.size(), static_cast<unsigned long long>(check));
  }
  const double n = static_cast<double>(faces) * reps;
  std::printf("ns per chunk face: sample %.1f, pieces %.1f, skips %.1f, loop %.1f, load %.1f (once per chunk)\n",
              sample * 1e9 / n, pieces * 1e9 / n, skips * 1e9 / n, loop * 1e9 / n, load * 1e9 / static_cast<double>(faces));
  return 0;
}
