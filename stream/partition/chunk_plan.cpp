// The plan: cell histograms over the positions, split cells, cells grouped into chunks in Morton
// order, and the owner pass writing owners.bin.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "stream/partition/face_spill.h"
#include "stream/partition/partition_run.h"
#include "stream/partition/position_scan.h"
#include "stream/partition/spill_thread.h"
#include "stream/partition/spill_writer.h"

namespace gaussmesh::stream::detail {

template <class Count>
Result<std::vector<std::uint32_t>> PartitionRun::count_positions(std::size_t size, Count&& count) {
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> local([size] { return std::vector<std::uint32_t>(size, 0); });
  GM_RETURN_IF_ERROR(scan_positions(
      *vertex_files_, out_.vertices, [&](std::size_t n, auto&& fn) { for_pieces(n, fn); },
      [&](std::uint64_t, std::span<const Vec3f> batch, std::size_t begin, std::size_t end) {
        std::uint32_t* histogram = local.local().data();
        for (std::size_t i = begin; i < end; ++i) count(histogram, batch[i]);
      },
      [](std::uint64_t, std::span<const Vec3f>) { return Status{}; }));
  // The first thread's counts become the sum (no copy more than the threads' own).
  std::vector<std::uint32_t> sum;
  for (std::vector<std::uint32_t>& part : local) {
    if (sum.empty()) {
      sum.swap(part);
      continue;
    }
    for (std::size_t i = 0; i < size; ++i) sum[i] += part[i];
  }
  if (sum.empty()) sum.assign(size, 0);  // no vertex: no thread counted
  return sum;
}

Status PartitionRun::plan() {
  Planner& p = planner_;
  p.grid = Grid::make(out_.lo, out_.hi);
  const std::size_t cells = p.grid.cells();
  auto counted = count_positions(cells, [&](std::uint32_t* histogram, const Vec3f& v) { ++histogram[p.grid.cell(v)]; });
  if (!counted) return counted.status();
  const std::vector<std::uint32_t> histogram = std::move(*counted);
  // Chunk size: faces per chunk from the budget, of which a chunk owns at most 3/4; vertices per
  // chunk from the input's vertex/face ratio.
  const std::uint64_t chunk_faces = options_.max_chunk_faces > 0
                                        ? options_.max_chunk_faces
                                        : std::max<std::uint64_t>(shares_.per_chunk / kChunkBytesPerFace, 1);
  const double owned_faces = std::max(0.75 * static_cast<double>(chunk_faces), 1.0);
  const double ratio = out_.faces > 0 ? static_cast<double>(out_.vertices) / static_cast<double>(out_.faces) : 1.0;
  const std::uint64_t target = std::max<std::uint64_t>(static_cast<std::uint64_t>(std::ceil(owned_faces * ratio)), 1);
  // Split cells: a cell with more than a quarter of a chunk's vertices (dense input: the cells'
  // size is fixed, so their counts grow with the input) gets 8^k sub-cells, k the least that
  // brings a surface's share of it (a quarter per level) to an eighth of a chunk, at most
  // kMaxSplitBits; one more scan of positions.bin counts their vertices. Without this the
  // largest chunk would grow with the input (a single cell can hold more than a chunk), and the
  // chunk passes' memory follows the largest chunk.
  // A cell whose vertices gather in a small part of it (a cluster, not a surface across the
  // cell) leaves sub-cells above a quarter of a chunk: its k goes up by two and the sub-cells are
  // counted again, at most twice. The sub-cell counts stay within an eighth of the budget: k is
  // capped lower when many cells are dense, and not raised past it.
  auto dense = [&](std::uint32_t vertices) { return vertices > target / 4 && vertices >= 2; };
  auto split_bits = [&](std::uint32_t vertices, std::uint32_t cap) {
    std::uint32_t k = 1;
    while (k < cap && (vertices >> (2 * k)) > target / 8) ++k;
    return k;
  };
  const std::uint64_t max_entries = shares_.sub_cells / sizeof(std::uint32_t);
  std::uint32_t cap = kMaxSplitBits;
  for (;; --cap) {
    std::uint64_t entries = 0;
    for (std::uint32_t c = 0; c < cells; ++c)
      if (dense(histogram[c])) entries += std::uint64_t{1} << (3 * split_bits(histogram[c], cap));
    if (cap == 1 || entries <= max_entries) break;
  }
  p.cell_chunk.assign(cells, 0);
  for (std::uint32_t c = 0; c < cells; ++c) {
    if (!dense(histogram[c])) continue;
    p.cell_chunk[c] = Partition::kSplitCell | static_cast<std::uint32_t>(p.splits.size());
    p.splits.push_back({split_bits(histogram[c], cap), 0, {}});
  }
  // Each scan counts a split cell's sub-cells two levels finer than its k where the budget
  // allows (cells in order, while the counts fit), and the counts at k are their sums (a code at
  // k is the top bits of its sub-cells' codes at k + 2: floor(t * 2^(k+2)) >> 2 is floor(t * 2^k)).
  // A cell whose k is raised then has its counts already: the rounds decide as if each counted
  // at k, and scan again only for a cell raised past what it counted (a whole scan of the
  // positions for a few cells otherwise).
  std::vector<std::uint32_t> split_offset, sub_histogram, counted_bits, counted_offset, fine;
  bool scan = true;
  for (int round = 0; !p.splits.empty(); ++round) {
    if (scan) {
      counted_bits.clear();
      std::uint64_t entries = 0;
      for (const Partition::SplitCell& split : p.splits) entries += std::uint64_t{1} << (3 * split.k);
      for (const Partition::SplitCell& split : p.splits) {
        const std::uint32_t finer = std::min(split.k + 2, kMaxSplitBits);
        const std::uint64_t more = (std::uint64_t{1} << (3 * finer)) - (std::uint64_t{1} << (3 * split.k));
        const bool fits = entries + more <= max_entries;
        entries += fits ? more : 0;
        counted_bits.push_back(fits ? finer : split.k);
      }
      counted_offset.assign(1, 0);
      for (std::uint32_t bits : counted_bits) counted_offset.push_back(counted_offset.back() + (1u << (3 * bits)));
      auto sub_counted = count_positions(counted_offset.back(), [&](std::uint32_t* sub, const Vec3f& v) {
        const std::uint32_t entry = p.cell_chunk[p.grid.cell(v)];
        if (!(entry & Partition::kSplitCell)) return;
        const std::uint32_t index = entry & ~Partition::kSplitCell;
        ++sub[counted_offset[index] + p.grid.sub_code(v, counted_bits[index])];
      });
      if (!sub_counted) return sub_counted.status();
      fine = std::move(*sub_counted);
    }
    split_offset.assign(1, 0);
    for (const Partition::SplitCell& split : p.splits) split_offset.push_back(split_offset.back() + (1u << (3 * split.k)));
    sub_histogram.assign(split_offset.back(), 0);
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      const std::uint32_t shift = 3 * (counted_bits[i] - p.splits[i].k);
      for (std::uint32_t code = 0; code < (1u << (3 * counted_bits[i])); ++code)
        sub_histogram[split_offset[i] + (code >> shift)] += fine[counted_offset[i] + code];
    }
    if (round == 2) break;
    std::vector<std::uint32_t> raised(p.splits.size());
    std::uint64_t entries = 0;
    bool any_raised = false;
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      const std::uint32_t* first = sub_histogram.data() + split_offset[i];
      const std::uint32_t* last = sub_histogram.data() + split_offset[i + 1];
      const std::uint32_t heaviest = *std::max_element(first, last);
      raised[i] = heaviest > target / 4 ? std::min(p.splits[i].k + 2, kMaxSplitBits) : p.splits[i].k;
      any_raised |= raised[i] != p.splits[i].k;
      entries += std::uint64_t{1} << (3 * raised[i]);
    }
    if (!any_raised || entries > max_entries) break;
    scan = false;
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      p.splits[i].k = raised[i];
      scan |= raised[i] > counted_bits[i];
    }
  }
  std::vector<std::uint32_t>().swap(fine);
  // Cells in Morton order (a split cell's sub-cells in theirs); cell of Morton code m is order[m].
  std::vector<std::uint32_t> order(cells);
  for (std::uint32_t c = 0; c < cells; ++c) order[p.grid.morton(c)] = c;
  // Cells fill chunks greedily in Morton order: a cell that would take the current chunk past
  // the target starts the next one, so no chunk owns more than the target unless one cell
  // alone does (the chunk passes' memory follows the largest chunk, not the mean).
  std::uint32_t chunk = 0;
  bool any = false;
  auto count = [&](std::uint32_t vertices) {
    if (vertices == 0) return;
    const bool full = any && p.owned_vertices[chunk] + vertices > target;
    if (full) ++chunk;
    if (!any || full) p.owned_vertices.push_back(0);
    any = true;
    p.owned_vertices[chunk] += vertices;
  };
  for (std::uint32_t c : order) {
    if (!(p.cell_chunk[c] & Partition::kSplitCell)) {
      count(histogram[c]);
      p.cell_chunk[c] = chunk;
      continue;
    }
    const std::uint32_t index = p.cell_chunk[c] & ~Partition::kSplitCell;
    Partition::SplitCell& split = p.splits[index];
    const std::uint32_t* sub = sub_histogram.data() + split_offset[index];
    for (std::uint32_t code = 0; code < (1u << (3 * split.k)); ++code) {
      const std::uint32_t was = chunk;
      count(sub[code]);
      if (code == 0) split.first = chunk;
      else if (chunk != was) split.starts.push_back(code);
    }
  }
  p.chunks = any ? chunk + 1 : 0;
  // Owner pass: the owning chunk per vertex, so that no later scan recomputes cells. The scans
  // read owners only (4 bytes a vertex through the cache); positions.bin stays for load_chunk.
  owners_path_ = out_.dir + "/owners.bin";
  vertex_files_->owners = owners_path_;
  // The writes go to a thread of their own, so that the next stripe's owners are computed while
  // the kernel copies the last one into the page cache.
  SpillWriter owners;
  GM_RETURN_IF_ERROR(owners.open(owners_path_, std::size_t{1} << 20));
  FaceSpill no_faces;
  SpillThread owner_writes(owners, no_faces, options_.threads > 1);
  std::vector<std::uint32_t> records;
  records.resize(kPositionStripeVertices);
  GM_RETURN_IF_ERROR(scan_positions(
      *vertex_files_, out_.vertices, [&](std::size_t n, auto&& fn) { for_pieces(n, fn); },
      [&](std::uint64_t, std::span<const Vec3f> batch, std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) records[i] = p.owner(batch[i]);
      },
      [&](std::uint64_t, std::span<const Vec3f> batch) {
        return owner_writes.bytes(std::as_bytes(std::span(records.data(), batch.size())));
      }));
  GM_RETURN_IF_ERROR(owner_writes.finish());
  GM_RETURN_IF_ERROR(owners.close());
  bytes_spilled_ += owners.bytes();
  // The cell table stays with the partition for owner_of.
  for (int a = 0; a < 3; ++a) {
    out_.owner_map.lo[a] = p.grid.lo[a];
    out_.owner_map.scale[a] = p.grid.scale[a];
    out_.owner_map.n[a] = p.grid.n[a];
  }
  out_.owner_map.cell_chunk = std::move(p.cell_chunk);
  out_.owner_map.splits = std::move(p.splits);
  return {};
}

}  // namespace gaussmesh::stream::detail
