// The chunked finish's two rounds and the output's assembly. See out_of_core_finish.h.
#include "stream/pipeline/out_of_core_finish.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <span>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "format/record_file.h"
#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"
#include "stream/finish/finish_pieces.h"
#include "stream/pipeline/chunk_scheduler.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kPieceVertexRecordKind = 0x56464D47u;   // "GMFV"
constexpr std::uint32_t kPieceFaceRecordKind = 0x46464D47u;     // "GMFF"
constexpr std::uint32_t kOutputVertexRecordKind = 0x564F4D47u;  // "GMOV"
constexpr std::uint32_t kOutputFaceRecordKind = 0x464F4D47u;    // "GMOF"

// Round 1's survivors: input id, position, quadric.
struct PieceVertexRecord {
  std::uint32_t id;
  float x, y, z;
  std::int64_t q[11];
};
struct PieceFaceRecord {
  std::uint32_t id[3];
};
// Round 2's: each piece's own vertices, and its faces with the piece owning each corner.
struct OutputVertexRecord {
  std::uint32_t id;
  float x, y, z;
};
struct OutputFaceRecord {
  std::uint32_t owner[3], id[3];
};
static_assert(sizeof(PieceVertexRecord) == 104 && sizeof(PieceFaceRecord) == 12);
static_assert(sizeof(OutputVertexRecord) == 16 && sizeof(OutputFaceRecord) == 24);

constexpr std::uint64_t kReserve = std::uint64_t{20} << 20;
constexpr std::uint64_t kMinPieceFaces = 4096;

std::uint64_t thread_share(const MemoryBudget& budget, std::uint32_t threads) {
  const std::uint64_t whole = budget.is_limited() ? budget.after_reserve(kReserve) : std::uint64_t{256} << 20;
  return whole / std::max<std::uint32_t>(threads, 1);
}

std::uint64_t spread21(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

// Round 2's cells: the partition's halved on every axis and moved by a third of a half cell, so
// that no face of one lies on a face of a partition cell or of its split cells (at dyadic
// fractions of a cell): round 1's locked borders follow those. Codes are Morton codes.
class ShiftedGrid {
 public:
  explicit ShiftedGrid(const Partition::OwnerMap& m) {
    for (int a = 0; a < 3; ++a) lo_[a] = m.lo[a], scale_[a] = m.scale[a], last_[a] = m.n[a];
  }
  std::uint64_t code(const format::Vec3f& p) const {
    const double x[3] = {p.x, p.y, p.z};
    std::uint64_t c = 0;
    for (int a = 0; a < 3; ++a) {
      double t = (x[a] - lo_[a]) * scale_[a] + 0.5;
      if (!(t >= 0)) t = 0;  // NaN too
      if (t > last_[a]) t = last_[a];
      c |= spread21(std::uint64_t(t)) << a;
    }
    return c;
  }

 private:
  double lo_[3], scale_[3], last_[3];
};

template <class R>
format::Result<format::RecordSegment> write_segment(format::RecordSegmentFile& file, std::uint32_t kind,
                                                    std::span<const R> records) {
  auto writer = format::RecordWriter::create_in(file, kind, sizeof(R));
  if (!writer) return writer.status();
  GM_RETURN_IF_ERROR((*writer)->append(std::as_bytes(records)));
  GM_RETURN_IF_ERROR((*writer)->finish());
  return (*writer)->segment();
}

template <class R>
format::Status read_segment(const std::string& path, std::uint32_t kind, format::RecordSegment segment,
                            std::vector<R>& out) {
  out.clear();
  auto reader = format::RecordReader::open(path, kind, sizeof(R), segment);
  if (!reader) return reader.status();
  out.reserve((*reader)->records());
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    const std::size_t n = frame->size() / sizeof(R);
    const std::size_t at = out.size();
    out.resize(at + n);
    std::memcpy(out.data() + at, frame->data(), n * sizeof(R));
  }
  return format::Status();
}

format::Status damaged(const std::string& path, const std::string& what) {
  return format::Status::error(format::Code::kBadInput, path, what);
}

// Round 1's output of one piece.
struct Unit {
  std::uint32_t chunk = 0, piece = 0;
  std::uint32_t file = 0;
  format::RecordSegment vertices, faces;
  std::vector<std::uint64_t> codes;  // its vertices' cells, ascending, distinct
};

struct Totals {
  std::mutex mutex;
  std::uint64_t collapses = 0, refused = 0, over_error = 0, unheld = 0, input_faces = 0, faces = 0;
  double error = 0;
  void add(const PieceResult& r, std::uint64_t faces_in) {
    std::lock_guard lock(mutex);
    collapses += r.collapses, refused += r.refused, over_error += r.over_error, unheld += !r.manifold;
    input_faces += faces_in;
    faces += r.piece.faces.size();
    error = std::max(error, r.estimated_error);
  }
};

// Runs body(i) for i < count, `threads` at a time; the first error stops what has not started.
format::Status parallel_pieces(std::size_t count, std::uint32_t threads, const std::function<format::Status(std::size_t)>& body,
                               const std::function<void(std::size_t)>& done) {
  std::vector<format::Status> errors(count);
  std::atomic<bool> failed{false};
  std::atomic<std::size_t> finished{0};
  std::mutex done_mutex;
  tbb::task_arena arena(static_cast<int>(std::max<std::uint32_t>(threads, 1)));
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
      if (failed) return;
      format::Status st;
      tbb::this_task_arena::isolate([&] { st = body(i); });
      if (!st) {
        errors[i] = st;
        failed = true;
        return;
      }
      const std::size_t n = ++finished;
      std::lock_guard lock(done_mutex);
      done(n);
    }, tbb::simple_partitioner());
  });
  for (auto& e : errors)
    if (!e) return e;
  return format::Status();
}

// The face target of piece k of round 2 by cumulative rounding, so that the shares add up to
// the target exactly.
std::uint64_t share_of(std::uint64_t target, std::uint64_t before, std::uint64_t faces, std::uint64_t total) {
  auto at = [&](std::uint64_t c) { return std::uint64_t(std::llround(double(target) * double(c) / double(total))); };
  return at(before + faces) - at(before);
}

std::uint64_t faces_at_locked(const Piece& piece) {
  std::uint64_t n = 0;
  for (const auto& t : piece.faces)
    n += piece.vertices[t.v[0]].locked || piece.vertices[t.v[1]].locked || piece.vertices[t.v[2]].locked;
  return n;
}

}  // namespace

std::uint64_t chunked_finish_chunk_faces(const MemoryBudget& budget, std::uint32_t threads) {
  // A chunk owns about 3/4 of its file's faces (the rest is the overlap).
  const std::uint64_t per_face = kChunkFileBytesPerFace + kPieceBytesPerFace * 3 / 4;
  return std::max<std::uint64_t>(thread_share(budget, threads) / per_face, kMinPieceFaces);
}

format::Result<ChunkedFinish> chunked_finish(const Partition& partition, const ChunkedFinishOptions& options) {
  ChunkedFinish out;
  const FinishOptions& finish = options.finish;
  QuadricFrame frame;
  frame.origin = {partition.lo.x, partition.lo.y, partition.lo.z};
  const double diagonal = diagonal_of(partition.lo, partition.hi);
  frame.scale = diagonal > 0 ? diagonal : 1;
  const double max_error = finish.max_error / kMaxErrorMargin / frame.scale;
  const std::uint64_t share = thread_share(options.memory, options.threads);
  const ShiftedGrid grid(partition.owner_map);

  // Round 1: every chunk's pieces, collapsed to kRoundOneShare × their share of the target.
  auto start = Clock::now();
  const double round_one_ratio =
      finish.target_faces > 0 ? std::min(1.0, kRoundOneShare * double(finish.target_faces) / double(std::max<std::uint64_t>(partition.faces, 1)))
                              : 1.0;
  format::RecordSegmentPool pool_one(partition.dir + "/finish-1-");
  std::vector<Unit> units;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> histogram;  // (cell, faces whose lowest corner is in it)
  std::mutex units_mutex;
  Totals one;
  const format::Status round_one = for_each_chunk(
      partition, options.threads,
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace&) {
        const std::uint64_t load = kChunkFileBytesPerFace * chunk.triangles.size();
        const std::uint64_t max_piece = std::max(kMinPieceFaces, (share > load ? share - load : 0) / kPieceBytesPerFace);
        std::vector<Piece> pieces = chunk_pieces(chunk, frame, max_piece);
        format::RecordSegmentPool::Lease lease(pool_one);
        GM_RETURN_IF_ERROR(lease.status());
        for (std::size_t p = 0; p < pieces.size(); ++p) {
          const std::uint64_t faces_in = pieces[p].faces.size();
          DecimationOptions d;
          d.max_error = max_error;
          // The share of the faces free to go: faces at a locked vertex stay for round 2, and
          // counting them in the share would take their number out of the piece's inside.
          if (finish.target_faces > 0) {
            const std::uint64_t at_locked = faces_at_locked(pieces[p]);
            d.target_faces = at_locked + std::max<std::uint64_t>(1, std::uint64_t(std::ceil(round_one_ratio * double(faces_in - at_locked))));
          }
          PieceResult r = decimate_piece(std::move(pieces[p]), frame, d);
          one.add(r, faces_in);
          std::vector<PieceVertexRecord> vs(r.piece.vertices.size());
          Unit unit;
          unit.chunk = std::uint32_t(c), unit.piece = std::uint32_t(p), unit.file = lease.index();
          for (std::size_t v = 0; v < vs.size(); ++v) {
            const PieceVertex& pv = r.piece.vertices[v];
            vs[v].id = pv.id, vs[v].x = pv.position.x, vs[v].y = pv.position.y, vs[v].z = pv.position.z;
            std::memcpy(vs[v].q, pv.quadric.q.data(), sizeof(vs[v].q));
            unit.codes.push_back(grid.code(pv.position));
          }
          std::vector<PieceFaceRecord> fs(r.piece.faces.size());
          std::vector<std::uint64_t> face_codes(fs.size());
          for (std::size_t f = 0; f < fs.size(); ++f) {
            const auto& t = r.piece.faces[f].v;
            for (int k = 0; k < 3; ++k) fs[f].id[k] = r.piece.vertices[t[k]].id;
            face_codes[f] = unit.codes[std::min({t[0], t[1], t[2]})];  // vertices ascend by id
          }
          auto vseg = write_segment<PieceVertexRecord>(lease.file(), kPieceVertexRecordKind, vs);
          if (!vseg) return vseg.status();
          auto fseg = write_segment<PieceFaceRecord>(lease.file(), kPieceFaceRecordKind, fs);
          if (!fseg) return fseg.status();
          unit.vertices = *vseg, unit.faces = *fseg;
          std::sort(unit.codes.begin(), unit.codes.end());
          unit.codes.erase(std::unique(unit.codes.begin(), unit.codes.end()), unit.codes.end());
          std::sort(face_codes.begin(), face_codes.end());
          std::vector<std::pair<std::uint64_t, std::uint64_t>> counts;
          for (auto code : face_codes) {
            if (counts.empty() || counts.back().first != code) counts.push_back({code, 0});
            ++counts.back().second;
          }
          std::lock_guard lock(units_mutex);
          units.push_back(std::move(unit));
          histogram.insert(histogram.end(), counts.begin(), counts.end());
        }
        return format::Status();
      },
      [&](std::size_t done, std::size_t total) {
        if (options.progress) options.progress("finish round 1", done, total);
      },
      options.memory);
  if (!round_one) return round_one;
  out.input_faces = one.input_faces;
  out.round_one_pieces = units.size();
  out.round_one_faces = one.faces;
  out.collapses = one.collapses, out.refused = one.refused, out.over_error = one.over_error, out.unheld_pieces = one.unheld;
  out.estimated_error = one.error;
  out.seconds_round_one = seconds_since(start);
  release_free_memory();

  // The plan of round 2: cells in Morton order, filled greedily into pieces of at most
  // max_faces faces (a cell alone may hold more).
  start = Clock::now();
  std::sort(units.begin(), units.end(),
            [](const Unit& a, const Unit& b) { return a.chunk != b.chunk ? a.chunk < b.chunk : a.piece < b.piece; });
  std::sort(histogram.begin(), histogram.end());
  const std::uint64_t max_faces = std::max(kMinPieceFaces, share / kPieceBytesPerFace);
  std::vector<std::uint64_t> starts, piece_faces;
  std::uint64_t filled = 0;
  for (std::size_t i = 0; i < histogram.size();) {
    const std::uint64_t code = histogram[i].first;
    std::uint64_t count = 0;
    for (; i < histogram.size() && histogram[i].first == code; ++i) count += histogram[i].second;
    if (starts.empty() || (filled > 0 && filled + count > max_faces)) {
      starts.push_back(starts.empty() ? 0 : code);
      piece_faces.push_back(0);
      filled = 0;
    }
    filled += count;
    piece_faces.back() += count;
  }
  std::vector<std::pair<std::uint64_t, std::uint64_t>>().swap(histogram);
  if (starts.empty()) starts.push_back(0), piece_faces.push_back(0);
  const std::size_t pieces_two = starts.size();
  auto piece_of_code = [&](std::uint64_t code) {
    return std::uint32_t(std::upper_bound(starts.begin(), starts.end(), code) - starts.begin() - 1);
  };
  auto piece_of = [&](const format::Vec3f& p) { return piece_of_code(grid.code(p)); };
  // Which round-1 pieces each round-2 piece reads: those holding a vertex of its cells.
  std::vector<std::vector<std::uint32_t>> reads(pieces_two);
  for (std::size_t j = 0; j < units.size(); ++j) {
    std::uint32_t last = UINT32_MAX;
    for (auto code : units[j].codes) {
      const std::uint32_t k = piece_of_code(code);
      if (k != last) reads[k].push_back(std::uint32_t(j)), last = k;
    }
    std::vector<std::uint64_t>().swap(units[j].codes);
  }
  std::vector<std::uint64_t> before(pieces_two + 1, 0);
  for (std::size_t k = 0; k < pieces_two; ++k) before[k + 1] = before[k] + piece_faces[k];
  out.round_two_pieces = pieces_two;
  out.largest_round_two_piece = *std::max_element(piece_faces.begin(), piece_faces.end());

  // Round 2.
  format::RecordSegmentPool pool_two(partition.dir + "/finish-2-");
  struct Output {
    std::uint32_t file = 0;
    format::RecordSegment vertices, faces;
  };
  std::vector<Output> outputs(pieces_two);
  Totals two;
  const std::uint64_t total = before[pieces_two];
  // Round 2's piece k from the round-1 pieces it reads.
  auto build = [&](std::size_t k, Piece& piece) -> format::Status {
    struct Held {
      PieceVertexRecord record;
      std::uint8_t owned, shared;
    };
    std::vector<Held> held;
    std::vector<PieceFaceRecord> faces;
    std::vector<PieceVertexRecord> vs;
    std::vector<PieceFaceRecord> fs;
    std::vector<std::uint32_t> owner;
    std::vector<std::uint8_t> take, shared;
    for (std::uint32_t j : reads[k]) {
      const Unit& unit = units[j];
      const std::string path = pool_one.path(unit.file);
      GM_RETURN_IF_ERROR(read_segment(path, kPieceVertexRecordKind, unit.vertices, vs));
      GM_RETURN_IF_ERROR(read_segment(path, kPieceFaceRecordKind, unit.faces, fs));
      owner.resize(vs.size());
      for (std::size_t v = 0; v < vs.size(); ++v) {
        if (v > 0 && vs[v].id <= vs[v - 1].id) return damaged(path, "finish vertices out of order");
        owner[v] = piece_of({vs[v].x, vs[v].y, vs[v].z});
      }
      take.assign(vs.size(), 0);
      shared.assign(vs.size(), 0);
      auto index_of = [&](std::uint32_t id) -> std::int64_t {
        auto it = std::lower_bound(vs.begin(), vs.end(), id, [](const PieceVertexRecord& r, std::uint32_t x) { return r.id < x; });
        return it != vs.end() && it->id == id ? it - vs.begin() : -1;
      };
      for (const auto& f : fs) {
        std::int64_t i[3];
        for (int c = 0; c < 3; ++c)
          if ((i[c] = index_of(f.id[c])) < 0) return damaged(path, "a finish face names a vertex its piece lacks");
        const std::int64_t lowest = std::min({i[0], i[1], i[2]});
        if (owner[lowest] == k) {
          faces.push_back(f);
          for (int c = 0; c < 3; ++c) take[i[c]] = 1;
        } else {
          for (int c = 0; c < 3; ++c)
            if (owner[i[c]] == k) shared[i[c]] = 1;
        }
      }
      for (std::size_t v = 0; v < vs.size(); ++v) {
        const bool own = owner[v] == k;
        if (take[v] || own) held.push_back({vs[v], std::uint8_t(own), shared[v]});
      }
    }
    // One vertex per id: the quadrics of its copies summed (a vertex round 1 shared has a
    // part in each piece that held it), the shared flags joined.
    std::stable_sort(held.begin(), held.end(), [](const Held& a, const Held& b) { return a.record.id < b.record.id; });
    std::vector<std::uint8_t> owned;
    for (std::size_t i = 0; i < held.size();) {
      const PieceVertexRecord& r = held[i].record;
      PieceVertex v;
      v.id = r.id;
      v.position = {r.x, r.y, r.z};
      std::uint8_t own = held[i].owned, shares = held[i].shared;
      std::memcpy(v.quadric.q.data(), r.q, sizeof(r.q));
      std::size_t e = i + 1;
      for (; e < held.size() && held[e].record.id == r.id; ++e) {
        const PieceVertexRecord& o = held[e].record;
        if (std::memcmp(&o.x, &r.x, 3 * sizeof(float)) != 0)
          return format::Status::error(format::Code::kProcessing, "finish", "a shared vertex moved in round 1");
        FixedQuadric q;
        std::memcpy(q.q.data(), o.q, sizeof(o.q));
        v.quadric += q;
        shares |= held[e].shared;
      }
      v.locked = !own || shares;
      piece.vertices.push_back(v);
      owned.push_back(own);
      i = e;
    }
    std::vector<Held>().swap(held);
    piece.faces.reserve(faces.size());
    auto local = [&](std::uint32_t id) {
      return std::uint32_t(std::lower_bound(piece.vertices.begin(), piece.vertices.end(), id,
                                            [](const PieceVertex& p, std::uint32_t x) { return p.id < x; }) -
                           piece.vertices.begin());
    };
    for (const auto& f : faces) {
      format::Triangle t{{local(f.id[0]), local(f.id[1]), local(f.id[2])}};
      while (t.v[0] > t.v[1] || t.v[0] > t.v[2]) t = {{t.v[1], t.v[2], t.v[0]}};  // lowest first, same turn
      piece.faces.push_back(t);
    }
    std::vector<PieceFaceRecord>().swap(faces);
    std::sort(piece.faces.begin(), piece.faces.end(),
              [](const format::Triangle& a, const format::Triangle& b) { return std::lexicographical_compare(a.v, a.v + 3, b.v, b.v + 3); });
    if (piece.faces.size() != piece_faces[k])
      return format::Status::error(format::Code::kProcessing, "finish", "a round-2 piece has other faces than planned");
    return format::Status();
  };
  // The faces at locked vertices stay; the rest of the target is shared among the others in
  // proportion (as in round 1), so a count of both comes first.
  std::vector<std::uint64_t> locked_faces(pieces_two, 0), free_before(pieces_two + 1, 0);
  if (finish.target_faces > 0 && before[pieces_two] > finish.target_faces) {
    const format::Status counted = parallel_pieces(
        pieces_two, options.threads,
        [&](std::size_t k) -> format::Status {
          Piece piece;
          GM_RETURN_IF_ERROR(build(k, piece));
          locked_faces[k] = faces_at_locked(piece);
          return format::Status();
        },
        [&](std::size_t done) {
          if (options.progress) options.progress("finish round 2 locks", done, pieces_two);
        });
    if (!counted) return counted;
  }
  std::uint64_t all_locked = 0;
  for (std::size_t k = 0; k < pieces_two; ++k) {
    all_locked += locked_faces[k];
    free_before[k + 1] = free_before[k] + (piece_faces[k] - locked_faces[k]);
  }
  const format::Status round_two = parallel_pieces(
      pieces_two, options.threads,
      [&](std::size_t k) -> format::Status {
        Piece piece;
        GM_RETURN_IF_ERROR(build(k, piece));
        const std::uint64_t faces_in = piece.faces.size();
        DecimationOptions d;
        d.max_error = max_error;
        if (finish.target_faces > 0 && total > finish.target_faces) {
          const std::uint64_t left = finish.target_faces > all_locked ? finish.target_faces - all_locked : 0;
          const std::uint64_t free_total = free_before[pieces_two];
          d.target_faces = locked_faces[k] + (free_total > 0 ? share_of(left, free_before[k], faces_in - locked_faces[k], free_total) : 0);
          d.target_faces = std::max<std::uint64_t>(d.target_faces, 1);
        }
        PieceResult r = decimate_piece(std::move(piece), frame, d);
        if (getenv("GM_DEBUG")) fprintf(stderr, "r2 piece %zu: in %llu locked %llu target %llu out %zu collapses %llu refused %llu\n", k, (unsigned long long)faces_in, (unsigned long long)locked_faces[k], (unsigned long long)d.target_faces, r.piece.faces.size(), (unsigned long long)r.collapses, (unsigned long long)r.refused);
        two.add(r, faces_in);
        std::vector<OutputVertexRecord> ov;
        std::vector<std::uint32_t> corner_owner(r.piece.vertices.size());
        for (std::size_t v = 0; v < r.piece.vertices.size(); ++v) {
          const PieceVertex& pv = r.piece.vertices[v];
          corner_owner[v] = pv.locked ? piece_of(pv.position) : std::uint32_t(k);
          if (corner_owner[v] == k) ov.push_back({pv.id, pv.position.x, pv.position.y, pv.position.z});
        }
        std::vector<OutputFaceRecord> of(r.piece.faces.size());
        for (std::size_t f = 0; f < of.size(); ++f)
          for (int c = 0; c < 3; ++c) {
            const std::uint32_t v = r.piece.faces[f].v[c];
            of[f].owner[c] = corner_owner[v], of[f].id[c] = r.piece.vertices[v].id;
          }
        format::RecordSegmentPool::Lease lease(pool_two);
        GM_RETURN_IF_ERROR(lease.status());
        auto vseg = write_segment<OutputVertexRecord>(lease.file(), kOutputVertexRecordKind, ov);
        if (!vseg) return vseg.status();
        auto fseg = write_segment<OutputFaceRecord>(lease.file(), kOutputFaceRecordKind, of);
        if (!fseg) return fseg.status();
        outputs[k] = {lease.index(), *vseg, *fseg};
        return format::Status();
      },
      [&](std::size_t done) {
        if (options.progress) options.progress("finish round 2", done, pieces_two);
      });
  if (!round_two) return round_two;
  out.collapses += two.collapses, out.refused += two.refused, out.over_error += two.over_error;
  out.unheld_pieces += two.unheld;
  out.estimated_error = std::max(out.estimated_error, two.error) * frame.scale;
  out.seconds_round_two = seconds_since(start);
  release_free_memory();

  // The output: every round-2 piece's own vertices in piece order, then the faces.
  start = Clock::now();
  std::vector<std::vector<std::uint32_t>> ids(pieces_two);
  std::vector<std::uint64_t> offset(pieces_two + 1, 0);
  std::vector<OutputVertexRecord> ov;
  std::vector<OutputFaceRecord> of;
  for (std::size_t k = 0; k < pieces_two; ++k) {
    const std::string path = pool_two.path(outputs[k].file);
    GM_RETURN_IF_ERROR(read_segment(path, kOutputVertexRecordKind, outputs[k].vertices, ov));
    for (const auto& v : ov) {
      ids[k].push_back(v.id);
      out.mesh.positions.push_back({v.x, v.y, v.z});
    }
    offset[k + 1] = offset[k] + ov.size();
  }
  if (offset[pieces_two] > UINT32_MAX) return format::Status::error(format::Code::kProcessing, "finish", "over 2^32 output vertices");
  out.mesh.triangles.reserve(two.faces);
  for (std::size_t k = 0; k < pieces_two; ++k) {
    const std::string path = pool_two.path(outputs[k].file);
    GM_RETURN_IF_ERROR(read_segment(path, kOutputFaceRecordKind, outputs[k].faces, of));
    for (const auto& f : of) {
      format::Triangle t;
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t o = f.owner[c];
        if (o >= pieces_two) return damaged(path, "a finish face names a piece that does not exist");
        const auto& list = ids[o];
        auto it = std::lower_bound(list.begin(), list.end(), f.id[c]);
        if (it == list.end() || *it != f.id[c])
          return format::Status::error(format::Code::kProcessing, "finish", "a corner's owner did not keep it");
        t.v[c] = std::uint32_t(offset[o] + std::uint64_t(it - list.begin()));
      }
      out.mesh.triangles.push_back(t);
    }
  }
  out.seconds_assemble = seconds_since(start);
  return out;
}

}  // namespace gaussmesh::stream
