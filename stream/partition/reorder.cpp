// The spatial renumbering of a scattered input or a soup, out of core, welding on the way (the
// rules are in spatial_order.h; the passes and their cost in docs/partition.md, "Scattered input
// and soups"). Every pass reads its input sequentially and distributes records into buckets
// (bucket_file.h) sized so that one bucket's table fits the budget: the renumbering costs the
// same whatever the input's order.
#include <cstdio>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "format/record_file.h"
#include "stream/core/stopwatch.h"
#include "stream/partition/bucket_file.h"
#include "stream/partition/face_spill.h"
#include "stream/partition/partition_run.h"
#include "stream/partition/position_scan.h"
#include "stream/partition/spatial_order.h"
#include "stream/partition/spill_thread.h"
#include "stream/partition/spill_writer.h"

namespace gaussmesh::stream::detail {
namespace {

// A vertex sent to its range of cells: its place in the cell order (cells in Morton order, ids
// in order within) is counted again when the range is read, as its records come in id order.
struct PositionRecord {
  std::uint32_t id;  // the input's
  Vec3f p;
};
// An old id and its new id, for the map.
struct MapPair {
  std::uint32_t old_id;
  std::uint32_t new_id;
};
static_assert(sizeof(PositionRecord) == 16 && sizeof(MapPair) == 8);

template <class Record>
std::span<const Record> records_of(std::span<const std::byte> block) {
  return {reinterpret_cast<const Record*>(block.data()), block.size() / sizeof(Record)};
}

std::uint64_t ceil_div(std::uint64_t a, std::uint64_t b) { return (a + b - 1) / b; }
std::uint32_t floor_log2(std::uint64_t x) { return 63 - static_cast<std::uint32_t>(__builtin_clzll(x | 1)); }

// Every corner of `faces` (from face `first` of the spill at `path` on) names one of `vertices`.
Status check_corners(const std::string& path, std::span<const Triangle> faces, std::uint64_t first, std::uint64_t vertices) {
  for (std::size_t i = 0; i < faces.size(); ++i) {
    for (const std::uint32_t v : faces[i].v) {
      if (v >= vertices) {
        return Status::error(Code::kBadInput, path, "face " + std::to_string(first + i) + " names vertex " + std::to_string(v) + " of " +
                                                        std::to_string(vertices));
      }
    }
  }
  return {};
}

}  // namespace

template <class Fn>
Status PartitionRun::for_each_spilled_frame(Fn&& fn) {
  auto reader = format::RecordReader::open(faces_path_, kFaceSpillRecordKind, sizeof(Triangle));
  if (!reader) return reader.status();
  // The frames are decompressed a frame ahead on a thread of their own (with --threads > 1).
  FrameReadAhead ahead(**reader, nullptr, [](std::size_t) { return false; }, options_.threads > 1);
  std::vector<Triangle> frame;
  std::vector<std::uint32_t> no_tags;
  std::uint64_t f = 0, no_skip = 0;
  for (;;) {
    GM_RETURN_IF_ERROR(ahead.next(frame, no_tags, no_skip));
    if (frame.empty()) break;
    const std::span<const Triangle> faces(frame);
    GM_RETURN_IF_ERROR(check_corners(faces_path_, faces, f, out_.vertices));
    GM_RETURN_IF_ERROR(fn(faces));
    f += faces.size();
    if (options_.progress) options_.progress("reorder", f, out_.faces);
  }
  if (f != out_.faces) return Status::error(Code::kBadInput, faces_path_, "temporary file is shorter than written");
  return {};
}

bool PartitionRun::reorder_fits() const { return 3 * out_.faces < UINT32_MAX; }

Status PartitionRun::reorder(bool weld) {
  const std::uint64_t vertices = out_.vertices, faces = out_.faces;
  auto step = std::chrono::steady_clock::now();
  // Three eighths of the budget for the one table a pass holds (a range of positions, of the
  // old-to-new map, of face corners, or a run of faces to sort), a sixteenth for the buckets'
  // buffers, halved between two bucket files when a pass reads one and writes another.
  const std::uint64_t table = options_.reorder_table_bytes > 0 ? options_.reorder_table_bytes
                                                                : std::max<std::uint64_t>(options_.memory_bytes / 8 * 3, std::uint64_t{1} << 20);
  const std::size_t buffers = std::max<std::size_t>(options_.memory_bytes / 16, std::size_t{1} << 20);
  // A range of cells holds whole cells (or is one cell larger than that), at least the largest
  // group of one fine code that is welded; the table holds its records, their ordered copies and
  // the sort's keys.
  const std::uint64_t range_vertices =
      std::max<std::uint64_t>(table / (sizeof(PositionRecord) + sizeof(OrderedVertex) + sizeof(std::uint64_t)), kMaxWeldGroup);
  const std::uint64_t range_ids = std::max<std::uint64_t>(table / sizeof(std::uint32_t), 1024);
  // Slices of old ids for the corners' passes are powers of two (a shift per record, not a
  // division) and stay within 4 MiB of the map, so that its look-ups mostly hit the cache while
  // the slices stay few enough for large blocks.
  const std::uint32_t slice_bits = std::min<std::uint32_t>(floor_log2(range_ids), 20);
  // A run of faces to sort holds at least a group too large to be ordered (order_face_group).
  const std::uint64_t run_faces = std::max<std::uint64_t>(table / sizeof(Triangle), kMaxFaceGroup + 1);

  // 1. Vertices per cell; cells in Morton order packed into ranges of whole cells (a cell larger
  // than a range is a range of its own), each vertex's place in the cell order.
  const Grid grid = Grid::make(out_.lo, out_.hi);
  std::vector<std::uint32_t> code(grid.cells()), next(grid.cells(), 0), range_of(grid.cells());
  for (std::uint32_t c = 0; c < grid.cells(); ++c) code[c] = grid.morton(c);
  // The two scans of the positions read a batch and find its vertices' cells on the run's
  // threads (cell_of, in Morton order), then count or send them on this one.
  const auto in_pieces = [&](std::size_t n, auto&& fn) { for_pieces(n, fn); };
  std::vector<std::uint32_t> cell_of(kPositionStripeVertices);  // scan_positions: a stripe at most a batch
  const auto find_cells = [&](std::uint64_t, std::span<const Vec3f> batch, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) cell_of[i] = code[grid.cell(batch[i])];
  };
  GM_RETURN_IF_ERROR(scan_positions(*vertex_files_, vertices, in_pieces, find_cells, [&](std::uint64_t, std::span<const Vec3f> batch) {
    for (std::size_t i = 0; i < batch.size(); ++i) ++next[cell_of[i]];
    return Status{};
  }));
  // Per range: its first cell (Morton code) and first vertex in the cell order.
  std::vector<std::uint32_t> range_cell;
  std::vector<std::uint64_t> range_first;
  {
    std::uint64_t sum = 0, in_range = 0;
    for (std::uint32_t m = 0; m < next.size(); ++m) {
      const std::uint64_t n = next[m];
      if (range_cell.empty() || (n > 0 && in_range + n > range_vertices)) {
        range_cell.push_back(m);
        range_first.push_back(sum);
        in_range = 0;
      }
      range_of[m] = static_cast<std::uint32_t>(range_cell.size() - 1);
      in_range += n;
      next[m] = static_cast<std::uint32_t>(sum);
      sum += n;
    }
    range_cell.push_back(static_cast<std::uint32_t>(next.size()));
    range_first.push_back(sum);
  }
  const std::size_t ranges = range_cell.size() - 1;
  std::vector<std::uint32_t> cell_start = std::move(next);  // each cell's first place in the cell order

  // 2. The positions by range, each with its id.
  BucketFile moved;
  GM_RETURN_IF_ERROR(moved.open(out_.dir + "/reorder-positions.bin", ranges, sizeof(PositionRecord), buffers / ranges));
  GM_RETURN_IF_ERROR(scan_positions(*vertex_files_, vertices, in_pieces, find_cells, [&](std::uint64_t first, std::span<const Vec3f> batch) {
    for (std::size_t i = 0; i < batch.size(); ++i)
      GM_RETURN_IF_ERROR(moved.append(range_of[cell_of[i]], PositionRecord{static_cast<std::uint32_t>(first + i), batch[i]}));
    return Status{};
  }));
  std::vector<std::uint32_t>().swap(cell_of);
  GM_RETURN_IF_ERROR(moved.finish());
  bytes_spilled_ += moved.bytes();
  std::vector<std::uint32_t>().swap(range_of);

  // 3. Range by range: each cell sorted (VertexKey) and welded, the new position files written
  // in the new order (they replace the input's own records too), and each vertex's new id sent
  // by slice of old ids (the corners' slices below), so that each slice of the map is put
  // together from its own bucket when the corners are renamed. The whole map fits the table when
  // all the ids do.
  const bool map_fits = vertices <= range_ids;
  const std::uint64_t slices = ceil_div(vertices, std::uint64_t{1} << slice_bits);
  BucketFile pairs;
  GM_RETURN_IF_ERROR(pairs.open(out_.dir + "/reorder-pairs.bin", slices, sizeof(MapPair), buffers / slices));
  std::uint32_t kept = 0;
  {
    // The kept positions gather a stripe at a time (position_file: stripes alternate between
    // the files), written whole.
    SpillWriter positions[kPositionFiles];
    for (std::uint32_t i = 0; i < kPositionFiles; ++i)
      GM_RETURN_IF_ERROR(positions[i].open(vertex_files_->positions[i], std::size_t{1} << 16));
    std::vector<Vec3f> stripe(kPositionStripeVertices);
    const auto write_stripe = [&](std::uint32_t end) {  // the stripe holding kept id end - 1
      const std::uint32_t held = (end - 1) % kPositionStripeVertices + 1;
      return positions[position_file(end - 1)].write(stripe.data(), held * sizeof(Vec3f));
    };
    Status failed;
    const auto emit = [&](const OrderedVertex& v, bool joined) {
      if (!failed.is_ok()) return;
      if (!joined) {
        stripe[kept % kPositionStripeVertices] = v.p;
        if (++kept % kPositionStripeVertices == 0) failed = write_stripe(kept);
      }
      if (Status appended = pairs.append(v.key.id >> slice_bits, MapPair{v.key.id, kept - 1}); !appended.is_ok()) failed = std::move(appended);
    };
    const auto fine_of = [&](const Vec3f& p) { return grid.sub_code(p, kReorderFineBits); };
    std::vector<PositionRecord> range;
    std::vector<OrderedVertex> run;
    // The vertices of bucket r whose fine code is in [lo, hi), ordered.
    const auto order_codes = [&](std::size_t r, std::uint32_t lo, std::uint64_t hi) -> Status {
      run.clear();
      GM_RETURN_IF_ERROR(moved.read(r, [&](std::span<const std::byte> block) {
        for (const PositionRecord& p : records_of<PositionRecord>(block)) {
          const std::uint32_t f = fine_of(p.p);
          if (f >= lo && f < hi) run.push_back({VertexKey::of(f, p.p, p.id), p.p});
        }
        return Status{};
      }));
      order_run(run, weld, emit);
      return failed;
    };
    // Consecutive counts[i] from `from`, up to `cap` in all (at least one): the end.
    const auto pack = [](const std::vector<std::uint64_t>& counts, std::size_t from, std::uint64_t cap) {
      std::size_t to = from;
      for (std::uint64_t total = 0; to < counts.size() && (to == from || total + counts[to] <= cap); ++to) total += counts[to];
      return to;
    };
    constexpr std::uint32_t kHalf = 3 * kReorderFineBits / 2;  // a fine code's high and low halves
    for (std::size_t r = 0; r < ranges; ++r) {
      const std::uint64_t first = range_first[r], count = range_first[r + 1] - first;
      if (count > range_vertices) {  // only one cell holds vertices: ranges hold whole cells

        // One cell larger than the table: ordered in pieces of whole fine codes, found by
        // counting the codes' high halves, then within a high half too large the low halves;
        // a single code larger than the table is a group past kMaxWeldGroup, whose records
        // come in id order, its order.
        std::vector<std::uint64_t> high(std::size_t{1} << kHalf, 0);
        GM_RETURN_IF_ERROR(moved.read(r, [&](std::span<const std::byte> block) {
          for (const PositionRecord& p : records_of<PositionRecord>(block)) ++high[fine_of(p.p) >> kHalf];
          return Status{};
        }));
        for (std::size_t h = 0; h < high.size();) {
          if (high[h] == 0) {
            ++h;
            continue;
          }
          if (high[h] <= range_vertices) {
            const std::size_t end = pack(high, h, range_vertices);
            GM_RETURN_IF_ERROR(order_codes(r, static_cast<std::uint32_t>(h << kHalf), std::uint64_t{end} << kHalf));
            h = end;
            continue;
          }
          std::vector<std::uint64_t> low(std::size_t{1} << kHalf, 0);
          GM_RETURN_IF_ERROR(moved.read(r, [&](std::span<const std::byte> block) {
            for (const PositionRecord& p : records_of<PositionRecord>(block)) {
              const std::uint32_t f = fine_of(p.p);
              if (f >> kHalf == h) ++low[f & ((1u << kHalf) - 1)];
            }
            return Status{};
          }));
          const std::uint32_t base = static_cast<std::uint32_t>(h << kHalf);
          for (std::size_t l = 0; l < low.size();) {
            if (low[l] == 0) {
              ++l;
              continue;
            }
            if (low[l] > range_vertices) {
              GM_RETURN_IF_ERROR(moved.read(r, [&](std::span<const std::byte> block) {
                for (const PositionRecord& p : records_of<PositionRecord>(block))
                  if (fine_of(p.p) == base + l) emit({VertexKey::of(base + static_cast<std::uint32_t>(l), p.p, p.id), p.p}, false);
                return failed;
              }));
              ++l;
              continue;
            }
            const std::size_t end = pack(low, l, range_vertices);
            GM_RETURN_IF_ERROR(order_codes(r, base + static_cast<std::uint32_t>(l), std::uint64_t{base} + end));
            l = end;
          }
          ++h;
        }
        continue;
      }
      range.resize(count);
      const std::uint32_t cell0 = range_cell[r], cells = range_cell[r + 1] - cell0;
      std::vector<std::uint32_t> place(cell_start.begin() + cell0, cell_start.begin() + cell0 + cells);
      std::uint64_t got = 0;
      GM_RETURN_IF_ERROR(moved.read(r, [&](std::span<const std::byte> block) {
        for (const PositionRecord& p : records_of<PositionRecord>(block)) {
          const std::uint32_t m = code[grid.cell(p.p)] - cell0;
          if (m >= cells || place[m] - first >= count) {
            return Status::error(Code::kBadInput, out_.dir + "/reorder-positions.bin", "a vertex is in the wrong range");
          }
          range[place[m]++ - first] = p;
        }
        got += block.size() / sizeof(PositionRecord);
        return Status{};
      }));
      if (got != count) return Status::error(Code::kProcessing, "reorder", "a range of positions lost a vertex");
      // The cells are sorted on the run's threads, then emitted in order on this one.
      const auto cell_span = [&](std::uint32_t m) {
        const std::uint64_t begin = cell_start[m] - first;
        const std::uint64_t end = (m + 1 < cell_start.size() ? cell_start[m + 1] : range_first[ranges]) - first;
        return std::span<OrderedVertex>(run.data() + begin, end - begin);
      };
      run.resize(count);
      for_pieces(cells, [&](std::size_t from, std::size_t to) {
        std::vector<std::uint64_t> scratch;  // the sort's keys and their radix copy: twice the largest cell's
        for (std::size_t c = from; c < to; ++c) {
          const std::span<OrderedVertex> cell = cell_span(static_cast<std::uint32_t>(cell0 + c));
          const PositionRecord* in = range.data() + (cell.data() - run.data());
          for (std::size_t i = 0; i < cell.size(); ++i) cell[i] = {VertexKey::of(fine_of(in[i].p), in[i].p, in[i].id), in[i].p};
          scratch.resize(std::max(scratch.size(), 2 * cell.size()));
          sort_run(cell, scratch);
        }
      }, 16);  // cells hold a few hundred vertices: pieces of 16 at least
      for (std::uint32_t c = 0; c < cells; ++c) {
        emit_run(cell_span(cell0 + c), weld, emit);
        GM_RETURN_IF_ERROR(failed);
      }
    }
    if (kept % kPositionStripeVertices != 0) GM_RETURN_IF_ERROR(write_stripe(kept));
    std::vector<Vec3f>().swap(stripe);
    for (SpillWriter& p : positions) {
      GM_RETURN_IF_ERROR(p.close());
      bytes_spilled_ += p.bytes();
    }
    moved.remove();
    vertex_files_->input.reset();
  }
  GM_RETURN_IF_ERROR(pairs.finish());
  bytes_spilled_ += pairs.bytes();
  std::vector<std::uint32_t>().swap(cell_start);

  const std::uint64_t new_vertices = kept;
  out_.reorder_steps.vertices = seconds_since(step);
  step = std::chrono::steady_clock::now();
  // Entries [first, first + count) of the old-to-new map, from the pairs of their slices.
  const auto read_map = [&](std::uint32_t* out, std::uint64_t first, std::uint64_t count) -> Status {
    std::uint64_t got = 0;
    for (std::uint64_t r = first >> slice_bits; r < slices && (r << slice_bits) < first + count; ++r) {
      GM_RETURN_IF_ERROR(pairs.read(r, [&](std::span<const std::byte> block) {
        for (const MapPair& c : records_of<MapPair>(block)) {
          if (c.old_id - first >= count) return Status::error(Code::kProcessing, "reorder", "a vertex is in the wrong slice of the map");
          out[c.old_id - first] = c.new_id;
        }
        got += block.size() / sizeof(MapPair);
        return Status{};
      }));
    }
    if (got != count) return Status::error(Code::kProcessing, "reorder", "a slice of the map lost a vertex");
    return Status{};
  };
  // Buckets of lowest corners holding about half a table of faces each (a power of two of ids),
  // so that the ordering pass (7) holds a bucket and its ordered copy at once and reads it once.
  const std::uint32_t lowest_bits =
      floor_log2(std::max<std::uint64_t>(ceil_div(new_vertices, std::max<std::uint64_t>(ceil_div(faces * sizeof(Triangle), table / 2), 1)), 1));
  const std::uint64_t range_lowest = std::uint64_t{1} << lowest_bits;
  const std::uint64_t lowest_ranges = std::max<std::uint64_t>(ceil_div(new_vertices, range_lowest), 1);
  // The map is read at random (a scattered input's ids): the entries a few corners ahead are
  // fetched into the cache while the current one is renamed.
  constexpr std::size_t kAhead = 24;

  // 4–6. Faces renamed and turned to start at their lowest corner, in input order, by range of
  // that corner. When the whole map fits the table, corners are renamed as the face spill is
  // read; else every corner's old id goes to its slice of old ids (4), each slice is renamed in
  // place from its part of the map (5), and the faces are put together again from the slices in
  // input order (6): records of 4 bytes, no face or corner number carried along. These three
  // work in parts of the face spill's frames, one part per thread (up to four), each with files
  // and buckets of its own; pass 7 reads a bucket part after part, in input order.
  const std::size_t parts = map_fits ? 1 : std::clamp<std::size_t>(options_.threads, 1, 4);
  std::vector<BucketFile> grouped(parts);
  // fn(w) for every part w, on the run's threads; the first part's error, if any.
  const auto on_parts = [&](std::size_t n, auto&& fn) -> Status {
    std::vector<Status> status_of(n);
    for_pieces(n, [&](std::size_t from, std::size_t to) {
      for (std::size_t w = from; w < to; ++w) status_of[w] = fn(w);
    }, 1);
    for (Status& status : status_of) GM_RETURN_IF_ERROR(status);
    return Status{};
  };
  for (std::size_t w = 0; w < parts; ++w)
    GM_RETURN_IF_ERROR(grouped[w].open(out_.dir + "/reorder-faces-" + std::to_string(w) + ".bin", lowest_ranges, sizeof(Triangle),
                                       buffers / 2 / parts / lowest_ranges));
  if (map_fits) {
    std::vector<std::uint32_t> whole(vertices);
    GM_RETURN_IF_ERROR(read_map(whole.data(), 0, vertices));
    pairs.remove();
    GM_RETURN_IF_ERROR(for_each_spilled_frame([&](std::span<const Triangle> faces) -> Status {
      for (std::size_t i = 0; i < faces.size(); ++i) {
        if (i + kAhead / 3 < faces.size())
          for (const std::uint32_t v : faces[i + kAhead / 3].v) __builtin_prefetch(whole.data() + v);
        Triangle t = faces[i];
        for (std::uint32_t& v : t.v) v = whole[v];
        GM_RETURN_IF_ERROR(grouped[0].append(lowest_corner(t) >> lowest_bits, lowest_first(t)));
      }
      return {};
    }));
    ::unlink(faces_path_.c_str());  // read for the last time
  } else {
    // 4. Every corner's old id, by slice of old ids, and in face order which slice it went to
    // (Tag: a byte, or two past 256 slices; four only for a test's tiny table).
    const auto rename_by_slices = [&]<class Tag>(Tag) -> Status {
      // Parts of the face spill's frames, one per thread: each part's corners and tags go to
      // files of its own, so that the three passes run on every thread.
      std::vector<BucketFile> corners(parts);
      std::vector<std::string> corners_paths(parts), tags_paths(parts);
      std::vector<std::uint64_t> part_faces(parts, 0);
      const std::size_t tags_per_part = std::max<std::size_t>(buffers / 2 / parts / sizeof(Tag) / 3, 1) * 3;
      for (std::size_t w = 0; w < parts; ++w) {
        corners_paths[w] = out_.dir + "/reorder-corners-" + std::to_string(w) + ".bin";
        tags_paths[w] = out_.dir + "/reorder-slices-" + std::to_string(w) + ".bin";
        GM_RETURN_IF_ERROR(corners[w].open(corners_paths[w], slices, sizeof(std::uint32_t), buffers / 2 / parts / slices));
      }
      std::mutex progress_mutex;
      std::uint64_t progress_done = 0;
      const auto spread_corners = [&](std::size_t w) -> Status {
        auto reader = format::RecordReader::open(faces_path_, kFaceSpillRecordKind, sizeof(Triangle));
        if (!reader) return reader.status();
        const std::size_t frames = (*reader)->frame_count(), first_frame = frames * w / parts, end_frame = frames * (w + 1) / parts;
        std::uint64_t f = 0;  // the spill's face number, for the corner check's message
        for (std::size_t i = 0; i < first_frame; ++i) {
          auto skipped = (*reader)->skip();
          if (!skipped) return skipped.status();
          f += *skipped;
        }
        SpillWriter tag_file;
        GM_RETURN_IF_ERROR(tag_file.open(tags_paths[w], 1 << 16));
        std::vector<Tag> tags(tags_per_part);
        std::size_t used = 0;
        for (std::size_t i = first_frame; i < end_frame; ++i) {
          auto frame = (*reader)->next();
          if (!frame) return frame.status();
          const std::span<const Triangle> in = records_of<Triangle>(*frame);
          GM_RETURN_IF_ERROR(check_corners(faces_path_, in, f, vertices));
          for (std::size_t k = 0; k < in.size(); ++k) {
            for (const std::uint32_t v : in[k].v) {
              GM_RETURN_IF_ERROR(corners[w].append(v >> slice_bits, v));
              tags[used++] = static_cast<Tag>(v >> slice_bits);
            }
            if (used == tags.size()) {
              GM_RETURN_IF_ERROR(tag_file.write(tags.data(), used * sizeof(Tag)));
              used = 0;
            }
          }
          f += in.size();
          part_faces[w] += in.size();
          if (options_.progress) {
            std::lock_guard lock(progress_mutex);
            progress_done += in.size();
            options_.progress("reorder", progress_done, faces);
          }
        }
        GM_RETURN_IF_ERROR(tag_file.write(tags.data(), used * sizeof(Tag)));
        GM_RETURN_IF_ERROR(tag_file.close());
        GM_RETURN_IF_ERROR(corners[w].finish());
        return Status{};
      };
      GM_RETURN_IF_ERROR(on_parts(parts, spread_corners));
      std::uint64_t read = 0;
      for (std::size_t w = 0; w < parts; ++w) {
        read += part_faces[w];
        bytes_spilled_ += corners[w].bytes() + 3 * part_faces[w] * sizeof(Tag);
      }
      if (read != faces) return Status::error(Code::kBadInput, faces_path_, "temporary file is shorter than written");
      // The input's face spill is read for the last time: gone now, its pages need no writing back.
      ::unlink(faces_path_.c_str());

      // 5. Each slice's corners renamed in place from that slice of the map, in every part.
      {
        std::vector<std::uint32_t> slice(std::min(std::uint64_t{1} << slice_bits, vertices));
        for (std::size_t r = 0; r < slices; ++r) {
          const std::uint64_t first = std::uint64_t{r} << slice_bits, count = std::min(std::uint64_t{1} << slice_bits, vertices - first);
          GM_RETURN_IF_ERROR(read_map(slice.data(), first, count));
          GM_RETURN_IF_ERROR(on_parts(parts, [&](std::size_t w) {
            return corners[w].rewrite(r, [&](std::span<std::byte> block) {
              const std::span<std::uint32_t> ids{reinterpret_cast<std::uint32_t*>(block.data()), block.size() / sizeof(std::uint32_t)};
              for (std::size_t k = 0; k < ids.size(); ++k) {
                if (k + kAhead < ids.size() && ids[k + kAhead] - first < count) __builtin_prefetch(slice.data() + (ids[k + kAhead] - first));
                std::uint32_t& id = ids[k];
                if (id - first >= count) return Status::error(Code::kBadInput, corners_paths[w], "a corner is in the wrong slice");
                id = slice[id - first];
              }
              return Status{};
            });
          }));
        }
      }
      pairs.remove();

      // 6. Whole faces again, in input order: each corner the next renamed id of its slice, in
      // each part from its own tags and corners.
      GM_RETURN_IF_ERROR(on_parts(parts, [&](std::size_t w) -> Status {
        const int fd = ::open(tags_paths[w].c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) return Status::error(Code::kBadInput, tags_paths[w], "cannot open temporary file: " + errno_text());
        FdCloser closer{fd};
        std::vector<BucketFile::Cursor<std::uint32_t>> cursor;
        cursor.reserve(slices);
        for (std::size_t r = 0; r < slices; ++r) cursor.emplace_back(corners[w], r);
        const std::uint64_t per_read = tags_per_part / 3;
        std::vector<Tag> tags(3 * per_read);
        for (std::uint64_t done = 0; done < part_faces[w];) {
          const std::uint64_t take = std::min(per_read, part_faces[w] - done), bytes = 3 * take * sizeof(Tag);
          if (read_some(fd, tags.data(), bytes, 3 * done * sizeof(Tag)) != static_cast<std::int64_t>(bytes)) {
            return Status::error(Code::kBadInput, tags_paths[w], "temporary file is shorter than written");
          }
          for (std::uint64_t i = 0; i < 3 * take; i += 3) {
            Triangle t;
            for (std::uint32_t k = 0; k < 3; ++k) {
              const Tag r = tags[i + k];
              if (r >= slices || !cursor[r].next(t.v[k])) {
                if (r < slices) GM_RETURN_IF_ERROR(cursor[r].status());
                return Status::error(Code::kBadInput, tags_paths[w], "a corner is missing from its slice");
              }
            }
            GM_RETURN_IF_ERROR(grouped[w].append(lowest_corner(t) >> lowest_bits, lowest_first(t)));
          }
          done += take;
        }
        std::uint32_t extra = 0;
        for (auto& c : cursor)
          if (c.next(extra)) return Status::error(Code::kBadInput, corners_paths[w], "a slice holds a corner too many");
        ::unlink(tags_paths[w].c_str());
        corners[w].remove();
        return Status{};
      }));
      return Status{};
    };
    GM_RETURN_IF_ERROR(slices <= 256     ? rename_by_slices(std::uint8_t{})
                       : slices <= 65536 ? rename_by_slices(std::uint16_t{})
                                         : rename_by_slices(std::uint32_t{}));
  }
  for (BucketFile& part : grouped) {
    GM_RETURN_IF_ERROR(part.finish());
    bytes_spilled_ += part.bytes();
  }
  out_.reorder_steps.faces = seconds_since(step);
  step = std::chrono::steady_clock::now();

  // 7. The face spill in order (spatial_order.h): a bucket within half the table is read once
  // and placed by lowest corner in a copy; a larger one is counted, then sorted in runs of
  // lowest corners that fit the table (one read each). Each lowest corner's faces are ordered; a
  // vertex that is the lowest corner of more faces than a run holds is a run of its own,
  // streamed (past kMaxFaceGroup its faces stay in input order, the order they come in).
  const std::string ordered_path = out_.dir + "/faces-ordered.gmr";
  FaceSpill ordered;
  GM_RETURN_IF_ERROR(ordered.open(ordered_path, kRenumberedSpillLevel));
  {
    // The spill's compression runs on a thread of its own (with --threads > 1), beside the
    // sorting; it gets the faces in pieces, of which SpillThread copies a few at a time.
    SpillWriter no_positions;
    SpillThread spills(no_positions, ordered, options_.threads > 1);
    const auto write_ordered = [&](std::span<const Triangle> faces) -> Status {
      constexpr std::size_t kPiece = std::size_t{1} << 16;
      for (std::size_t at = 0; at < faces.size(); at += kPiece) GM_RETURN_IF_ERROR(spills.triangles(faces.subspan(at, std::min(kPiece, faces.size() - at))));
      return Status{};
    };
    // Bucket b's faces, part after part: in input order.
    const auto read_grouped = [&](std::size_t b, auto&& fn) -> Status {
      for (BucketFile& part : grouped) GM_RETURN_IF_ERROR(part.read(b, fn));
      return {};
    };
    std::vector<Triangle> run, staged;
    std::vector<std::uint32_t> at(range_lowest + 1);
    for (std::size_t b = 0; b < lowest_ranges; ++b) {
      const std::uint64_t base = b * range_lowest, ids = std::min(range_lowest, new_vertices - base);
      std::fill(at.begin(), at.end(), 0);
      std::uint64_t in_bucket = 0;
      for (const BucketFile& part : grouped) in_bucket += part.bucket_bytes(b) / sizeof(Triangle);
      if (2 * in_bucket <= run_faces) {  // read once, then counted and placed in memory
        staged.resize(in_bucket);
        auto* into = reinterpret_cast<std::byte*>(staged.data());
        for (BucketFile& part : grouped) {
          GM_RETURN_IF_ERROR(part.read_all(b, into));
          into += part.bucket_bytes(b);
        }
        for (const Triangle& t : staged) ++at[lowest_corner(t) - base];
        for (std::uint64_t v = 0, sum = 0; v <= ids; ++v) sum += std::exchange(at[v], static_cast<std::uint32_t>(sum));
        run.resize(staged.size());
        for (const Triangle& t : staged) run[at[lowest_corner(t) - base]++] = t;  // at[v]: the end of v's group now
        for (std::uint64_t v = 0, begin = 0; v < ids; ++v) {
          order_face_group(std::span<Triangle>(run.data() + begin, at[v] - begin));
          begin = at[v];
        }
        GM_RETURN_IF_ERROR(write_ordered(run));
        continue;
      }
      // A bucket larger than half a table (lowest corners of many faces): counted in one read,
      // then read once per run of lowest corners that fits the table.
      std::vector<Triangle>().swap(staged);
      GM_RETURN_IF_ERROR(read_grouped(b, [&](std::span<const std::byte> block) {
        for (const Triangle& t : records_of<Triangle>(block)) ++at[lowest_corner(t) - base];
        return Status{};
      }));
      for (std::uint64_t v0 = 0; v0 < ids;) {
        std::uint64_t v1 = v0 + 1, total = at[v0];
        while (v1 < ids && total + at[v1] <= run_faces) total += at[v1++];
        if (total == 0) {
          v0 = v1;
          continue;
        }
        const bool streamed = total > run_faces;  // one vertex alone
        std::vector<std::uint64_t> offset(v1 - v0, 0);
        for (std::uint64_t v = v0 + 1; v < v1; ++v) offset[v - v0] = offset[v - v0 - 1] + at[v - 1];
        if (!streamed) run.resize(total);
        GM_RETURN_IF_ERROR(read_grouped(b, [&](std::span<const std::byte> block) {
          std::span<const Triangle> in = records_of<Triangle>(block);
          if (streamed) {
            run.clear();
            for (const Triangle& t : in)
              if (lowest_corner(t) - base == v0) run.push_back(t);
            return write_ordered(run);
          }
          for (const Triangle& t : in) {
            const std::uint64_t v = lowest_corner(t) - base;
            if (v >= v0 && v < v1) run[offset[v - v0]++] = t;
          }
          return Status{};
        }));
        if (!streamed) {
          for (std::uint64_t v = v0, begin = 0; v < v1; ++v) {  // offset[v - v0]: the end of v's group now
            order_face_group(std::span<Triangle>(run.data() + begin, offset[v - v0] - begin));
            begin = offset[v - v0];
          }
          GM_RETURN_IF_ERROR(write_ordered(run));
        }
        v0 = v1;
      }
      std::vector<Triangle>().swap(run);
    }
    GM_RETURN_IF_ERROR(spills.finish());
  }
  GM_RETURN_IF_ERROR(ordered.close());
  for (BucketFile& part : grouped) part.remove();
  bytes_spilled_ += ordered.bytes();
  if (std::rename(ordered_path.c_str(), faces_path_.c_str()) != 0) {
    return Status::error(Code::kOutput, faces_path_, "cannot replace temporary file: " + errno_text());
  }
  out_.reorder_steps.spill = seconds_since(step);
  out_.reordered = true;
  out_.welded_vertices = vertices - new_vertices;
  out_.vertices = new_vertices;
  return {};
}

}  // namespace gaussmesh::stream::detail
