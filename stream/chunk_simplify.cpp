// simplify out of core: passes A-C over the chunks and the stitch. See chunk_simplify.h.
#include "stream/chunk_simplify.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <iterator>
#include <numbers>

#include "stream/piece_joins.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

bool is_collapsed(const format::Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }

format::Status damaged(const std::string& what) { return format::Status::error(format::Code::kBadInput, "stitch", what); }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Loads every chunk and calls body (stream/chunk_sampler.h for_each_chunk), reporting `pass`.
format::Status for_each_chunk(const Partition& partition, std::uint32_t threads, const char* pass,
                              const OutOfCoreSimplifyOptions& options, const ChunkBody& body) {
  return stream::for_each_chunk(partition, threads, body, [&](std::size_t done, std::size_t total) {
    if (options.progress) options.progress(pass, done, total, partition.faces);
  });
}

}  // namespace

void find_chunk_loops(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                      const std::function<std::uint32_t(std::uint32_t)>& patch_of_face,
                      const std::function<bool(std::uint32_t)>& is_corner, const std::vector<GlobalSample>& samples,
                      ChunkLoops& out) {
  const std::size_t nf = chunk.triangles.size();
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  const auto& tris = chunk.triangles;
  std::vector<std::uint32_t> patch(nf);
  for (std::uint32_t f = 0; f < nf; ++f) patch[f] = patch_of_face(f);
  auto border = [&](std::uint32_t f, int i) {
    const std::uint32_t g = nb[3 * std::size_t{f} + i];
    return g == MeshAdjacency::kNoFace || patch[g] != patch[f];
  };
  // Half-edges of owned faces on a patch border, with their successor around the end vertex
  // (the polygon mesher's next_border, under the merged patches).
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f] || is_collapsed(tris[f])) continue;
    for (int i = 0; i < 3; ++i) {
      if (!border(f, i)) continue;
      const std::uint32_t b = tris[f].v[(i + 1) % 3];
      std::uint32_t g = f;
      int j = (i + 1) % 3;
      std::uint64_t next = ~std::uint64_t{0};
      const std::size_t bound = adjacency.star_end(b) - adjacency.star_begin(b) + 2;
      for (std::size_t step = 0; step < bound; ++step) {
        if (border(g, j)) {
          next = 3 * chunk.global_face[g] + static_cast<std::uint64_t>(j);
          break;
        }
        const std::uint32_t h = nb[3 * std::size_t{g} + j];
        int k = 0;
        while (k < 3 && tris[h].v[k] != b) ++k;
        if (k == 3) break;
        g = h;
        j = k;
      }
      out.half_edges.push_back({3 * chunk.global_face[f] + static_cast<std::uint64_t>(i), next,
                                chunk.global_vertex[tris[f].v[i]], patch[f], nb[3 * std::size_t{f} + i] == MeshAdjacency::kNoFace});
    }
  }
  // Owned vertices with feature edges, and owned samples.
  for (std::uint32_t v = 0; v < chunk.positions.size(); ++v) {
    if (!chunk.owned_vertex[v]) continue;
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
    LoopVertexRecord r;
    r.vertex = gv;
    r.position = chunk.positions[v];
    r.degree = degree;
    if (is_sample) {
      r.role = VertexRole::kSample;
    } else if (degree == 1 || degree >= 3 || is_corner(gv)) {
      r.role = VertexRole::kCorner;
    } else if (degree == 2 && out_breaks == 1 && in_breaks == 1 &&
               turns_at_boundary(chunk.positions[u], chunk.positions[v], chunk.positions[w])) {
      r.role = VertexRole::kCorner;
    }
    if (is_sample && degree == 0 && adjacency.star_end(v) > adjacency.star_begin(v))
      r.interior_patch = patch[corners[adjacency.star_begin(v)] / 3];
    out.vertices.push_back(r);
  }
  // Vector areas of the merged patches, over owned faces.
  std::map<std::uint32_t, std::array<double, 3>> areas;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f] || is_collapsed(tris[f])) continue;
    const auto& a = chunk.positions[tris[f].v[0]];
    const auto& b = chunk.positions[tris[f].v[1]];
    const auto& c = chunk.positions[tris[f].v[2]];
    const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
    auto& sum = areas[patch[f]];
    sum[0] += uy * vz - uz * vy;
    sum[1] += uz * vx - ux * vz;
    sum[2] += ux * vy - uy * vx;
  }
  for (const auto& [p, sum] : areas) out.areas.emplace_back(p, sum);
}

format::Result<PolygonGraphInput> stitch_loops(const std::vector<ChunkLoops>& chunks, std::size_t patches,
                                               const std::vector<format::Vec3f>& plane_normal,
                                               const std::vector<std::pair<std::uint32_t, format::Vec3f>>& extra_vertices) {
  std::vector<HalfEdgeRecord> halves;
  std::vector<LoopVertexRecord> vertices;
  PolygonGraphInput g;
  g.patches = patches;
  g.patch_area.assign(patches, {0, 0, 0});
  g.patch_has_faces.assign(patches, 0);
  std::size_t total_halves = 0, total_vertices = extra_vertices.size();
  for (const ChunkLoops& c : chunks) {
    total_halves += c.half_edges.size();
    total_vertices += c.vertices.size();
  }
  halves.reserve(total_halves);
  vertices.reserve(total_vertices);
  for (const ChunkLoops& c : chunks) {
    halves.insert(halves.end(), c.half_edges.begin(), c.half_edges.end());
    vertices.insert(vertices.end(), c.vertices.begin(), c.vertices.end());
    for (const auto& [p, sum] : c.areas) {
      if (p >= patches) return damaged("a vector area names an unknown patch");
      for (int k = 0; k < 3; ++k) g.patch_area[p][k] += sum[k];
      g.patch_has_faces[p] = 1;
    }
  }
  for (const auto& [v, position] : extra_vertices) {
    LoopVertexRecord r;
    r.vertex = v;
    r.position = position;
    vertices.push_back(r);
  }
  std::sort(halves.begin(), halves.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  std::sort(vertices.begin(), vertices.end(), [](const auto& a, const auto& b) { return a.vertex < b.vertex; });
  for (std::size_t k = 1; k < halves.size(); ++k)
    if (halves[k].id == halves[k - 1].id) return damaged("half-edge " + std::to_string(halves[k].id) + " twice");
  for (std::size_t k = 1; k < vertices.size(); ++k)
    if (vertices[k].vertex == vertices[k - 1].vertex) return damaged("vertex " + std::to_string(vertices[k].vertex) + " twice");
  auto half_at = [&](std::uint64_t id) -> std::int64_t {
    auto it = std::lower_bound(halves.begin(), halves.end(), id, [](const auto& a, std::uint64_t x) { return a.id < x; });
    return it != halves.end() && it->id == id ? it - halves.begin() : -1;
  };
  auto dense = [&](std::uint32_t v) -> std::int64_t {
    auto it = std::lower_bound(vertices.begin(), vertices.end(), v, [](const auto& a, std::uint32_t x) { return a.vertex < x; });
    return it != vertices.end() && it->vertex == v ? it - vertices.begin() : -1;
  };
  for (const LoopVertexRecord& r : vertices) {
    g.positions.push_back(r.position);
    g.global.push_back(r.vertex);
    g.degree.push_back(r.degree);
    g.role.push_back(r.role);
  }
  g.interior_samples.assign(patches, {});
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const std::uint32_t p = vertices[k].interior_patch;
    if (p == kNone) continue;
    if (p >= patches) return damaged("an interior sample names an unknown patch");
    g.interior_samples[p].push_back(static_cast<std::uint32_t>(k));
  }
  g.plane_normal = plane_normal;
  // Loops: each patch's from its lowest unwalked half-edge id.
  std::vector<std::uint32_t> order(halves.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return halves[a].patch < halves[b].patch; });
  std::vector<std::uint8_t> walked(halves.size(), 0);
  std::size_t breaks = 0;
  for (std::uint32_t start : order) {
    if (walked[start]) continue;
    PatchLoop loop;
    loop.patch = halves[start].patch;
    if (loop.patch >= patches) return damaged("a half-edge names an unknown patch");
    std::int64_t at = start;
    for (std::size_t guard = 0;; ++guard) {
      if (at < 0 || guard > halves.size() || walked[at] || halves[at].patch != loop.patch)
        return damaged("the half-edges of patch " + std::to_string(loop.patch) + " do not close into a loop");
      walked[at] = 1;
      const std::int64_t d = dense(halves[at].from);
      if (d < 0) return damaged("no record for loop vertex " + std::to_string(halves[at].from));
      loop.vertices.push_back(static_cast<std::uint32_t>(d));
      loop.is_break.push_back(halves[at].is_break);
      breaks += halves[at].is_break;
      at = half_at(halves[at].next);
      if (at == start) break;
    }
    g.loops.push_back(std::move(loop));
  }
  g.graph.feature_edges = breaks + (halves.size() - breaks) / 2;
  return g;
}

format::Result<OutOfCoreSimplify> simplify_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                       const OutOfCoreSimplifyOptions& options) {
  if (options.sampler.sample_test != SampleTest::kExact) {
    return format::Status::error(format::Code::kUsage, "simplify",
                                 "out of core (--memory) runs the exact sample test only: the paper test's "
                                 "noisy-sample filter needs candidate chains across chunks, which are not stitched yet");
  }
  if (options.spheres.empty() || options.threads == 0) {
    return format::Status::error(format::Code::kUsage, "simplify", "no orientation, or 0 threads");
  }
  auto created = create_spheres(options.spheres);
  if (!created) return created.status();
  std::vector<GaussSphere>& spheres = *created;
  auto partition = partition_for_chunks(input_path, read, options.partition, options.sampler, options.threads);
  if (!partition) return partition.status();
  OutOfCoreSimplify out;
  out.vertices = partition->vertices;
  out.faces = partition->faces;
  out.chunks = partition->chunks.size();
  out.seconds_ingest = partition->seconds_ingest;
  out.seconds_partition = partition->seconds_partition;
  out.peak_rss_after_partition = peak_rss();
  const std::size_t nc = partition->chunks.size(), no = spheres.size();

  // Pass A: samples of every orientation (and, with one orientation, the pieces too). Each
  // chunk's border edges and face answers go to disk (stream/piece_joins.h) as it finishes.
  auto start = std::chrono::steady_clock::now();
  std::vector<std::vector<GlobalSample>> samples(nc * no);
  std::vector<ChunkPieces> pieces(nc);
  // Border-edge records: about one per face of each chunk's first overlap ring, whose size is
  // about the overlap's over the rings (a guess: a wrong one costs reads, not memory).
  std::uint64_t expected_border = 0;
  for (const ChunkInfo& info : partition->chunks)
    expected_border += (info.faces - std::min(info.faces, info.owned_faces)) / std::max<std::uint32_t>(options.partition.rings, 1);
  auto joins = PieceJoinFiles::create(partition->dir, nc, border_bucket_count(expected_border, options.partition.memory_bytes));
  if (!joins) return joins.status();
  auto find_pieces = [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
    find_chunk_pieces(*partition, chunk, ws.adjacency, ws.labels, ws.feature, pieces[c]);
    return (*joins)->spill(static_cast<std::uint32_t>(c), pieces[c]);
  };
  GM_RETURN_IF_ERROR(for_each_chunk(*partition, options.threads, "sample", options,
                                    [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
                                      ChunkSamplingStats stats;
                                      for (std::size_t k = 0; k < no; ++k) {
                                        GM_RETURN_IF_ERROR(sample_chunk(chunk, spheres[k], options.sampler, ws,
                                                                        samples[c * no + k], stats));
                                      }
                                      if (no == 1) return find_pieces(c, chunk, ws);
                                      return format::Status();
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
  }
  samples = {};
  if (no > 1) {
    GM_RETURN_IF_ERROR(for_each_chunk(*partition, options.threads, "pieces", options,
                                      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
                                        std::vector<GlobalSample> unused;
                                        ChunkSamplingStats stats;
                                        GM_RETURN_IF_ERROR(sample_chunk(chunk, gauss, options.sampler, ws, unused, stats));
                                        return find_pieces(c, chunk, ws);
                                      }));
  }
  GM_RETURN_IF_ERROR((*joins)->finish());
  partition->bytes_spilled += (*joins)->bytes_written();
  out.seconds_sample = seconds_since(start);
  out.peak_rss_after_pieces = peak_rss();

  // Stitch: patches, merge.
  start = std::chrono::steady_clock::now();
  auto stitched = stitch_pieces(pieces, **joins, options.partition.memory_bytes);
  if (!stitched) return stitched.status();
  pieces = {};
  const PatchMergeResult merged = merge_stitched_patches(*stitched);
  out.patches = merged.patch_label.size();
  out.merged_patches = merged.merged_patches;
  out.merge_rounds = merged.rounds;
  std::vector<std::uint32_t> corners;
  for (std::size_t k = 0; k < stitched->candidates.size(); ++k)
    if (merged.is_candidate[k]) corners.push_back(stitched->candidates[k].vertex);
  out.candidates = corners.size();
  out.peak_rss_after_merge = peak_rss();
  auto merged_patch_of_piece = [&](PieceId piece) -> std::uint32_t {
    const std::int64_t p = stitched->patch_of_piece(piece);
    return p < 0 ? kNone : merged.patch_of[p];
  };

  // A chunk's faces under the merged patches: labels again (sample_chunk), pieces again
  // (deterministic), owned faces through their piece, the others through the owners' answer
  // files (each read once per chunk); kNone where neither knows (faces far from every owned face).
  auto merged_patches_of_chunk = [&](const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                                     std::vector<std::uint32_t>& patch) -> format::Status {
    std::vector<GlobalSample> unused;
    ChunkSamplingStats stats;
    GM_RETURN_IF_ERROR(sample_chunk(chunk, gauss, options.sampler, ws, unused, stats));
    ChunkPieces scratch;
    std::vector<std::uint32_t> piece_index;
    find_chunk_pieces(*partition, chunk, ws.adjacency, ws.labels, ws.feature, scratch, &piece_index);
    scratch = {};
    std::vector<PieceId> face_piece;
    GM_RETURN_IF_ERROR(chunk_face_pieces(*partition, chunk, piece_index, **joins, face_piece));
    patch.resize(chunk.triangles.size());
    for (std::uint32_t f = 0; f < patch.size(); ++f) patch[f] = merged_patch_of_piece(face_piece[f]);
    return format::Status();
  };

  // Pass C: loops under the merged patches.
  std::vector<ChunkLoops> loops(nc);
  GM_RETURN_IF_ERROR(for_each_chunk(
      *partition, options.threads, "loops", options,
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        std::vector<std::uint32_t> patch;
        GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch));
        auto patch_of_face = [&](std::uint32_t f) { return patch[f]; };
        auto is_corner = [&](std::uint32_t v) { return std::binary_search(corners.begin(), corners.end(), v); };
        find_chunk_loops(chunk, ws.adjacency, patch_of_face, is_corner, chosen[c], loops[c]);
        return format::Status();
      }));
  for (const ChunkLoops& l : loops) out.stitch_half_edges += l.half_edges.size();
  out.peak_rss_after_loops = peak_rss();
  out.bytes_spilled = partition->bytes_spilled;
  std::vector<format::Vec3f> plane(merged.patch_label.size());
  for (std::size_t p = 0; p < plane.size(); ++p) {
    if (merged.patch_label[p] == kNoLabel) continue;
    const Vec3d& c = gauss.triangle_center(merged.patch_label[p]);
    plane[p] = {float(c.x), float(c.y), float(c.z)};
  }
  auto graph = stitch_loops(loops, merged.patch_label.size(), plane);
  if (!graph) return graph.status();
  out.seconds_stitch = seconds_since(start);

  start = std::chrono::steady_clock::now();
  auto meshed = mesh_patch_loops(*graph);
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
    std::vector<std::vector<Fetched>> per_chunk(nc);
    GM_RETURN_IF_ERROR(for_each_chunk(
        *partition, options.threads, "faces", options,
        [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
          std::vector<std::uint32_t> patch_of;
          GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch_of));
          for (std::uint32_t f = 0; f < chunk.triangles.size(); ++f) {
            const auto& t = chunk.triangles[f];
            if (!chunk.owned_face[f] || is_collapsed(t)) continue;
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
    std::vector<std::pair<std::uint32_t, format::Vec3f>> missing;
    for (const auto& e : extra)
      if (!std::binary_search(graph->global.begin(), graph->global.end(), e.first)) missing.push_back(e);
    auto regraph = stitch_loops(loops, merged.patch_label.size(), plane, missing);
    if (!regraph) return regraph.status();
    graph = std::move(regraph);
    auto dense = [&](std::uint32_t v) {
      return static_cast<std::uint32_t>(std::lower_bound(graph->global.begin(), graph->global.end(), v) - graph->global.begin());
    };
    std::map<std::uint32_t, PatchFaces> by_patch;
    for (const Fetched& r : fetched) {
      PatchFaces& pf = by_patch[r.patch];
      pf.patch = r.patch;
      pf.triangles.push_back({dense(r.v[0]), dense(r.v[1]), dense(r.v[2])});
    }
    for (auto& [patch, pf] : by_patch) graph->patch_faces.push_back(std::move(pf));
    out.fetched_patches = wanted.size();
    out.fetched_faces = fetched.size();
    meshed = mesh_patch_loops(*graph);
    if (!meshed) return meshed.status();
  }
  partition->remove_temp();
  out.mesh = std::move(meshed->mesh.mesh);
  out.birth = std::move(meshed->mesh.birth);
  out.polygon = meshed->stats;
  out.rotation = gauss.options().rotation;
  out.gauss_vertices = gauss.vertex_count();
  out.gauss_triangles = gauss.triangle_count();
  out.seconds_mesh = seconds_since(start);
  return out;
}

}  // namespace gaussmesh::stream
