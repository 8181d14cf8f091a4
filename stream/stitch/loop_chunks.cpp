// The loops pass on one chunk, the loop chunk and the run files. See loop_chunks.h.
#include "stream/stitch/loop_chunks.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <type_traits>

#include "format/file_io.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;


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
  if (patch.size() != nf) return format::Status::error(format::Code::kProcessing, "loops pass", "one merged patch per chunk face expected");
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
  if (loop_chunk && chunk.core_face.size() != nf) return format::Status::error(format::Code::kProcessing, "loops pass", "one core flag per chunk face expected");
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
    return format::Status::error(format::Code::kProcessing, "loops pass", "one loop flag per chunk vertex expected");
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
  if (piece_index.size() != nf) return format::Status::error(format::Code::kProcessing, "sample pass", "one piece index per chunk face expected");
  if (feature.size() != nf) return format::Status::error(format::Code::kProcessing, "sample pass", "feature bits per chunk face expected");
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
    if (it == chunk.global_vertex.end() || *it != s.vertex) return format::Status::error(format::Code::kProcessing, "sample pass", "a sample the chunk does not hold");
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
  // zstd sizes its tables by the frame, so a whole-chunk buffer or larger frames raise the peak
  // (docs/benchmarks.md).
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
  // Held by the run until the mesher is done (a fetch stitches the loops again): no slack from
  // the vectors' growth.
  out.runs.shrink_to_fit();
  out.vertices.shrink_to_fit();
  out.areas.shrink_to_fit();
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

// Whether a T can be written and read back as its bytes (std::pair's assignment is not trivial,
// its copy is).
template <class T>
constexpr bool kBytewise = std::is_trivially_copyable_v<T>;
template <class A, class B>
constexpr bool kBytewise<std::pair<A, B>> = kBytewise<A> && kBytewise<B>;

template <class T>
std::uint64_t bytes_of(const std::vector<T>& v) {
  static_assert(kBytewise<T>, "written as it is in memory");
  return v.size() * sizeof(T);
}

}  // namespace

format::Status spill_loop_summaries(std::vector<ChunkLoopSummary>& chunks, const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  std::uint64_t at = 0;
  bool ok = true;
  for (ChunkLoopSummary& c : chunks) {
    c.spilled_at = at;
    c.spilled_runs = c.runs.size();
    c.spilled_vertices = c.vertices.size();
    c.spilled_areas = c.areas.size();
    ok = ok && format::write_all(fd, c.runs.data(), bytes_of(c.runs), at);
    at += bytes_of(c.runs);
    ok = ok && format::write_all(fd, c.vertices.data(), bytes_of(c.vertices), at);
    at += bytes_of(c.vertices);
    ok = ok && format::write_all(fd, c.areas.data(), bytes_of(c.areas), at);
    at += bytes_of(c.areas);
    if (!ok) break;
    std::vector<LoopRunRecord>().swap(c.runs);
    std::vector<LoopVertexRecord>().swap(c.vertices);
    std::vector<std::pair<std::uint32_t, std::array<double, 3>>>().swap(c.areas);
  }
  const int error = errno;
  ::close(fd);
  if (!ok) return format::Status::error(format::Code::kOutput, path, "write failed: " + std::string(std::strerror(error)));
  return format::Status();
}

format::Result<std::vector<ChunkLoopSummary>> read_loop_summaries(const std::vector<ChunkLoopSummary>& chunks,
                                                                  const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return format::Status::error(format::Code::kBadInput, path, std::strerror(errno));
  std::vector<ChunkLoopSummary> out(chunks.size());
  bool ok = true;
  for (std::size_t k = 0; k < chunks.size() && ok; ++k) {
    const ChunkLoopSummary& c = chunks[k];
    ChunkLoopSummary& r = out[k];
    r.path = c.path;
    r.segment = c.segment;
    r.entries = c.entries;
    r.bytes = c.bytes;
    r.runs.resize(c.spilled_runs);
    r.vertices.resize(c.spilled_vertices);
    r.areas.resize(c.spilled_areas);
    std::uint64_t at = c.spilled_at;
    ok = format::pread_all(fd, r.runs.data(), bytes_of(r.runs), at);
    at += bytes_of(r.runs);
    ok = ok && format::pread_all(fd, r.vertices.data(), bytes_of(r.vertices), at);
    at += bytes_of(r.vertices);
    ok = ok && format::pread_all(fd, r.areas.data(), bytes_of(r.areas), at);
  }
  ::close(fd);
  if (!ok) return format::Status::error(format::Code::kBadInput, path, "shorter than the loop summaries written to it");
  return out;
}

}  // namespace gaussmesh::stream
