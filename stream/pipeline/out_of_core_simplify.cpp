// simplify out of core: passes A-C over the chunks and the stitch. See chunk_simplify.h.
#include "stream/pipeline/out_of_core_simplify.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <map>
#include <mutex>
#include <numbers>
#include <span>

#include "format/file_io.h"
#include "format/record_file.h"

#include "stream/partition/id_indexed_file.h"
#include "stream/stitch/paper_chains.h"
#include "stream/stitch/piece_joins.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;


format::Status damaged(const std::string& what) { return format::Status::error(format::Code::kBadInput, "stitch", what); }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Loads every chunk and calls body (stream/sampling/chunk_sampler.h for_each_chunk), reporting `pass`.
format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const char* pass,
                              const OutOfCoreSimplifyOptions& options, const ChunkBody& body) {
  return stream::for_each_chunk(
      partition, threads, body,
      [&](std::size_t done, std::size_t total) {
        if (options.progress) options.progress(pass, done, total, partition.faces);
      },
      options.partition.memory_bytes);
}

format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of, std::uint64_t faces,
                              std::uint32_t threads, const char* pass, const OutOfCoreSimplifyOptions& options,
                              const ChunkBody& body) {
  return stream::for_each_chunk(
      count, info_of, threads, body,
      [&](std::size_t done, std::size_t total) {
        if (options.progress) options.progress(pass, done, total, faces);
      },
      options.partition.memory_bytes);
}

// Adds the cross product (b - a) x (c - a), in doubles, to sum: a face's vector area, twice over.
void add_cross_product(const format::Vec3f& a, const format::Vec3f& b, const format::Vec3f& c, std::array<double, 3>& sum) {
  const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  sum[0] += uy * vz - uz * vy;
  sum[1] += uz * vx - ux * vz;
  sum[2] += ux * vy - uy * vx;
}

}  // namespace

format::Status find_chunk_loops(const ChunkMesh& chunk, const MeshAdjacency& sampler_adjacency,
                                std::span<const std::uint32_t> patch,
                                const std::function<bool(std::uint32_t)>& is_corner,
                                const std::vector<GlobalSample>& samples, ChunkLoops& out) {
  const std::size_t nf = chunk.triangles.size();
  // The mesher leaves collapsed faces and repeats of a vertex set out, and walks an adjacency
  // without them. A face and its repeats share their vertices, so they are owned by one chunk and
  // travel together: the chunk sees every repeat the whole mesh has.
  // A loop chunk has none (write_loop_chunk writes none for a chunk with any).
  bool any_repeat = false;
  const std::vector<std::uint8_t> skip = chunk.core_face.empty()
                                             ? faces_the_mesher_skips(chunk.triangles, sampler_adjacency, &any_repeat)
                                             : std::vector<std::uint8_t>(nf, 0);
  MeshAdjacency without_repeats;
  if (any_repeat) {
    std::vector<format::Triangle> kept(chunk.triangles);
    for (std::size_t f = 0; f < nf; ++f)
      if (skip[f]) kept[f] = {{kept[f].v[0], kept[f].v[0], kept[f].v[0]}};
    GM_RETURN_IF_ERROR(build_mesh_adjacency({chunk.positions, kept}, without_repeats));
  }
  const MeshAdjacency& adjacency = any_repeat ? without_repeats : sampler_adjacency;
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  const auto& tris = chunk.triangles;
  if (patch.size() != nf) return format::Status::error(format::Code::kProcessing, "pass C", "one merged patch per chunk face expected");
  auto border = [&](std::uint32_t f, int i) {
    const std::uint32_t g = nb[3 * std::size_t{f} + i];
    return g == MeshAdjacency::kNoFace || patch[g] != patch[f];
  };
  // Half-edges of owned faces on a patch border (ascending id, as faces are in ascending global
  // id), with their successor around the end vertex (the polygon mesher's next_border, under the
  // merged patches): its id, and its index here when an owned face holds it.
  struct Half {
    std::uint64_t id, next;
    std::uint32_t from, patch, succ;
    bool is_break;
  };
  std::vector<Half> halves;
  std::vector<std::uint32_t> half_of(3 * nf, kNone);
  const bool loop_chunk = !chunk.core_face.empty();
  if (loop_chunk && chunk.core_face.size() != nf) return format::Status::error(format::Code::kProcessing, "pass C", "one core flag per chunk face expected");
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f] || skip[f] || (loop_chunk && !chunk.core_face[f])) continue;
    for (int i = 0; i < 3; ++i) {
      if (!border(f, i)) continue;
      const auto [g, j] = next_loop_half_edge(adjacency, tris.data(), f, i, border);
      std::uint64_t next = ~std::uint64_t{0};
      std::uint32_t next_local = kNone;
      if (g != MeshAdjacency::kNoFace) {
        next = 3 * chunk.global_face[g] + static_cast<std::uint64_t>(j);
        if (chunk.owned_face[g] && !skip[g]) next_local = 3 * g + static_cast<std::uint32_t>(j);
      }
      half_of[3 * std::size_t{f} + i] = static_cast<std::uint32_t>(halves.size());
      halves.push_back({3 * chunk.global_face[f] + static_cast<std::uint64_t>(i), next, tris[f].v[i], patch[f],
                        next_local, nb[3 * std::size_t{f} + i] == MeshAdjacency::kNoFace});
    }
  }
  for (Half& h : halves) h.succ = h.succ == kNone ? kNone : half_of[h.succ];
  half_of = {};
  // Runs: from every half-edge no owned half-edge leads to, along successors while they are
  // here; what is left are loops inside the chunk, each one run from its lowest id.
  std::vector<std::uint8_t> has_pred(halves.size(), 0), taken(halves.size(), 0);
  for (const Half& h : halves)
    if (h.succ != kNone) has_pred[h.succ] = 1;
  auto emit_run = [&](std::uint32_t start) {
    LoopRunRecord run;
    run.first = halves[start].id;
    run.min_id = run.first;
    run.offset = out.run_vertices.size();
    run.patch = halves[start].patch;
    run.chunk = chunk.chunk;
    std::uint32_t at = start;
    for (;;) {
      const Half& h = halves[at];
      taken[at] = 1;
      if (h.id < run.min_id) {
        run.min_id = h.id;
        run.min_index = run.length;
      }
      ++run.length;
      run.breaks += h.is_break;
      out.run_vertices.push_back({chunk.global_vertex[h.from], chunk.positions[h.from]});
      run.next = h.next;
      // A successor on another patch, or taken already (a successor with two predecessors), ends
      // the run too: the stitch refuses what does not close into loops.
      if (h.succ == kNone || h.succ == start || taken[h.succ] || halves[h.succ].patch != run.patch) break;
      at = h.succ;
    }
    out.runs.push_back(run);
  };
  for (std::uint32_t k = 0; k < halves.size(); ++k)
    if (!has_pred[k] && !taken[k]) emit_run(k);
  for (std::uint32_t k = 0; k < halves.size(); ++k)
    if (!taken[k]) emit_run(k);
  // Owned vertices with feature edges, and owned samples: in a loop chunk, its loop vertices
  // (their stars are whole there; the others have no feature edge and are no samples).
  if (loop_chunk && chunk.loop_vertex.size() != chunk.positions.size())
    return format::Status::error(format::Code::kProcessing, "pass C", "one loop flag per chunk vertex expected");
  for (std::uint32_t v = 0; v < chunk.positions.size(); ++v) {
    if (!chunk.owned_vertex[v] || (loop_chunk && !chunk.loop_vertex[v])) continue;
    const std::uint32_t gv = chunk.global_vertex[v];
    std::uint32_t degree = 0, out_breaks = 0, in_breaks = 0, w = 0, u = 0;
    for (std::uint32_t k = adjacency.star_begin(v); k < adjacency.star_end(v); ++k) {
      const std::uint32_t f = corners[k] / 3, i = corners[k] % 3;
      if (border(f, static_cast<int>(i))) ++degree;
      if (nb[3 * std::size_t{f} + i] == MeshAdjacency::kNoFace) {
        ++out_breaks;
        w = tris[f].v[(i + 1) % 3];
      }
      if (nb[3 * std::size_t{f} + (i + 2) % 3] == MeshAdjacency::kNoFace) {
        ++degree;
        ++in_breaks;
        u = tris[f].v[(i + 2) % 3];
      }
    }
    const auto s = std::lower_bound(samples.begin(), samples.end(), gv,
                                    [](const GlobalSample& a, std::uint32_t x) { return a.vertex < x; });
    const bool is_sample = s != samples.end() && s->vertex == gv;
    if (degree == 0 && !is_sample) continue;
    const bool is_turn = degree == 2 && out_breaks == 1 && in_breaks == 1 &&
                         turns_at_boundary(chunk.positions[u], chunk.positions[v], chunk.positions[w]);
    if (!is_sample && degree == 2 && !is_turn && !is_corner(gv)) continue;  // a plain chain vertex
    LoopVertexRecord r;
    r.vertex = gv;
    r.position = chunk.positions[v];
    r.degree = degree;
    if (is_sample) {
      r.role = VertexRole::kSample;
    } else if (degree == 1 || degree >= 3 || is_corner(gv)) {
      r.role = VertexRole::kCorner;
    } else if (is_turn) {
      r.role = VertexRole::kCorner;
    }
    if (is_sample && degree == 0 && adjacency.star_end(v) > adjacency.star_begin(v))
      r.interior_patch = patch[corners[adjacency.star_begin(v)] / 3];
    out.vertices.push_back(r);
  }
  // Vector areas of the merged patches, over owned faces. Neighbouring faces mostly share a patch:
  // the last patch's sum is kept at hand (a map lookup per face cost a quarter of this function).
  // Each patch still sums its faces in face order.
  if (loop_chunk) return format::Status();
  std::map<std::uint32_t, std::array<double, 3>> areas;
  std::uint32_t last_patch = kNone;
  std::array<double, 3>* last_sum = nullptr;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f] || skip[f]) continue;
    if (patch[f] != last_patch || last_sum == nullptr) {
      last_patch = patch[f];
      last_sum = &areas[last_patch];
    }
    const auto& p = chunk.positions;
    add_cross_product(p[tris[f].v[0]], p[tris[f].v[1]], p[tris[f].v[2]], *last_sum);
  }
  for (const auto& [p, sum] : areas) out.areas.emplace_back(p, sum);
  return format::Status();
}

format::Result<bool> write_loop_chunk(const ChunkMesh& chunk, const ChunkInfo& info, const MeshAdjacency& adjacency,
                                      const std::vector<std::uint32_t>& piece_index, const std::vector<std::uint8_t>& feature,
                                      const std::vector<GlobalSample>& samples, format::RecordSegmentFile& file,
                                      ChunkInfo& loop_info, std::vector<std::array<double, 3>>& piece_area) {
  const std::size_t nf = chunk.triangles.size(), nv = chunk.positions.size();
  const auto& tris = chunk.triangles;
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  if (piece_index.size() != nf) return format::Status::error(format::Code::kProcessing, "pass A", "one piece index per chunk face expected");
  if (feature.size() != nf) return format::Status::error(format::Code::kProcessing, "pass A", "feature bits per chunk face expected");
  piece_area.clear();
  if (nf == 0) return false;
  bool any_repeat = false;
  const std::vector<std::uint8_t> skip = faces_the_mesher_skips(tris, adjacency, &any_repeat);
  if (any_repeat || std::find(skip.begin(), skip.end(), 1) != skip.end()) return false;
  // R: both ends of an owned face's feature edges (a loop's half-edge and its successor around
  // the end vertex need that vertex's whole star, owned or not), the owned ends of the other
  // faces' feature edges (their vertex records), owned samples. An owned vertex's edges have all
  // their faces here, so their bits are the whole mesh's.
  std::vector<std::uint8_t> in_r(nv, 0);
  for (std::uint32_t f = 0; f < nf; ++f) {
    const unsigned bits = feature[f] & 7u;
    if (bits == 0) continue;
    const auto& t = tris[f].v;
    const bool owned = chunk.owned_face[f];
    for (int i = 0; i < 3; ++i) {
      if (!(bits >> i & 1)) continue;
      const std::uint32_t a = t[i], b = t[(i + 1) % 3];
      if (owned || chunk.owned_vertex[a]) in_r[a] = 1;
      if (owned || chunk.owned_vertex[b]) in_r[b] = 1;
    }
  }
  for (const GlobalSample& s : samples) {
    const auto it = std::lower_bound(chunk.global_vertex.begin(), chunk.global_vertex.end(), s.vertex);
    if (it == chunk.global_vertex.end() || *it != s.vertex) return format::Status::error(format::Code::kProcessing, "pass A", "a sample the chunk does not hold");
    in_r[static_cast<std::size_t>(it - chunk.global_vertex.begin())] = 1;
  }
  // Core faces touch R; the file holds them and every face on an edge of theirs: an edge with
  // an end in R has its faces in that end's star, all core; the faces on the others are found
  // across the edge when it is manifold (the two faces that hold it, one each way: no third
  // face holds both ends), else in the star of one end (a walk of the star per edge was a tenth
  // of this function).
  std::vector<std::uint8_t> keep(nf, 0);
  for (std::uint32_t f = 0; f < nf; ++f) {
    const auto& t = tris[f].v;
    if (in_r[t[0]] || in_r[t[1]] || in_r[t[2]]) keep[f] = 2;
  }
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (keep[f] != 2) continue;
    const auto& t = tris[f].v;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = t[i], b = t[(i + 1) % 3];
      if (in_r[a] || in_r[b]) continue;
      if (const std::uint32_t g = nb[3 * std::size_t{f} + i]; g != MeshAdjacency::kNoFace) {
        if (keep[g] == 0) keep[g] = 1;
        continue;
      }
      for (std::uint32_t k = adjacency.star_begin(a); k < adjacency.star_end(a); ++k) {
        const std::uint32_t g = corners[k] / 3;
        const auto& u = tris[g].v;
        if (keep[g] == 0 && (u[0] == b || u[1] == b || u[2] == b)) keep[g] = 1;
      }
    }
  }
  std::vector<std::uint32_t> kept;
  for (std::uint32_t f = 0; f < nf; ++f)
    if (keep[f]) kept.push_back(f);
  if (4 * kept.size() > 3 * nf) return false;
  // Each piece's vector area, over its faces in face order (as find_chunk_loops sums a patch's).
  std::uint32_t pieces = 0;
  for (std::uint32_t f = 0; f < nf; ++f)
    if (chunk.owned_face[f]) pieces = std::max(pieces, piece_index[f] + 1);
  piece_area.assign(pieces, {0, 0, 0});
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f]) continue;
    const auto& p = chunk.positions;
    add_cross_product(p[tris[f].v[0]], p[tris[f].v[1]], p[tris[f].v[2]], piece_area[piece_index[f]]);
  }
  // Frames of 128 KiB, encoded one at a time: this runs while the sampler's arrays are held, and
  // a whole-chunk buffer, 1 MiB frames and the zstd tables sized for them were 5-7 MB of peak at
  // 1M triangles (zstd sizes its tables by the frame).
  format::RecordWriterOptions options;
  options.columns = {{8, true}, {4, true}, {4, true}, {4, true}, {1, false}, {4, false}};
  options.frame_bytes = std::size_t{128} << 10;
  auto writer = format::RecordWriter::create_in(file, kLoopChunkRecordKind, kLoopChunkRecordBytes, options);
  if (!writer) return writer.status();
  const std::size_t per_frame = (*writer)->frame_limit() / kLoopChunkRecordBytes;
  std::vector<std::byte> records(std::min(kept.size(), per_frame) * kLoopChunkRecordBytes);
  loop_info = info;
  loop_info.path = file.path();
  loop_info.loop = true;
  loop_info.faces = kept.size();
  loop_info.owned_faces = 0;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const std::uint32_t f = kept[k];
    std::byte* r = records.data() + (k % per_frame) * kLoopChunkRecordBytes;
    std::uint32_t v[3];
    std::uint8_t flags = 0;
    for (int j = 0; j < 3; ++j) {
      v[j] = chunk.global_vertex[tris[f].v[j]];
      flags |= static_cast<std::uint8_t>(chunk.owned_vertex[tris[f].v[j]] << j);
      if (in_r[tris[f].v[j]]) flags |= static_cast<std::uint8_t>(kLoopCornerVertex << j);
    }
    if (chunk.owned_face[f]) flags |= kOwnsFace;
    if (keep[f] == 2) flags |= kCoreFace;
    const std::uint32_t piece = chunk.owned_face[f] ? piece_index[f] : 0xFFFFFFFFu;
    loop_info.owned_faces += chunk.owned_face[f];
    std::memcpy(r, &chunk.global_face[f], 8);
    std::memcpy(r + 8, v, 12);
    r[20] = std::byte{flags};
    std::memcpy(r + 21, &piece, 4);
    if ((k + 1) % per_frame == 0 || k + 1 == kept.size())
      GM_RETURN_IF_ERROR((*writer)->append(std::span(records).first((k % per_frame + 1) * kLoopChunkRecordBytes)));
  }
  GM_RETURN_IF_ERROR((*writer)->finish());
  loop_info.segment = (*writer)->segment();
  return true;
}

format::Result<ChunkLoopSummary> spill_chunk_loops(ChunkLoops&& loops, format::RecordSegmentFile& file) {
  ChunkLoopSummary out;
  out.runs = std::move(loops.runs);
  out.vertices = std::move(loops.vertices);
  out.areas = std::move(loops.areas);
  out.entries = loops.run_vertices.size();
  if (out.entries == 0) return out;
  out.path = file.path();
  auto writer = format::RecordWriter::create_in(file, kLoopVertexRecordKind, sizeof(LoopVertexEntry));
  if (!writer) return writer.status();
  static_assert(sizeof(LoopVertexEntry) == 16, "16 bytes per run vertex on disk");
  GM_RETURN_IF_ERROR((*writer)->append(std::as_bytes(std::span(loops.run_vertices))));
  GM_RETURN_IF_ERROR((*writer)->finish());
  out.bytes = (*writer)->bytes_written();
  out.segment = (*writer)->segment();
  loops.run_vertices = {};
  return out;
}

namespace {

// Positions by dense vertex id from the file stitch_loops writes: 12 bytes per vertex, read with
// pread on demand (the mesher caches what it reads).
class FilePositions final : public VertexPositionSource {
 public:
  FilePositions(int fd, std::string path, std::size_t count) : fd_(fd), path_(std::move(path)), count_(count) {}
  ~FilePositions() override { ::close(fd_); }
  format::Vec3f position(std::uint32_t v) override {
    float xyz[3] = {0, 0, 0};
    if (v >= count_ || ::pread(fd_, xyz, sizeof xyz, static_cast<off_t>(std::uint64_t{v} * sizeof xyz)) != sizeof xyz) {
      if (status_.is_ok())
        status_ = format::Status::error(format::Code::kOutput, path_, "cannot read the position of loop vertex " + std::to_string(v));
      return {};
    }
    return {xyz[0], xyz[1], xyz[2]};
  }
  // Ascending ids: one read per run of nearby ids (read_by_ascending_id); an id it cannot serve
  // (out of range, out of order, a failed read) is read alone, which records the error.
  void positions(std::span<const std::uint32_t> ids, std::span<format::Vec3f> out) override {
    ids = ids.first(std::min(ids.size(), out.size()));
    while (!ids.empty()) {
      const std::size_t served = read_by_ascending_id(fd_, count_, sizeof(format::Vec3f), ids, window_,
                                                      [&](std::size_t i, const std::byte* record) {
                                                        std::memcpy(&out[i], record, sizeof(format::Vec3f));
                                                      });
      if (served < ids.size()) out[served] = position(ids[served]);
      const std::size_t next = std::min(served + 1, ids.size());
      ids = ids.subspan(next);
      out = out.subspan(next);
    }
  }
  format::Status status() const override { return status_; }

 private:
  int fd_;
  std::string path_;
  std::size_t count_;
  format::Status status_;
  std::vector<std::byte> window_;
};

// The loop stitch's loop file: one dense vertex id (4 bytes) per entry, written at its place by
// write and read back a loop at a time by the mesher.
class FileLoopVertices final : public LoopVertexSource {
 public:
  FileLoopVertices(int fd, std::string path, std::uint64_t entries) : fd_(fd), path_(std::move(path)), entries_(entries) {}
  ~FileLoopVertices() override { ::close(fd_); }
  format::Status write(std::uint64_t first, std::span<const std::uint32_t> ids) {
    if (first + ids.size() > entries_) return damaged("a loop run lies outside its loop");
    if (!format::write_all(fd_, ids.data(), ids.size_bytes(), first * sizeof(std::uint32_t)))
      return format::Status::error(format::Code::kOutput, path_, "cannot write loop vertices: " + std::string(std::strerror(errno)));
    return format::Status();
  }
  bool read(std::uint64_t first, std::span<std::uint32_t> out) override {
    if (first + out.size() <= entries_ && format::pread_all(fd_, out.data(), out.size_bytes(), first * sizeof(std::uint32_t))) return true;
    if (status_.is_ok())
      status_ = format::Status::error(format::Code::kOutput, path_, "cannot read loop vertices " + std::to_string(first) + " on");
    return false;
  }
  format::Status status() const override { return status_; }

 private:
  int fd_;
  std::string path_;
  std::uint64_t entries_;
  format::Status status_;
};

// The dense id of a global id: its lower bound in `global` (ascending, distinct), searched only
// among the ids that share its high bits, through a table of where each block of 2^shift ids
// starts — a quarter of global's size at most. A binary search over all of global took a third of
// the loop stitch at 100M triangles (2.7M half-edges, 1.3M vertices, three lookups per vertex).
class DenseIds {
 public:
  explicit DenseIds(const std::vector<std::uint32_t>& global) : global_(global) {
    const std::uint64_t span = global.empty() ? 1 : std::uint64_t{global.back()} + 1;
    const std::uint64_t entries = std::max<std::uint64_t>(global.size() / 4, 1);
    while ((span >> shift_) > entries) ++shift_;
    first_.resize((span >> shift_) + 2);
    std::size_t at = 0;
    for (std::size_t b = 0; b < first_.size(); ++b) {
      const std::uint64_t lo = std::uint64_t{b} << shift_;
      while (at < global.size() && global[at] < lo) ++at;
      first_[b] = static_cast<std::uint32_t>(at);
    }
  }
  std::uint32_t operator()(std::uint32_t v) const {
    const std::size_t b = v >> shift_;
    if (b + 1 >= first_.size()) return static_cast<std::uint32_t>(global_.size());
    const auto begin = global_.begin() + first_[b], end = global_.begin() + first_[b + 1];
    return static_cast<std::uint32_t>(std::lower_bound(begin, end, v) - global_.begin());
  }

 private:
  const std::vector<std::uint32_t>& global_;
  unsigned shift_ = 0;
  std::vector<std::uint32_t> first_;
};

// Calls body(run index in chunk, index in run, entry) for every run vertex of a chunk's file,
// checking the file against the summary (its runs tile the records in order).
template <class Body>
format::Status read_run_vertices(const ChunkLoopSummary& chunk, Body&& body) {
  std::uint64_t expect = 0;
  for (const LoopRunRecord& r : chunk.runs) {
    if (r.offset != expect || r.length == 0) return damaged("the runs of " + chunk.path + " do not tile its records");
    expect += r.length;
  }
  if (expect != chunk.entries) return damaged("the runs of " + chunk.path + " do not tile its records");
  if (chunk.entries == 0) return format::Status();
  auto reader = format::RecordReader::open(chunk.path, kLoopVertexRecordKind, sizeof(LoopVertexEntry), chunk.segment);
  if (!reader) return reader.status();
  if ((*reader)->records() != chunk.entries) return damaged(chunk.path + " holds a different number of run vertices");
  std::uint64_t at = 0;
  std::size_t run = 0;
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    for (std::size_t k = 0; k + sizeof(LoopVertexEntry) <= frame->size(); k += sizeof(LoopVertexEntry), ++at) {
      if (at >= chunk.entries) return damaged(chunk.path + " holds more run vertices than its runs");
      while (at >= chunk.runs[run].offset + chunk.runs[run].length) ++run;
      LoopVertexEntry e;
      std::memcpy(&e, frame->data() + k, sizeof e);
      body(run, static_cast<std::uint32_t>(at - chunk.runs[run].offset), e);
    }
  }
  if (at != chunk.entries) return damaged(chunk.path + " holds fewer run vertices than its runs");
  return format::Status();
}

}  // namespace

format::Result<PolygonGraphInput> stitch_loops(const std::vector<ChunkLoopSummary>& chunks, std::size_t patches,
                                               const std::vector<format::Vec3f>& plane_normal, const std::string& dir,
                                               const std::vector<std::pair<std::uint32_t, format::Vec3f>>& extra_vertices,
                                               LoopStitchStats* stats) {
  PolygonGraphInput g;
  g.patches = patches;
  g.patch_area.assign(patches, {0, 0, 0});
  g.patch_has_faces.assign(patches, 0);
  g.plane_normal = plane_normal;
  // Runs by first half-edge id.
  struct RunRef {
    std::uint64_t first;
    std::uint32_t chunk, index;
  };
  std::vector<RunRef> by_first;
  std::size_t total_runs = 0, total_records = extra_vertices.size();
  for (const ChunkLoopSummary& c : chunks) {
    total_runs += c.runs.size();
    total_records += c.vertices.size();
  }
  by_first.reserve(total_runs);
  for (std::uint32_t c = 0; c < chunks.size(); ++c) {
    for (std::uint32_t k = 0; k < chunks[c].runs.size(); ++k) {
      const LoopRunRecord& r = chunks[c].runs[k];
      if (r.patch >= patches) return damaged("a loop run names an unknown patch");
      if (r.min_index >= r.length) return damaged("a loop run's lowest half-edge lies outside it");
      by_first.push_back({r.first, c, k});
    }
    for (const auto& [p, sum] : chunks[c].areas) {
      if (p >= patches) return damaged("a vector area names an unknown patch");
      for (int k = 0; k < 3; ++k) g.patch_area[p][k] += sum[k];
      g.patch_has_faces[p] = 1;
    }
  }
  std::sort(by_first.begin(), by_first.end(), [](const RunRef& a, const RunRef& b) { return a.first < b.first; });
  for (std::size_t k = 1; k < by_first.size(); ++k)
    if (by_first[k].first == by_first[k - 1].first) return damaged("half-edge " + std::to_string(by_first[k].first) + " starts two runs");
  auto run_of = [&](std::size_t k) -> const LoopRunRecord& { return chunks[by_first[k].chunk].runs[by_first[k].index]; };
  // Each run's successor; every run must have exactly one predecessor.
  const std::size_t nr = by_first.size();
  std::vector<std::uint32_t> succ(nr);
  {
    std::vector<std::uint8_t> preds(nr, 0);
    for (std::size_t k = 0; k < nr; ++k) {
      const LoopRunRecord& r = run_of(k);
      auto it = std::lower_bound(by_first.begin(), by_first.end(), r.next,
                                 [](const RunRef& a, std::uint64_t x) { return a.first < x; });
      if (it == by_first.end() || it->first != r.next)
        return damaged("the half-edges of patch " + std::to_string(r.patch) + " do not close into a loop");
      const std::size_t s = it - by_first.begin();
      if (run_of(s).patch != r.patch || preds[s]++)
        return damaged("the half-edges of patch " + std::to_string(r.patch) + " do not close into a loop");
      succ[k] = static_cast<std::uint32_t>(s);
    }
  }
  // Loops: cycles of runs, each starting at its lowest half-edge id; a patch's loops in that order.
  struct LoopInfo {
    std::uint32_t patch;
    std::uint64_t min_id;
    std::uint32_t start;  // the run holding min_id (index in by_first)
    std::uint64_t length;
  };
  std::vector<LoopInfo> infos;
  std::size_t breaks = 0, halves = 0;
  {
    std::vector<std::uint8_t> walked(nr, 0);
    for (std::size_t k = 0; k < nr; ++k) {
      if (walked[k]) continue;
      LoopInfo info{run_of(k).patch, run_of(k).min_id, static_cast<std::uint32_t>(k), 0};
      for (std::size_t at = k; !walked[at]; at = succ[at]) {
        walked[at] = 1;
        const LoopRunRecord& r = run_of(at);
        info.length += r.length;
        breaks += r.breaks;
        if (r.min_id < info.min_id) {
          info.min_id = r.min_id;
          info.start = static_cast<std::uint32_t>(at);
        }
      }
      if (info.length >= 0xFFFFFFFFu) return damaged("a loop is too long");
      halves += info.length;
      infos.push_back(info);
    }
  }
  std::sort(infos.begin(), infos.end(),
            [](const LoopInfo& a, const LoopInfo& b) { return a.patch != b.patch ? a.patch < b.patch : a.min_id < b.min_id; });
  // Where each run's vertices go: its loop, and its offset there before the loop is turned to
  // start at min_id.
  std::vector<std::uint32_t> run_loop(nr), run_at(nr);
  std::vector<std::vector<std::uint32_t>> chunk_run(chunks.size());  // index in by_first of each chunk's runs
  for (std::uint32_t c = 0; c < chunks.size(); ++c) chunk_run[c].resize(chunks[c].runs.size());
  for (std::size_t k = 0; k < nr; ++k) chunk_run[by_first[k].chunk][by_first[k].index] = static_cast<std::uint32_t>(k);
  // Dense ids: every loop vertex, record and extra vertex, in global id order. Gathered from
  // the run files before the loops exist, summed up now and then (each vertex is on two loops).
  std::vector<std::uint32_t>& global = g.global;
  {
    constexpr std::size_t kSlack = std::size_t{1} << 18;  // 1 MiB of ids
    std::size_t unique = 0;
    auto compact = [&] {
      std::sort(global.begin(), global.end());
      global.erase(std::unique(global.begin(), global.end()), global.end());
      unique = global.size();
    };
    auto add = [&](std::uint32_t v) {
      make_room_for_one(global, unique, kSlack, compact);
      global.push_back(v);
    };
    for (const ChunkLoopSummary& c : chunks) {
      GM_RETURN_IF_ERROR(read_run_vertices(c, [&](std::size_t, std::uint32_t, const LoopVertexEntry& e) { add(e.vertex); }));
      for (const LoopVertexRecord& r : c.vertices) add(r.vertex);
    }
    for (const auto& e : extra_vertices) add(e.first);
    compact();
    global.shrink_to_fit();
  }
  release_free_memory();  // the gathering's spare capacity
  const std::size_t nv = global.size();
  const DenseIds dense(global);
  // Positions in dense order, to a file, one range of dense ids at a time (the run files read
  // once per range), before the loops exist: the range buffer and the loops are never held
  // together.
  const std::string path = dir + "/loop-positions.bin";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  auto source = std::make_shared<FilePositions>(fd, path, nv);
  {
    constexpr std::size_t kRange = (std::size_t{8} << 20) / sizeof(format::Vec3f);
    std::vector<format::Vec3f> buffer;
    std::vector<std::uint8_t> filled;
    std::size_t lo = 0;
    auto put = [&](std::uint32_t v, const format::Vec3f& p) {
      const std::size_t d = dense(v);
      if (d < lo || d >= lo + buffer.size()) return;
      buffer[d - lo] = p;
      filled[d - lo] = 1;
    };
    for (lo = 0; lo < nv; lo += kRange) {
      const std::size_t n = std::min(nv - lo, kRange);
      buffer.assign(n, {});
      filled.assign(n, 0);
      for (const ChunkLoopSummary& c : chunks) {
        GM_RETURN_IF_ERROR(read_run_vertices(c, [&](std::size_t, std::uint32_t, const LoopVertexEntry& e) { put(e.vertex, e.position); }));
        for (const LoopVertexRecord& r : c.vertices) put(r.vertex, r.position);
      }
      for (const auto& [v, p] : extra_vertices) put(v, p);
      if (std::find(filled.begin(), filled.end(), 0) != filled.end()) return damaged("a loop vertex has no position");
      const std::size_t bytes = buffer.size() * sizeof(format::Vec3f);
      if (!format::write_all(fd, buffer.data(), bytes, lo * sizeof(format::Vec3f)))
        return format::Status::error(format::Code::kOutput, path, "cannot write loop vertex positions: " + std::string(std::strerror(errno)));
    }
  }
  release_free_memory();  // the range buffer
  // The loops, in dense ids, to a file: loop l is entries loop_offset[l] .. of it, starting at
  // its lowest half-edge. Each run's vertices go to their place in one write (two when the
  // loop's start lies inside it), so only one run is held at a time.
  const std::size_t nl = infos.size();
  g.loop_patch.resize(nl);
  g.loop_offset.assign(nl + 1, 0);
  std::vector<std::uint32_t> rotation(nl);
  for (std::uint32_t l = 0; l < nl; ++l) {
    g.loop_patch[l] = infos[l].patch;
    g.loop_offset[l + 1] = g.loop_offset[l] + infos[l].length;
    rotation[l] = run_of(infos[l].start).min_index;
    std::uint32_t at = 0, k = infos[l].start;
    do {
      run_loop[k] = l;
      run_at[k] = at;
      at += run_of(k).length;
      k = succ[k];
    } while (k != infos[l].start);
  }
  succ = {};
  const std::string loop_path = dir + "/loop-vertices.bin";
  const int loop_fd = ::open(loop_path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (loop_fd < 0) return format::Status::error(format::Code::kOutput, loop_path, std::strerror(errno));
  auto loop_source = std::make_shared<FileLoopVertices>(loop_fd, loop_path, g.loop_offset.back());
  {
    std::vector<std::uint32_t> run_ids;
    std::size_t run_index = kNone;  // in by_first
    // Writes run_ids at entry `at` of loop l onwards (wrapping round to its start).
    auto put = [&](std::uint32_t l, std::uint64_t at, std::span<const std::uint32_t> ids) -> format::Status {
      const std::uint64_t length = infos[l].length;
      while (!ids.empty()) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(ids.size(), length - at));
        GM_RETURN_IF_ERROR(loop_source->write(g.loop_offset[l] + at, ids.first(n)));
        ids = ids.subspan(n);
        at = 0;
      }
      return format::Status();
    };
    auto flush = [&]() -> format::Status {
      if (run_index == kNone || run_ids.empty()) return format::Status();
      const std::uint32_t l = run_loop[run_index];
      const std::uint64_t length = infos[l].length;
      const std::uint64_t at = (run_at[run_index] + length - rotation[l]) % length;
      GM_RETURN_IF_ERROR(put(l, at, run_ids));
      run_ids.clear();
      return format::Status();
    };
    for (std::uint32_t c = 0; c < chunks.size(); ++c) {
      format::Status written;
      GM_RETURN_IF_ERROR(read_run_vertices(chunks[c], [&](std::size_t run, std::uint32_t, const LoopVertexEntry& e) {
        const std::uint32_t k = chunk_run[c][run];
        if (k != run_index) {
          if (written.is_ok()) written = flush();
          run_index = k;
        }
        run_ids.push_back(dense(e.vertex));
      }));
      GM_RETURN_IF_ERROR(written);
      GM_RETURN_IF_ERROR(flush());
      run_index = kNone;
    }
  }
  g.loop_source = std::move(loop_source);
  g.role.assign(nv, VertexRole::kNone);
  g.interior_samples.assign(patches, {});
  std::vector<std::uint8_t> has_record(nv, 0);
  for (const ChunkLoopSummary& c : chunks) {
    for (const LoopVertexRecord& r : c.vertices) {
      const std::uint32_t d = dense(r.vertex);
      if (has_record[d]++) return damaged("vertex " + std::to_string(r.vertex) + " twice");
      g.role[d] = r.role;
      if (r.degree > 0 && r.role != VertexRole::kNone) ++g.graph.corners;
      if (r.interior_patch == kNone) continue;
      if (r.interior_patch >= patches) return damaged("an interior sample names an unknown patch");
      g.interior_samples[r.interior_patch].push_back(d);
    }
  }
  has_record = {};
  for (auto& list : g.interior_samples) std::sort(list.begin(), list.end());
  g.graph.feature_edges = breaks + (halves - breaks) / 2;
  g.position_source = std::move(source);
  g.vertex_count = nv;
  if (stats) *stats = {nr, halves, nv};
  return g;
}

namespace {

// A graph's dense-to-input id table moves to a file in dir before the mesher runs (1.3M ids at
// 100M input triangles): the mesher then gives dense ids as birth indices, and only those —
// the output's vertices — are read back.
format::Result<std::uint64_t> spill_global_ids(PolygonGraphInput& g, const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  const bool ok = format::write_all(fd, g.global.data(), g.global.size() * sizeof(std::uint32_t), 0);
  const int error = errno;
  ::close(fd);
  if (!ok) return format::Status::error(format::Code::kOutput, path, "cannot write vertex ids: " + std::string(std::strerror(error)));
  const std::uint64_t count = g.global.size();
  std::vector<std::uint32_t>().swap(g.global);
  return count;
}

// birth (dense ids) to input ids through spill_global_ids' file of count ids.
format::Status map_births(std::vector<std::uint32_t>& birth, const std::string& path, std::uint64_t count) {
  std::vector<std::uint32_t> ids(birth);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::vector<std::uint32_t> global(ids.size());
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  std::vector<std::byte> window;
  const std::size_t served = read_by_ascending_id(fd, count, sizeof(std::uint32_t), ids, window, [&](std::size_t i, const std::byte* record) {
    std::memcpy(&global[i], record, sizeof(std::uint32_t));
  });
  ::close(fd);
  if (served < ids.size()) return format::Status::error(format::Code::kOutput, path, "cannot read the id of vertex " + std::to_string(ids[served]));
  for (std::uint32_t& b : birth) b = global[std::lower_bound(ids.begin(), ids.end(), b) - ids.begin()];
  return format::Status();
}

// Passes A-D and the stitch over a partition, for `spheres` (the exact test: every orientation
// in pass A; the paper test: one). `out` comes with the partition's figures. The temporary
// directory is removed at the end when remove_temp (the paper test's runs per orientation keep
// it for the next run; each run's files replace the last one's).
format::Result<OutOfCoreSimplify> simplify_partition(Partition* partition, std::span<const GaussSphere> spheres,
                                                     const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify out,
                                                     bool remove_temp) {
  const std::size_t nc = partition->chunks.size(), no = spheres.size();

  // Pass A: samples of every orientation (and, with one orientation, the pieces too). Each
  // chunk's border edges and face answers go to disk (stream/stitch/piece_joins.h) as it finishes.
  auto start = std::chrono::steady_clock::now();
  std::vector<std::vector<GlobalSample>> samples(nc * no);
  std::vector<ChunkSamplingStats> chunk_stats(nc * no);
  std::vector<ChunkPieces> pieces(nc);
  // The paper test: each chunk's candidates' star geometry (stream/stitch/paper_chains.h), for their
  // records after the merge.
  const bool paper = options.sampler.sample_test == SampleTest::kPaper;
  std::vector<ChunkRecordSegment> star_geometry(paper ? nc : 0);
  // Border-edge records: about one per face of each chunk's first overlap ring, whose size is
  // about the overlap's over the rings (a guess: a wrong one costs reads, not memory).
  std::uint64_t expected_border = 0;
  for (const ChunkInfo& info : partition->chunks)
    expected_border += (info.faces - std::min(info.faces, info.owned_faces)) / std::max<std::uint32_t>(options.partition.rings, 1);
  auto joins = PieceJoinFiles::create(partition->dir, nc, border_bucket_count(expected_border, options.partition.memory_bytes),
                                      options.partition.memory_bytes);
  if (!joins) return joins.status();
  // Pass C reads loop chunks where pass A could write them (write_loop_chunk), else the chunk;
  // the pieces' areas ride in the spilled piece records (held here they grew with the pieces:
  // 100M under 16M, +10 MB at the merge).
  // A loop chunk may hold no face (no feature edge and no sample in the chunk: inside one flat
  // patch); pass C then reads nothing for it but its pieces' areas.
  struct LoopChunk {
    std::uint64_t faces = 0, owned_faces = 0;
    std::uint32_t file = 0;  // its pass-b file (PieceJoinFiles::segments)
    format::RecordSegment segment;
    bool present = false;  // false: pass C reads the chunk
  };
  std::vector<LoopChunk> loop_chunks(nc);
  auto loop_info_of = [&](std::size_t c) {
    ChunkInfo info = partition->chunks[c];
    if (!loop_chunks[c].present) return info;
    info.path = (*joins)->segment_path(loop_chunks[c].file);
    info.segment = loop_chunks[c].segment;
    info.loop = true;
    info.faces = loop_chunks[c].faces;
    info.owned_faces = loop_chunks[c].owned_faces;
    return info;
  };
  auto find_pieces = [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                         const std::vector<GlobalSample>& chunk_samples) {
    std::vector<std::uint32_t> piece_index, candidates;
    for (const VertexRecord& r : ws.records)  // the sampler's, for these labels (sample_chunk)
      if (r.is_candidate) candidates.push_back(r.vertex);
    find_chunk_pieces(*partition, chunk, ws.adjacency, ws.labels, ws.feature, pieces[c], &piece_index, &candidates);
    GM_RETURN_IF_ERROR((*joins)->write_face_pieces(static_cast<std::uint32_t>(c), chunk, piece_index));
    ChunkInfo loop_info;
    std::vector<std::array<double, 3>> piece_area;
    format::RecordSegmentPool::Lease lease((*joins)->segments());
    GM_RETURN_IF_ERROR(lease.status());
    auto written = write_loop_chunk(chunk, partition->chunks[c], ws.adjacency, piece_index, ws.feature, chunk_samples, lease.file(),
                                    loop_info, piece_area);
    if (!written) return written.status();
    if (*written) {
      loop_chunks[c] = {loop_info.faces, loop_info.owned_faces, lease.index(), loop_info.segment, true};
      if (piece_area.size() > pieces[c].pieces.size())
        return format::Status::error(format::Code::kProcessing, "pass A", "more piece areas than pieces");
      const std::size_t first = pieces[c].pieces.size() - piece_area.size();  // this chunk's, appended last
      for (std::size_t k = 0; k < piece_area.size(); ++k) pieces[c].pieces[first + k].area = piece_area[k];
    }
    return (*joins)->spill(static_cast<std::uint32_t>(c), pieces[c]);
  };
  std::mutex geometry_mutex;
  auto write_geometry = [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) -> format::Status {
    format::RecordSegmentPool::Lease lease((*joins)->segments());
    GM_RETURN_IF_ERROR(lease.status());
    auto written = write_star_geometry(chunk, ws.adjacency, ws.normals, ws.records, lease.file());
    if (!written) return written.status();
    star_geometry[c] = std::move(written).value();
    std::lock_guard<std::mutex> lock(geometry_mutex);
    partition->bytes_spilled += star_geometry[c].segment.bytes;
    return format::Status();
  };
  GM_RETURN_IF_ERROR(for_each_chunk(*partition, options.threads, "sample", options,
                                    [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
                                      for (std::size_t k = 0; k < no; ++k) {
                                        GM_RETURN_IF_ERROR(sample_chunk(chunk, spheres[k], options.sampler, ws,
                                                                        samples[c * no + k], chunk_stats[c * no + k]));
                                      }
                                      if (no > 1) return format::Status();
                                      if (paper) GM_RETURN_IF_ERROR(write_geometry(c, chunk, ws));
                                      return find_pieces(c, chunk, ws, samples[c]);
                                    }));
  for (std::size_t k = 0; k < no; ++k) {
    std::size_t n = 0;
    for (std::size_t c = 0; c < nc; ++c) n += samples[c * no + k].size();
    out.samples_per_orientation.push_back(n);
    if (n < out.samples_per_orientation[out.chosen]) out.chosen = k;
  }
  const GaussSphere& gauss = spheres[out.chosen];
  std::vector<std::vector<GlobalSample>> chosen(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    chosen[c] = std::move(samples[c * no + out.chosen]);
    out.samples += chosen[c].size();
    out.sampling_stats.add(chunk_stats[c * no + out.chosen]);
  }
  std::vector<ChunkSamplingStats>().swap(chunk_stats);
  samples = {};
  if (no > 1) {
    GM_RETURN_IF_ERROR(for_each_chunk(*partition, options.threads, "pieces", options,
                                      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
                                        std::vector<GlobalSample> unused;
                                        ChunkSamplingStats stats;
                                        GM_RETURN_IF_ERROR(sample_chunk(chunk, gauss, options.sampler, ws, unused, stats));
                                        if (paper) GM_RETURN_IF_ERROR(write_geometry(c, chunk, ws));
                                        return find_pieces(c, chunk, ws, chosen[c]);
                                      }));
  }
  GM_RETURN_IF_ERROR((*joins)->finish());
  partition->bytes_spilled += (*joins)->bytes_written();
  out.seconds_sample = seconds_since(start);
  out.peak_rss_after_pieces = peak_rss();

  // Stitch: patches, merge.
  start = std::chrono::steady_clock::now();
  auto stitched = stitch_pieces(pieces, **joins, options.partition.memory_bytes, options.threads);
  if (!stitched) return stitched.status();
  out.stitch_steps.pieces = seconds_since(start);
  auto step = std::chrono::steady_clock::now();
  std::vector<ChunkPieces>().swap(pieces);
  release_free_memory();
  CandidateEdges candidate_edges;
  PatchGraphInput merge_input = take_merge_input(*stitched, candidate_edges);
  // The merge reads the candidates' edges; after it only the paper test reads their stars (its
  // records under the merged labels), and the exact test only their vertices (100M: 7 MB less
  // through the merge).
  std::vector<std::uint32_t> candidate_vertex;
  candidate_vertex.reserve(stitched->candidates.size());
  for (const auto& c : stitched->candidates) candidate_vertex.push_back(c.vertex);
  if (!paper) {
    std::vector<StitchedPatches::Star>().swap(stitched->star);
    std::vector<std::uint8_t>().swap(stitched->entering_break);
    std::vector<StitchedPatches::Candidate>().swap(stitched->candidates);
  }
  PatchMergeResult merged = merge_stitched_patches(candidate_edges, std::move(merge_input));
  candidate_edges = CandidateEdges();
  out.patches = merged.patch_label.size();
  out.merged_patches = merged.merged_patches;
  out.merge_rounds = merged.rounds;
  std::vector<std::uint32_t> corners;
  for (std::size_t k = 0; k < candidate_vertex.size(); ++k)
    if (merged.is_candidate[k]) corners.push_back(candidate_vertex[k]);
  std::vector<std::uint32_t>().swap(candidate_vertex);
  out.candidates = corners.size();
  out.peak_rss_after_merge = peak_rss();
  out.stitch_steps.merge = seconds_since(step);
  step = std::chrono::steady_clock::now();
  // The paper test: the surviving candidates' records under the merged labels, from their star
  // geometry and their stars' patches (what sample_mesh's merge leaves in its records).
  std::vector<PaperCandidate> paper_candidates;
  if (paper) {
    auto merged_label = [&](std::uint32_t p) { return merged.patch_label[merged.patch_of[p]]; };
    const MergedStar star = [&](std::uint32_t vertex, std::vector<StarSlotLabel>& slots) {
      const auto& cands = stitched->candidates;
      const auto it = std::lower_bound(cands.begin(), cands.end(), vertex,
                                       [](const StitchedPatches::Candidate& a, std::uint32_t v) { return a.vertex < v; });
      if (it == cands.end() || it->vertex != vertex || !merged.is_candidate[it - cands.begin()]) return false;
      for (std::uint32_t k = it->first; k < it->first + it->count; ++k) {
        const auto& e = stitched->star[k];
        const std::uint32_t label = merged_label(e.patch);
        slots.push_back({label, e.next_patch == kNone || merged_label(e.next_patch) != label});
      }
      return true;
    };
    for (std::size_t c = 0; c < nc; ++c)
      GM_RETURN_IF_ERROR(reevaluate_candidates(star_geometry[c], static_cast<std::uint32_t>(c), gauss, star, paper_candidates));
    if (paper_candidates.size() != corners.size())
      return damaged("the star geometry holds " + std::to_string(paper_candidates.size()) + " of " +
                     std::to_string(corners.size()) + " candidates");
    std::sort(paper_candidates.begin(), paper_candidates.end(),
              [](const PaperCandidate& a, const PaperCandidate& b) { return a.vertex < b.vertex; });
    std::vector<ChunkRecordSegment>().swap(star_geometry);
  }
  // Passes C and D need each piece's merged patch and each merged patch's label; the rest of the
  // stitch and the merge goes now.
  std::vector<StitchedPatches::Star>().swap(stitched->star);
  std::vector<std::uint8_t>().swap(stitched->entering_break);
  std::vector<StitchedPatches::Candidate>().swap(stitched->candidates);
  std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(merged.adjacency);
  std::vector<std::uint8_t>().swap(merged.is_candidate);
  release_free_memory();
  auto merged_patch_of_piece = [&](PieceId piece) -> std::uint32_t {
    const std::int64_t p = stitched->patch_of_piece(piece);
    return p < 0 ? kNone : merged.patch_of[p];
  };

  // A chunk's faces under the merged patches, and its adjacency in ws: owned faces through the
  // pieces pass A/B wrote for them, the others through the owners' answer files (each read once
  // per chunk); kNone where neither knows (faces far from every owned face). No labelling again.
  // A loop chunk carries its owned faces' pieces (checked against pieces, the chunk's pieces).
  auto merged_patches_of_chunk = [&](const ChunkMesh& chunk, ChunkSamplerWorkspace& ws, std::vector<std::uint32_t>& patch,
                                     const std::vector<PieceRecord>& pieces = {}) -> format::Status {
    GM_RETURN_IF_ERROR(build_mesh_adjacency(chunk.view(), ws.adjacency));
    std::vector<std::uint32_t> piece_index;
    if (chunk.core_face.empty()) {
      GM_RETURN_IF_ERROR((*joins)->read_face_pieces(chunk.chunk, chunk, piece_index));
    } else {
      for (std::size_t f = 0; f < chunk.loop_piece.size(); ++f)
        if (chunk.owned_face[f] && chunk.loop_piece[f] >= pieces.size())
          return damaged("the loop chunk of chunk " + std::to_string(chunk.chunk) + ": a face names a piece the chunk does not have");
    }
    const std::vector<std::uint32_t>& index = chunk.core_face.empty() ? piece_index : chunk.loop_piece;
    std::vector<PieceId> face_piece;
    GM_RETURN_IF_ERROR(chunk_face_pieces(*partition, chunk, index, **joins, face_piece));
    patch.resize(chunk.triangles.size());
    for (std::uint32_t f = 0; f < patch.size(); ++f) patch[f] = merged_patch_of_piece(face_piece[f]);
    return format::Status();
  };

  // The paper test's samples: candidate chains under the merged labels, chunk by chunk (loop
  // chunks hold every vertex on a feature edge with its whole star), joined across chunks, then
  // the non-sample and noisy filters (sample_mesh's last steps).
  if (paper) {
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> chunk_pairs(nc);
    std::vector<ChunkRecordSegment> fragment_files(nc);
    GM_RETURN_IF_ERROR(for_each_chunk(
        nc, loop_info_of, partition->faces, options.threads, "chains", options,
        [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
          if (chunk.triangles.empty()) return format::Status();  // no face (an empty loop chunk): no chain
          std::vector<std::uint32_t> patch;
          std::vector<PieceRecord> piece_records;
          if (!chunk.core_face.empty()) GM_RETURN_IF_ERROR((*joins)->read_pieces(static_cast<std::uint32_t>(c), piece_records));
          GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch, piece_records));
          std::vector<std::uint32_t> label(patch.size(), 0);
          std::vector<std::uint8_t> known(patch.size(), 0);
          for (std::size_t f = 0; f < patch.size(); ++f) {
            if (patch[f] == kNone) continue;
            label[f] = merged.patch_label[patch[f]];
            known[f] = 1;
          }
          auto is_candidate = [&](std::uint32_t v) { return std::binary_search(corners.begin(), corners.end(), v); };
          std::vector<ChainFragment> fragments;
          GM_RETURN_IF_ERROR(find_chunk_chains(chunk, ws.adjacency, label, known, is_candidate, chunk_pairs[c], fragments));
          std::sort(chunk_pairs[c].begin(), chunk_pairs[c].end());
          chunk_pairs[c].erase(std::unique(chunk_pairs[c].begin(), chunk_pairs[c].end()), chunk_pairs[c].end());
          chunk_pairs[c].shrink_to_fit();
          if (fragments.empty()) return format::Status();
          format::RecordSegmentPool::Lease lease((*joins)->segments());
          GM_RETURN_IF_ERROR(lease.status());
          auto written = write_chain_fragments(fragments, lease.file());
          if (!written) return written.status();
          fragment_files[c] = std::move(written).value();
          return format::Status();
        }));
    std::vector<std::pair<std::uint32_t, std::uint32_t>> candidate_pairs;
    for (auto& p : chunk_pairs) {
      candidate_pairs.insert(candidate_pairs.end(), p.begin(), p.end());
      std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(p);
    }
    for (const ChunkRecordSegment& f : fragment_files) {
      out.chain_fragments += f.records;
      partition->bytes_spilled += f.segment.bytes;
    }
    GM_RETURN_IF_ERROR(join_chain_fragments(fragment_files, options.partition.memory_bytes, candidate_pairs));
    std::sort(candidate_pairs.begin(), candidate_pairs.end());
    candidate_pairs.erase(std::unique(candidate_pairs.begin(), candidate_pairs.end()), candidate_pairs.end());
    out.candidate_pairs = candidate_pairs.size();
    out.candidate_pairs_digest = candidate_pairs_digest(candidate_pairs);
    std::vector<NoisyFilterInput> survivors;
    std::vector<std::uint32_t> survivor_of;  // index into paper_candidates
    for (std::uint32_t k = 0; k < paper_candidates.size(); ++k) {
      const PaperCandidate& r = paper_candidates[k];
      if (r.is_tree) {
        ++out.tree_filtered;
        continue;
      }
      if (options.sampler.drop_unwinding_candidates && r.gauss_vertex != kNoGaussVertex &&
          r.characteristic == Characteristic::kNone) {
        ++out.unwinding_filtered;
        continue;
      }
      survivors.push_back({r.vertex, r.gauss_vertex, static_cast<std::uint8_t>(r.characteristic), r.cover_mask});
      survivor_of.push_back(k);
    }
    const std::vector<std::uint8_t> keep = noisy_sample_filter(survivors, candidate_pairs);
    std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(candidate_pairs);
    out.samples = 0;
    for (std::size_t k = 0; k < survivors.size(); ++k) {
      if (!keep[k]) {
        ++out.noisy_filtered;
        continue;
      }
      const PaperCandidate& r = paper_candidates[survivor_of[k]];
      const GlobalSample sample{r.vertex, r.position, r.gauss_vertex, r.characteristic};
      if (options.samples_only) {
        out.sample_points.push_back(sample);
      } else {
        if (r.chunk >= nc) return damaged("a candidate names chunk " + std::to_string(r.chunk));
        chosen[r.chunk].push_back(sample);
      }
      ++out.samples;
    }
    out.samples_per_orientation.assign(1, out.samples);
    std::vector<PaperCandidate>().swap(paper_candidates);
    out.stitch_steps.chains = seconds_since(step);
    step = std::chrono::steady_clock::now();
  }
  if (options.samples_only) {
    out.bytes_spilled = partition->bytes_spilled;
    out.seconds_stitch = seconds_since(start);
    if (remove_temp) {
      const auto cleanup = std::chrono::steady_clock::now();
      partition->remove_temp();
      out.seconds_cleanup = seconds_since(cleanup);
    }
    out.rotation = gauss.options().rotation;
    out.gauss_vertices = gauss.vertex_count();
    out.gauss_triangles = gauss.triangle_count();
    if (!paper) {
      for (auto& part : chosen) out.sample_points.insert(out.sample_points.end(), part.begin(), part.end());
      std::sort(out.sample_points.begin(), out.sample_points.end(),
                [](const GlobalSample& a, const GlobalSample& b) { return a.vertex < b.vertex; });
    }
    return out;
  }

  // Pass C: loops under the merged patches; each chunk's run vertices go to a file. A loop chunk
  // carries its owned faces' pieces, and its areas come from pass A's per-piece sums.
  std::vector<ChunkLoopSummary> loops(nc);
  GM_RETURN_IF_ERROR(for_each_chunk(
      nc, loop_info_of, partition->faces, options.threads, "loops", options,
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        std::vector<std::uint32_t> patch;
        const bool loop_chunk = loop_chunks[c].present;
        if (loop_chunk != !chunk.core_face.empty() && !chunk.triangles.empty())
          return format::Status::error(format::Code::kProcessing, "pass C", "a loop chunk without its core flags");
        std::vector<PieceRecord> piece_records;
        if (loop_chunk) GM_RETURN_IF_ERROR((*joins)->read_pieces(static_cast<std::uint32_t>(c), piece_records));
        auto is_corner = [&](std::uint32_t v) { return std::binary_search(corners.begin(), corners.end(), v); };
        ChunkLoops found;
        if (!chunk.triangles.empty()) {  // no face (an empty loop chunk): no loop, only its pieces' areas
          GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch, piece_records));
          GM_RETURN_IF_ERROR(find_chunk_loops(chunk, ws.adjacency, patch, is_corner, chosen[c], found));
        }
        if (loop_chunk) {
          std::map<std::uint32_t, std::array<double, 3>> areas;
          for (const PieceRecord& r : piece_records) {
            auto& sum = areas[merged_patch_of_piece(r.piece)];
            for (int i = 0; i < 3; ++i) sum[i] += r.area[i];
          }
          for (const auto& [p, sum] : areas) found.areas.emplace_back(p, sum);
        }
        format::RecordSegmentPool::Lease lease((*joins)->segments());
        GM_RETURN_IF_ERROR(lease.status());
        auto summary = spill_chunk_loops(std::move(found), lease.file());
        if (!summary) return summary.status();
        loops[c] = std::move(summary).value();
        return format::Status();
      }));
  out.peak_rss_after_loops = peak_rss();
  out.bytes_spilled = partition->bytes_spilled;
  for (std::size_t c = 0; c < nc; ++c) {
    const bool loop = loop_chunks[c].present;
    out.loop_chunks += loop;
    out.loop_faces += loop ? loop_chunks[c].faces : partition->chunks[c].faces;
    out.bytes_spilled += loop ? loop_chunks[c].segment.bytes : 0;
  }
  std::vector<LoopChunk>().swap(loop_chunks);
  for (const ChunkLoopSummary& l : loops) out.bytes_spilled += l.bytes;
  std::vector<format::Vec3f> plane(merged.patch_label.size());
  for (std::size_t p = 0; p < plane.size(); ++p) {
    if (merged.patch_label[p] == kNoLabel) continue;
    const Vec3d& c = gauss.triangle_center(merged.patch_label[p]);
    plane[p] = {float(c.x), float(c.y), float(c.z)};
  }
  out.stitch_steps.loops = seconds_since(step);
  step = std::chrono::steady_clock::now();
  LoopStitchStats stitch_stats;
  auto graph = stitch_loops(loops, merged.patch_label.size(), plane, partition->dir, {}, &stitch_stats);
  if (!graph) return graph.status();
  out.stitch_runs = stitch_stats.runs;
  out.stitch_half_edges = stitch_stats.half_edges;
  out.stitch_vertices = stitch_stats.vertices;
  out.bytes_spilled += 12 * stitch_stats.vertices;
  out.stitch_steps.loop_stitch = seconds_since(step);
  out.seconds_stitch = seconds_since(start);

  start = std::chrono::steady_clock::now();
  const std::string ids_path = partition->dir + "/loop-ids.bin";
  auto id_count = spill_global_ids(*graph, ids_path);
  if (!id_count) return id_count.status();
  auto meshed = mesh_patch_loops(std::move(*graph));
  if (!meshed) return meshed.status();
  // Patches that need their input faces: pass D collects them from the chunks (owned,
  // non-collapsed faces, ascending global id), then the mesher runs again from the start.
  std::vector<std::uint32_t> wanted;
  struct Fetched {
    std::uint64_t face;
    std::uint32_t patch;
    std::array<std::uint32_t, 3> v;
    std::array<format::Vec3f, 3> p;
  };
  std::vector<Fetched> fetched;
  for (int attempt = 0; !meshed->needs_faces.empty(); ++attempt) {
    if (attempt >= 8) return format::Status::error(format::Code::kProcessing, "stitch", "patches keep asking for faces");
    std::vector<std::uint32_t> asked = meshed->needs_faces;
    std::sort(asked.begin(), asked.end());
    std::vector<std::uint32_t> now;
    std::set_difference(asked.begin(), asked.end(), wanted.begin(), wanted.end(), std::back_inserter(now));
    if (now.empty()) return format::Status::error(format::Code::kProcessing, "stitch", "fetched faces did not help");
    // Only the chunks that own faces of those patches: a merged patch's owned faces are its
    // pieces' faces, and a piece is its chunk's. (At 300M triangles one patch of 4,683 faces
    // asked, and a pass over all 2,033 chunks took 16 s.)
    if (stitched->chunk_first.size() != nc + 1) return damaged("the stitched pieces do not cover the chunks");
    std::vector<std::uint32_t> holders;
    for (std::uint32_t c = 0; c < nc; ++c)
      for (std::uint32_t k = stitched->chunk_first[c]; k < stitched->chunk_first[c + 1]; ++k)
        if (std::binary_search(now.begin(), now.end(), merged.patch_of[stitched->piece_patch[k]])) {
          holders.push_back(c);
          break;
        }
    out.fetched_chunks += holders.size();
    std::vector<std::vector<Fetched>> per_chunk(holders.size());
    GM_RETURN_IF_ERROR(for_each_chunk(
        holders.size(), [&](std::size_t i) { return partition->chunks[holders[i]]; }, partition->faces,
        options.threads, "faces", options,
        [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
          std::vector<std::uint32_t> patch_of;
          GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch_of));
          const std::vector<std::uint8_t> skip = faces_the_mesher_skips(chunk.triangles, ws.adjacency);
          for (std::uint32_t f = 0; f < chunk.triangles.size(); ++f) {
            const auto& t = chunk.triangles[f];
            if (!chunk.owned_face[f] || skip[f]) continue;
            const std::uint32_t patch = patch_of[f];
            if (!std::binary_search(now.begin(), now.end(), patch)) continue;
            Fetched r{chunk.global_face[f], patch, {}, {}};
            for (int i = 0; i < 3; ++i) {
              r.v[i] = chunk.global_vertex[t.v[i]];
              r.p[i] = chunk.positions[t.v[i]];
            }
            per_chunk[c].push_back(r);
          }
          return format::Status();
        }));
    for (auto& part : per_chunk) fetched.insert(fetched.end(), part.begin(), part.end());
    wanted.insert(wanted.end(), now.begin(), now.end());
    std::sort(wanted.begin(), wanted.end());
    std::sort(fetched.begin(), fetched.end(), [](const Fetched& a, const Fetched& b) { return a.face < b.face; });
    // The graph again, with the fetched faces' vertices among its (dense, global-order) ids.
    std::vector<std::pair<std::uint32_t, format::Vec3f>> extra;
    for (const Fetched& r : fetched)
      for (int i = 0; i < 3; ++i) extra.emplace_back(r.v[i], r.p[i]);
    std::sort(extra.begin(), extra.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    extra.erase(std::unique(extra.begin(), extra.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                extra.end());
    auto regraph = stitch_loops(loops, merged.patch_label.size(), plane, partition->dir, extra, nullptr);
    if (!regraph) return regraph.status();
    {
      const DenseIds dense(regraph->global);
      std::map<std::uint32_t, PatchFaces> by_patch;
      for (const Fetched& r : fetched) {
        PatchFaces& pf = by_patch[r.patch];
        pf.patch = r.patch;
        pf.triangles.push_back({dense(r.v[0]), dense(r.v[1]), dense(r.v[2])});
      }
      for (auto& [patch, pf] : by_patch) regraph->patch_faces.push_back(std::move(pf));
    }
    id_count = spill_global_ids(*regraph, ids_path);
    if (!id_count) return id_count.status();
    out.fetched_patches = wanted.size();
    out.fetched_faces = fetched.size();
    meshed = mesh_patch_loops(std::move(*regraph));
    if (!meshed) return meshed.status();
  }
  GM_RETURN_IF_ERROR(map_births(meshed->mesh.birth, ids_path, *id_count));
  out.seconds_mesh = seconds_since(start);
  if (remove_temp) {
    start = std::chrono::steady_clock::now();
    partition->remove_temp();
    out.seconds_cleanup = seconds_since(start);
  }
  out.mesh = std::move(meshed->mesh.mesh);
  out.birth = std::move(meshed->mesh.birth);
  out.polygon = meshed->stats;
  out.rotation = gauss.options().rotation;
  out.gauss_vertices = gauss.vertex_count();
  out.gauss_triangles = gauss.triangle_count();
  return out;
}

}  // namespace

format::Result<OutOfCoreSimplify> simplify_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                       const OutOfCoreSimplifyOptions& options) {
  GM_RETURN_IF_ERROR(check_out_of_core_options("simplify", options.spheres, options.threads));
  auto created = create_spheres(options.spheres);
  if (!created) return created.status();
  const std::vector<GaussSphere>& spheres = *created;
  auto partition = partition_for_chunks(input_path, read, options.partition, options.sampler, options.threads);
  if (!partition) return partition.status();
  OutOfCoreSimplify base;
  record_partition(*partition, base);
  const std::size_t no = spheres.size();
  if (options.sampler.sample_test != SampleTest::kPaper || no == 1)
    return simplify_partition(&*partition, spheres, options, std::move(base), true);

  // The paper test's samples come after the merge and the chains, so each orientation runs the
  // passes up to its samples (as sample_mesh_best_orientation samples the mesh once per
  // orientation); the one with the fewest (ties: the first) is kept — with `samples_only` as it
  // is, else run again to the end.
  OutOfCoreSimplifyOptions counting = options;
  counting.samples_only = true;
  std::vector<std::size_t> counts;
  std::size_t chosen = 0;
  double seconds_sample = 0, seconds_stitch = 0, seconds_cleanup = 0;
  std::optional<OutOfCoreSimplify> best;
  for (std::size_t k = 0; k < no; ++k) {
    const bool last = options.samples_only && k + 1 == no;
    auto run = simplify_partition(&*partition, std::span(&spheres[k], 1), counting, base, last);
    if (!run) return run.status();
    counts.push_back(run->samples);
    seconds_sample += run->seconds_sample;
    seconds_stitch += run->seconds_stitch;
    seconds_cleanup += run->seconds_cleanup;
    if (k == 0 || run->samples < counts[chosen]) {
      chosen = k;
      if (options.samples_only) best = std::move(run).value();
    }
    release_free_memory();
  }
  if (!options.samples_only) {
    auto run = simplify_partition(&*partition, std::span(&spheres[chosen], 1), options, base, true);
    if (!run) return run.status();
    best = std::move(run).value();
    best->seconds_sample += seconds_sample;
    best->seconds_stitch += seconds_stitch;
  } else {
    best->seconds_sample = seconds_sample;
    best->seconds_stitch = seconds_stitch;
    best->seconds_cleanup = seconds_cleanup;
    best->bytes_spilled = partition->bytes_spilled;
  }
  best->chosen = chosen;
  best->samples_per_orientation = counts;
  return std::move(best).value();
}

}  // namespace gaussmesh::stream
