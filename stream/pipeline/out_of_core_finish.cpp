// The chunked finish's two rounds and the output's assembly. See out_of_core_finish.h.
#include "stream/pipeline/out_of_core_finish.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "format/record_file.h"
#include "stream/core/morton.h"
#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"
#include "stream/finish/finish_pieces.h"
#include "stream/pipeline/chunk_scheduler.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kPieceVertexRecordKind = 0x56464D47u;  // "GMFV"
constexpr std::uint32_t kPieceFaceRecordKind = 0x46464D47u;    // "GMFF"

// A round's survivors: input id, position, quadric, and whether the piece owns the vertex (it
// holds the vertex's whole quadric; a piece that does not holds only what the vertex absorbed
// there, so that the copies add up to the whole).
struct PieceVertexRecord {
  std::uint32_t id;
  float x, y, z;
  std::int64_t q[11];
  std::uint32_t owned, unused;
};
struct PieceFaceRecord {
  std::uint32_t id[3];
};
static_assert(sizeof(PieceVertexRecord) == 112 && sizeof(PieceFaceRecord) == 12);

constexpr std::uint64_t kMinPieceFaces = 4096;

// A piece's share of the budget: what the process keeps from the earlier passes
// (kept_memory_estimate) set aside (a quarter of the budget at least is left), then split among
// kPiecesInFlight pieces. Not by --threads: the pieces, and so the output, depend on the budget
// only; more threads than kPiecesInFlight do not add pieces in flight.
constexpr std::uint32_t kPiecesInFlight = 2;

std::uint64_t piece_share(const MemoryBudget& budget, std::uint64_t input_faces) {
  const std::uint64_t kept = kept_memory_estimate(input_faces);
  const std::uint64_t whole = !budget.is_limited() ? std::uint64_t{256} << 20
                              : budget.bytes() > kept + budget.bytes() / 4 ? budget.bytes() - kept
                                                                          : budget.bytes() / 4;
  return whole / kPiecesInFlight;
}

// The cells of round r ≥ 2: the partition's, moved by a fraction of a cell on every axis
// (round_offset), so that the new pieces' borders lie away from the last round's, which follow
// the previous grid's cell faces. Codes are Morton codes.
class ShiftedGrid {
 public:
  ShiftedGrid(const Partition::OwnerMap& m, double offset) : offset_(offset) {
    for (int a = 0; a < 3; ++a) lo_[a] = m.lo[a], scale_[a] = m.scale[a], last_[a] = m.n[a];
  }
  std::uint64_t code(const format::Vec3f& p) const {
    const double x[3] = {p.x, p.y, p.z};
    std::uint64_t c = 0;
    for (int a = 0; a < 3; ++a) {
      double t = (x[a] - lo_[a]) * scale_[a] + offset_;
      if (!(t >= 0)) t = 0;  // NaN too
      if (t > last_[a]) t = last_[a];
      c |= spread21(std::uint64_t(t)) << a;
    }
    return c;
  }

 private:
  double offset_, lo_[3], scale_[3], last_[3];
};

// Round r's shift: half a cell, then a quarter and three quarters, and so on between the
// earlier ones, so that each round's borders lie between the last round's.
double round_offset(int round) {
  static constexpr double kOffsets[] = {0, 0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875};
  return kOffsets[std::min<std::size_t>(std::size_t(round), std::size(kOffsets) - 1)];
}

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

// One piece's output of a round.
struct Unit {
  std::uint32_t file = 0;
  format::RecordSegment vertices, faces;
  std::uint64_t owned = 0;  // survivors it owns (each vertex is owned by one unit of a round)
  std::vector<std::uint64_t> codes;  // its vertices' cells in the next round's grid, ascending, distinct
};

// A round's output: its pieces (in a fixed order), and the faces whose lowest corner lies in each
// cell of the next round's grid.
struct RoundOutput {
  std::unique_ptr<format::RecordSegmentPool> pool;
  std::vector<Unit> units;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> histogram;
  std::uint64_t faces = 0;
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

// Writes one piece's survivors as a unit of its round: owned[v] says whether the piece owns
// survivor v; `absorbed_from` holds, for the vertices it does not own, the quadric they came in
// with, so that only what they absorbed is written. Their cells are taken in `next`.
format::Result<Unit> write_unit(format::RecordSegmentPool::Lease& lease, const Piece& piece,
                                const std::vector<std::uint8_t>& owned, const std::vector<PieceVertex>& absorbed_from,
                                const ShiftedGrid& next, std::vector<std::pair<std::uint64_t, std::uint64_t>>& counts) {
  Unit unit;
  unit.file = lease.index();
  std::vector<PieceVertexRecord> vs(piece.vertices.size());
  for (std::size_t v = 0; v < vs.size(); ++v) {
    const PieceVertex& pv = piece.vertices[v];
    FixedQuadric q = pv.quadric;
    if (!owned[v]) {
      auto it = std::lower_bound(absorbed_from.begin(), absorbed_from.end(), pv.id,
                                 [](const PieceVertex& a, std::uint32_t id) { return a.id < id; });
      if (it != absorbed_from.end() && it->id == pv.id)
        for (int i = 0; i < 11; ++i) q.q[i] = std::int64_t(std::uint64_t(q.q[i]) - std::uint64_t(it->quadric.q[i]));
    }
    vs[v] = {pv.id, pv.position.x, pv.position.y, pv.position.z, {}, owned[v], 0};
    unit.owned += owned[v];
    std::memcpy(vs[v].q, q.q.data(), sizeof(vs[v].q));
    unit.codes.push_back(next.code(pv.position));
  }
  std::vector<PieceFaceRecord> fs(piece.faces.size());
  std::vector<std::uint64_t> face_codes(fs.size());
  for (std::size_t f = 0; f < fs.size(); ++f) {
    const auto& t = piece.faces[f].v;
    for (int k = 0; k < 3; ++k) fs[f].id[k] = piece.vertices[t[k]].id;
    face_codes[f] = unit.codes[std::min({t[0], t[1], t[2]})];  // vertices ascend by id
  }
  auto vseg = write_segment<PieceVertexRecord>(lease.file(), kPieceVertexRecordKind, vs);
  if (!vseg) return vseg.status();
  auto fseg = write_segment<PieceFaceRecord>(lease.file(), kPieceFaceRecordKind, fs);
  if (!fseg) return fseg.status();
  unit.vertices = *vseg, unit.faces = *fseg;
  std::sort(unit.codes.begin(), unit.codes.end());
  unit.codes.erase(std::unique(unit.codes.begin(), unit.codes.end()), unit.codes.end());
  unit.codes.shrink_to_fit();  // kept for every unit of the round: a few cells, not a vertex each
  std::sort(face_codes.begin(), face_codes.end());
  for (auto code : face_codes) {
    if (counts.empty() || counts.back().first != code) counts.push_back({code, 0});
    ++counts.back().second;
  }
  return unit;
}

// A round's plan: the cells of its grid in Morton order, filled greedily into pieces of at most
// max_faces faces (a cell alone may hold more); piece k begins at code starts[k].
struct Plan {
  std::vector<std::uint64_t> starts, faces, before;  // before: faces of the pieces ahead of k
  std::vector<std::vector<std::uint32_t>> reads;     // the last round's units each piece reads
  std::uint32_t piece_of_code(std::uint64_t code) const {
    return std::uint32_t(std::upper_bound(starts.begin(), starts.end(), code) - starts.begin() - 1);
  }
};

Plan plan_round(RoundOutput& last, std::uint64_t max_faces) {
  Plan plan;
  auto& histogram = last.histogram;
  std::sort(histogram.begin(), histogram.end());
  std::uint64_t filled = 0;
  for (std::size_t i = 0; i < histogram.size();) {
    const std::uint64_t code = histogram[i].first;
    std::uint64_t count = 0;
    for (; i < histogram.size() && histogram[i].first == code; ++i) count += histogram[i].second;
    if (plan.starts.empty() || (filled > 0 && filled + count > max_faces)) {
      plan.starts.push_back(plan.starts.empty() ? 0 : code);
      plan.faces.push_back(0);
      filled = 0;
    }
    filled += count;
    plan.faces.back() += count;
  }
  std::vector<std::pair<std::uint64_t, std::uint64_t>>().swap(histogram);
  if (plan.starts.empty()) plan.starts.push_back(0), plan.faces.push_back(0);
  plan.before.assign(plan.starts.size() + 1, 0);
  for (std::size_t k = 0; k < plan.starts.size(); ++k) plan.before[k + 1] = plan.before[k] + plan.faces[k];
  // A piece reads every unit holding a vertex of its cells: so the owner of a vertex sees every
  // copy of it, and every face around it.
  plan.reads.resize(plan.starts.size());
  for (std::size_t j = 0; j < last.units.size(); ++j) {
    std::uint32_t previous = UINT32_MAX;
    for (auto code : last.units[j].codes) {
      const std::uint32_t k = plan.piece_of_code(code);
      if (k != previous) plan.reads[k].push_back(std::uint32_t(j)), previous = k;
    }
    std::vector<std::uint64_t>().swap(last.units[j].codes);
  }
  return plan;
}

// Piece k of a round from the last round's units it reads: the faces whose lowest corner it
// owns, their corners, and every vertex it owns; a vertex is locked unless the piece owns it and
// every face around it. owned[v] and `absorbed_from` (the quadrics of the vertices it does not
// own, as they came in) are for write_unit.
format::Status build_piece(const RoundOutput& last, const Plan& plan, const ShiftedGrid& grid, std::size_t k, Piece& piece,
                           std::vector<std::uint8_t>& owned, std::vector<PieceVertex>& absorbed_from) {
  struct Held {
    PieceVertexRecord record;
    std::uint8_t owned, shared;
  };
  std::vector<Held> held;
  std::vector<PieceFaceRecord> faces, fs;
  std::vector<PieceVertexRecord> vs;
  std::vector<std::uint32_t> owner, ids;
  std::vector<std::uint8_t> take, shared;
  for (std::uint32_t j : plan.reads[k]) {
    const Unit& unit = last.units[j];
    const std::string path = last.pool->path(unit.file);
    GM_RETURN_IF_ERROR(read_segment(path, kPieceVertexRecordKind, unit.vertices, vs));
    GM_RETURN_IF_ERROR(read_segment(path, kPieceFaceRecordKind, unit.faces, fs));
    owner.resize(vs.size());
    for (std::size_t v = 0; v < vs.size(); ++v) {
      if (v > 0 && vs[v].id <= vs[v - 1].id) return damaged(path, "finish vertices out of order");
      owner[v] = plan.piece_of_code(grid.code({vs[v].x, vs[v].y, vs[v].z}));
    }
    take.assign(vs.size(), 0);
    shared.assign(vs.size(), 0);
    // The faces' corners by binary search over the ids alone (the records are 112 B each),
    // without branches: the comparisons go either way at random, and the faces are many.
    ids.resize(vs.size());
    for (std::size_t v = 0; v < vs.size(); ++v) ids[v] = vs[v].id;
    auto index_of = [&](std::uint32_t id) -> std::int64_t {
      if (ids.empty()) return -1;
      const std::uint32_t* base = ids.data();
      for (std::size_t n = ids.size(); n > 1;) {
        const std::size_t half = n / 2;
        base = base[half] <= id ? base + half : base;
        n -= half;
      }
      return *base == id ? base - ids.data() : -1;
    };
    for (const auto& f : fs) {
      std::int64_t i[3];
      for (int c = 0; c < 3; ++c)
        if ((i[c] = index_of(f.id[c])) < 0) return damaged(path, "a finish face names a vertex its piece lacks");
      if (owner[std::min({i[0], i[1], i[2]})] == k) {
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
  // One vertex per id: the quadrics of its copies summed, the shared flags joined.
  std::stable_sort(held.begin(), held.end(), [](const Held& a, const Held& b) { return a.record.id < b.record.id; });
  piece = Piece{};
  owned.clear();
  absorbed_from.clear();
  for (std::size_t i = 0; i < held.size();) {
    const PieceVertexRecord& r = held[i].record;
    PieceVertex v;
    v.id = r.id;
    v.position = {r.x, r.y, r.z};
    std::uint8_t shares = held[i].shared;
    std::memcpy(v.quadric.q.data(), r.q, sizeof(r.q));
    std::size_t e = i + 1;
    for (; e < held.size() && held[e].record.id == r.id; ++e) {
      const PieceVertexRecord& o = held[e].record;
      if (std::memcmp(&o.x, &r.x, 3 * sizeof(float)) != 0)
        return format::Status::error(format::Code::kProcessing, "finish", "a shared vertex moved");
      FixedQuadric q;
      std::memcpy(q.q.data(), o.q, sizeof(o.q));
      v.quadric += q;
      shares |= held[e].shared;
    }
    v.locked = !held[i].owned || shares;
    piece.vertices.push_back(v);
    owned.push_back(held[i].owned);
    if (!held[i].owned) absorbed_from.push_back(v);
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
  std::sort(piece.faces.begin(), piece.faces.end(), [](const format::Triangle& a, const format::Triangle& b) {
    return std::lexicographical_compare(a.v, a.v + 3, b.v, b.v + 3);
  });
  if (piece.faces.size() != plan.faces[k])
    return format::Status::error(format::Code::kProcessing, "finish", "a piece has other faces than planned");
  return format::Status();
}


}  // namespace

// The last round's units, its plan and its grid: what the output is read from.
struct ChunkedOutput::Rounds {
  RoundOutput last;
  Plan plan;
  ShiftedGrid grid;
};

ChunkedOutput::ChunkedOutput(std::unique_ptr<Rounds> rounds, std::uint64_t vertices, std::string ids_prefix)
    : rounds_(std::move(rounds)), vertices_(vertices), ids_(std::make_unique<format::RecordSegmentPool>(std::move(ids_prefix))) {}
ChunkedOutput::~ChunkedOutput() = default;

std::uint64_t ChunkedOutput::face_count() const { return rounds_->last.faces; }

namespace {
constexpr std::uint32_t kOwnedIdRecordKind = 0x44494D47u;  // "GMID"
// Batches handed to a writer: about 1 MiB of positions or faces.
constexpr std::size_t kBatch = std::size_t{1} << 16;
}  // namespace

format::Status ChunkedOutput::vertices(const std::function<format::Status(std::span<const format::Vec3f>)>& batch) {
  const RoundOutput& last = rounds_->last;
  std::vector<PieceVertexRecord> vs;
  std::vector<format::Vec3f> positions;
  std::vector<std::uint32_t> ids;
  // The first reading writes each unit's owned ids for faces(); a later one only streams.
  const bool write_ids = offsets_.size() != last.units.size() + 1;
  std::optional<format::RecordSegmentPool::Lease> lease;
  if (write_ids) {
    lease.emplace(*ids_);
    GM_RETURN_IF_ERROR(lease->status());
    id_segments_.assign(last.units.size(), {});
    offsets_.assign(last.units.size() + 1, 0);
  }
  std::uint64_t owned = 0;
  for (std::size_t k = 0; k < last.units.size(); ++k) {
    const Unit& unit = last.units[k];
    GM_RETURN_IF_ERROR(read_segment(last.pool->path(unit.file), kPieceVertexRecordKind, unit.vertices, vs));
    ids.clear();
    for (const auto& v : vs) {
      if (!v.owned) continue;
      ids.push_back(v.id);
      positions.push_back({v.x, v.y, v.z});
      if (positions.size() == kBatch) {
        GM_RETURN_IF_ERROR(batch(positions));
        positions.clear();
      }
    }
    owned += ids.size();
    if (!write_ids) continue;
    auto segment = write_segment<std::uint32_t>(lease->file(), kOwnedIdRecordKind, ids);
    if (!segment) return segment.status();
    id_segments_[k] = *segment;
    ids_file_ = lease->index();
    offsets_[k + 1] = offsets_[k] + ids.size();
  }
  if (!positions.empty()) GM_RETURN_IF_ERROR(batch(positions));
  if (owned != vertices_ || offsets_.back() != vertices_)
    return format::Status::error(format::Code::kProcessing, "finish", "the units own other vertices than counted");
  return format::Status();
}

format::Status ChunkedOutput::faces(const std::function<format::Status(std::span<const format::Triangle>)>& batch) {
  const RoundOutput& last = rounds_->last;
  if (offsets_.size() != last.units.size() + 1)
    return format::Status::error(format::Code::kProcessing, "finish", "faces asked for before the vertices");
  // The owned ids of the units the faces' corners belong to, the most recent kCachedUnits of
  // them: corners lie in the unit or its neighbours, which come near it in unit order.
  constexpr std::size_t kCachedUnits = 64;
  std::vector<std::pair<std::uint32_t, std::vector<std::uint32_t>>> cache;
  std::uint64_t clock = 0;
  std::vector<std::uint64_t> used;
  auto ids_of = [&](std::uint32_t unit) -> format::Result<const std::vector<std::uint32_t>*> {
    for (std::size_t i = 0; i < cache.size(); ++i)
      if (cache[i].first == unit) {
        used[i] = ++clock;
        return &cache[i].second;
      }
    std::size_t slot = cache.size();
    if (cache.size() < kCachedUnits) {
      cache.push_back({unit, {}});
      used.push_back(0);
    } else {
      slot = std::size_t(std::min_element(used.begin(), used.end()) - used.begin());
      cache[slot].first = unit;
    }
    used[slot] = ++clock;
    GM_RETURN_IF_ERROR(read_segment(ids_->path(ids_file_), kOwnedIdRecordKind, id_segments_[unit], cache[slot].second));
    return &cache[slot].second;
  };
  std::vector<PieceVertexRecord> vs;
  std::vector<PieceFaceRecord> fs;
  std::vector<format::Triangle> triangles;
  for (std::size_t k = 0; k < last.units.size(); ++k) {
    const Unit& unit = last.units[k];
    const std::string path = last.pool->path(unit.file);
    GM_RETURN_IF_ERROR(read_segment(path, kPieceVertexRecordKind, unit.vertices, vs));
    GM_RETURN_IF_ERROR(read_segment(path, kPieceFaceRecordKind, unit.faces, fs));
    for (const auto& f : fs) {
      format::Triangle t;
      for (int c = 0; c < 3; ++c) {
        auto it = std::lower_bound(vs.begin(), vs.end(), f.id[c], [](const PieceVertexRecord& r, std::uint32_t x) { return r.id < x; });
        if (it == vs.end() || it->id != f.id[c]) return damaged(path, "a finish face names a vertex its piece lacks");
        // A corner this unit does not own is locked, so still where its owner's cell says.
        const std::uint32_t o = it->owned ? std::uint32_t(k) : rounds_->plan.piece_of_code(rounds_->grid.code({it->x, it->y, it->z}));
        if (o >= last.units.size()) return damaged(path, "a finish corner's owner does not exist");
        auto list = ids_of(o);
        if (!list) return list.status();
        auto at = std::lower_bound((*list)->begin(), (*list)->end(), f.id[c]);
        if (at == (*list)->end() || *at != f.id[c])
          return format::Status::error(format::Code::kProcessing, "finish", "a corner's owner did not keep it");
        t.v[c] = std::uint32_t(offsets_[o] + std::uint64_t(at - (*list)->begin()));
      }
      triangles.push_back(t);
      if (triangles.size() == kBatch) {
        GM_RETURN_IF_ERROR(batch(triangles));
        triangles.clear();
      }
    }
  }
  if (!triangles.empty()) GM_RETURN_IF_ERROR(batch(triangles));
  return format::Status();
}


std::uint64_t chunked_finish_chunk_faces(const MemoryBudget& budget) {
  // A chunk owns about 3/4 of its file's faces (the rest is the overlap).
  const std::uint64_t per_face = kChunkFileBytesPerFace + kPieceBytesPerFace * 3 / 4;
  // The input's size is not known yet: the most the process keeps, whatever the size.
  return std::max<std::uint64_t>(piece_share(budget, std::uint64_t{1} << 40) / per_face, kMinPieceFaces);
}

format::Result<ChunkedFinish> chunked_finish(const Partition& partition, const ChunkedFinishOptions& options) {
  ChunkedFinish out;
  const FinishOptions& finish = options.finish;
  QuadricFrame frame;
  frame.origin = {partition.lo.x, partition.lo.y, partition.lo.z};
  const double diagonal = diagonal_of(partition.lo, partition.hi);
  frame.scale = diagonal > 0 ? diagonal : 1;
  const double max_error = finish.max_error / kMaxErrorMargin / frame.scale;
  const std::uint64_t share = piece_share(options.memory, partition.faces);
  const std::uint32_t threads = std::min(options.threads, kPiecesInFlight);
  const std::uint64_t target = finish.target_faces;

  // Round 1: every chunk's pieces, collapsed to kRoundOneShare × their share of the target.
  auto start = Clock::now();
  const double round_one_ratio =
      target > 0 ? std::min(1.0, kRoundOneShare * double(target) / double(std::max<std::uint64_t>(partition.faces, 1))) : 1.0;
  RoundOutput last;
  last.pool = std::make_unique<format::RecordSegmentPool>(partition.dir + "/finish-1-");
  struct Numbered {
    std::uint64_t chunk, piece;
    Unit unit;
  };
  std::vector<Numbered> numbered;
  std::mutex mutex;
  Totals totals;
  ShiftedGrid next(partition.owner_map, round_offset(2));
  const format::Status round_one = for_each_chunk(
      partition, threads,
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace&) {
        const std::uint64_t load = kChunkFileBytesPerFace * chunk.triangles.size();
        const std::uint64_t max_piece = std::max(kMinPieceFaces, (share > load ? share - load : 0) / kPieceBytesPerFace);
        std::vector<Piece> pieces = chunk_pieces(chunk, frame, max_piece);
        format::RecordSegmentPool::Lease lease(*last.pool);
        GM_RETURN_IF_ERROR(lease.status());
        for (std::size_t p = 0; p < pieces.size(); ++p) {
          const std::uint64_t faces_in = pieces[p].faces.size();
          DecimationOptions d;
          d.max_error = max_error;
          // The share of the faces free to go: faces at a locked vertex stay for the next round,
          // and counting them in the share would take their number out of the piece's inside.
          if (target > 0) {
            const std::uint64_t at_locked = faces_at_locked(pieces[p]);
            d.target_faces = at_locked + std::max<std::uint64_t>(1, std::uint64_t(std::ceil(round_one_ratio * double(faces_in - at_locked))));
            // Sweeps first, to kSweepShare × the share (where that is at most half the faces).
            const std::uint64_t free = faces_in - at_locked;
            d.sweep_to_faces = at_locked + std::uint64_t(std::ceil(
                sweep_share_of_faces(free, std::uint64_t(std::ceil(round_one_ratio / kRoundOneShare * double(free)))) * double(free)));
          }
          PieceResult r = decimate_piece(std::move(pieces[p]), frame, d);
          totals.add(r, faces_in);
          // Round 1's copies of a shared vertex are each its own faces' part of the quadric.
          std::vector<std::uint8_t> owned(r.piece.vertices.size(), 1);
          std::vector<std::pair<std::uint64_t, std::uint64_t>> counts;
          auto unit = write_unit(lease, r.piece, owned, {}, next, counts);
          if (!unit) return unit.status();
          std::lock_guard lock(mutex);
          numbered.push_back({c, p, std::move(unit).value()});
          last.histogram.insert(last.histogram.end(), counts.begin(), counts.end());
        }
        return format::Status();
      },
      [&](std::size_t done, std::size_t total) {
        if (options.progress) options.progress("finish round 1", done, total);
      },
      options.memory);
  if (!round_one) return round_one;
  std::sort(numbered.begin(), numbered.end(),
            [](const Numbered& a, const Numbered& b) { return a.chunk != b.chunk ? a.chunk < b.chunk : a.piece < b.piece; });
  for (auto& n : numbered) last.units.push_back(std::move(n.unit));
  std::vector<Numbered>().swap(numbered);
  last.faces = totals.faces;
  out.input_faces = totals.input_faces;
  out.round_faces.push_back(last.faces);
  out.round_pieces.push_back(last.units.size());
  out.seconds_rounds.push_back(seconds_since(start));
  release_free_memory();

  // Rounds 2, 3, …: pieces of a shifted grid, until the target is met or a round gains little.
  const std::uint64_t max_faces = std::max(kMinPieceFaces, share / kPieceBytesPerFace);
  Plan plan;
  std::unique_ptr<ShiftedGrid> grid;
  for (int round = 2;; ++round) {
    start = Clock::now();
    grid = std::make_unique<ShiftedGrid>(next);
    next = ShiftedGrid(partition.owner_map, round_offset(round + 1));
    plan = plan_round(last, max_faces);
    const std::size_t pieces = plan.starts.size();
    out.largest_piece = std::max(out.largest_piece, *std::max_element(plan.faces.begin(), plan.faces.end()));
    const std::uint64_t total = plan.before[pieces];
    // The faces at locked vertices stay; the rest of the target is shared among the other faces
    // in proportion, as in round 1: so both are counted first.
    std::vector<std::uint64_t> locked_faces(pieces, 0), free_before(pieces + 1, 0);
    const bool by_share = target > 0 && total > target;
    if (by_share) {
      const format::Status counted = parallel_pieces(
          pieces, threads,
          [&](std::size_t k) -> format::Status {
            Piece piece;
            std::vector<std::uint8_t> owned;
            std::vector<PieceVertex> absorbed_from;
            GM_RETURN_IF_ERROR(build_piece(last, plan, *grid, k, piece, owned, absorbed_from));
            locked_faces[k] = faces_at_locked(piece);
            return format::Status();
          },
          [&](std::size_t) {});
      if (!counted) return counted;
    }
    std::uint64_t all_locked = 0;
    for (std::size_t k = 0; k < pieces; ++k) {
      all_locked += locked_faces[k];
      free_before[k + 1] = free_before[k] + (plan.faces[k] - locked_faces[k]);
    }
    // When the locked faces of round 2 take more than their share of the target (see
    // kLastRoundLockedShare), it cannot place the target well: it takes the free faces to half
    // round 1's density and leaves the rest to round 3, whose borders lie elsewhere. From round 3
    // on every round aims at the target.
    const double ratio =
        target > 0 ? std::min(1.0, kRoundOneShare / 2 * double(target) / double(std::max<std::uint64_t>(total, 1))) : 1;
    // Taking the free faces to twice the target's density leaves at most all_locked + 2 × target
    // faces: when those fit one piece, round 3 has no locked vertex.
    const double locked_share =
        all_locked + 2 * target <= max_faces ? options.last_round_locked_share_before_one_piece : kLastRoundLockedShare;
    const bool last_squeeze = double(all_locked) <= locked_share * double(target) || ratio >= 1 || round >= 3;
    RoundOutput now;
    now.pool = std::make_unique<format::RecordSegmentPool>(partition.dir + "/finish-" + std::to_string(round) + "-");
    now.units.resize(pieces);
    std::vector<std::vector<std::pair<std::uint64_t, std::uint64_t>>> counts(pieces);
    Totals round_totals;
    const format::Status done = parallel_pieces(
        pieces, threads,
        [&](std::size_t k) -> format::Status {
          Piece piece;
          std::vector<std::uint8_t> owned;
          std::vector<PieceVertex> absorbed_from;
          GM_RETURN_IF_ERROR(build_piece(last, plan, *grid, k, piece, owned, absorbed_from));
          const std::uint64_t faces_in = piece.faces.size();
          DecimationOptions d;
          d.max_error = max_error;
          if (by_share && !last_squeeze) {
            d.target_faces = locked_faces[k] + std::max<std::uint64_t>(
                1, std::uint64_t(std::ceil(ratio * double(faces_in - locked_faces[k]))));
          } else if (by_share) {
            const std::uint64_t left = target > all_locked ? target - all_locked : 0;
            const std::uint64_t free_total = free_before[pieces];
            d.target_faces = std::max<std::uint64_t>(
                1, locked_faces[k] + (free_total > 0 ? share_of(left, free_before[k], faces_in - locked_faces[k], free_total) : 0));
          } else if (target > 0) {
            d.target_faces = faces_in;  // the target is met: this round only gathers the pieces
          }
          std::vector<std::uint32_t> ids;
          for (const auto& v : piece.vertices) ids.push_back(v.id);
          PieceResult r = decimate_piece(std::move(piece), frame, d);
          round_totals.add(r, faces_in);
          // Survivors keep their ownership (a free one is owned; it may have moved out of its cell).
          std::vector<std::uint8_t> own(r.piece.vertices.size());
          for (std::size_t v = 0; v < own.size(); ++v)
            own[v] = owned[std::size_t(std::lower_bound(ids.begin(), ids.end(), r.piece.vertices[v].id) - ids.begin())];
          format::RecordSegmentPool::Lease lease(*now.pool);
          GM_RETURN_IF_ERROR(lease.status());
          auto unit = write_unit(lease, r.piece, own, absorbed_from, next, counts[k]);
          if (!unit) return unit.status();
          now.units[k] = std::move(unit).value();
          return format::Status();
        },
        [&](std::size_t n) {
          if (options.progress) options.progress("finish round", n, pieces);
        });
    if (!done) return done;
    for (auto& c : counts) now.histogram.insert(now.histogram.end(), c.begin(), c.end());
    now.faces = round_totals.faces;
    totals.collapses += round_totals.collapses, totals.refused += round_totals.refused;
    totals.over_error += round_totals.over_error, totals.unheld += round_totals.unheld;
    totals.error = std::max(totals.error, round_totals.error);
    const std::uint64_t before_round = last.faces;
    last = std::move(now);
    out.round_faces.push_back(last.faces);
    out.round_pieces.push_back(pieces);
    out.round_locked_faces.push_back(all_locked);
    out.seconds_rounds.push_back(seconds_since(start));
    release_free_memory();
    // Stop once the target is met, when a round removed under 1 % of what it had, or at the
    // last round.
    if ((target > 0 && last.faces <= target) || (!by_share && target > 0) || last.faces * 100 > before_round * 99 ||
        round >= kMaxRounds)
      break;
  }
  out.collapses = totals.collapses, out.refused = totals.refused, out.over_error = totals.over_error;
  out.unheld_pieces = totals.unheld;
  out.estimated_error = totals.error * frame.scale;

  std::uint64_t vertices = 0;
  for (const auto& unit : last.units) vertices += unit.owned;
  out.output = std::make_unique<ChunkedOutput>(std::make_unique<ChunkedOutput::Rounds>(ChunkedOutput::Rounds{std::move(last), std::move(plan), *grid}),
                                               vertices, partition.dir + "/finish-ids-");

  return out;
}

}  // namespace gaussmesh::stream
