// Shape approximation, polygon first (paper §5 "Shape Approximation", per-patch approach), the
// default mesher: patch loops, canonical guards, planar triangulation per patch,
// densify-and-retry, then the corner collapses of stream/meshing/collapse_mesher on the
// output-sized mesh. See polygon_mesher.h.
#include "stream/meshing/polygon_mesher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <tuple>
#include <unordered_set>
#include <utility>
#include <vector>

#include "stream/core/canonical_order.h"
#include "stream/core/edge_key_map.h"
#include "stream/core/hash_mix.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/core/process_memory.h"
#include "stream/meshing/polygon_triangulation.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
constexpr double kBoundaryTurnDegrees = 30;  // as the collapse mesher: a boundary corner
constexpr std::size_t kMaxRounds = 24;
// A failing patch first gets the middle vertex of every stretch of its loops between kept
// vertices, up to this many times, before it keeps every loop vertex.
constexpr std::uint8_t kMaxRefinements = 6;

enum class Keep : std::uint8_t { kNo = 0, kCorner, kGuard, kSample };

// One boundary loop in memory (its patch is in loop_patch_): the vertices of its half-edges in
// walking order (the patch on the left), and per half-edge whether it is a break edge.
struct Loop {
  std::vector<std::uint32_t> vertices;
  std::vector<std::uint8_t> is_break;
};

enum class PatchMode : std::uint8_t { kReduced, kRefined, kDensified, kCollapsed, kOriginal };

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return a < b ? std::uint64_t{a} << 32 | b : std::uint64_t{b} << 32 | a;
}

bool is_collapsed(const format::Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }

// Empties each vector and frees its allocation (assigning {} keeps the capacity).
template <class... Vectors>
void release(Vectors&... vectors) {
  ((Vectors().swap(vectors)), ...);
}

class PolygonMesher {
 public:
  // skip[f]: a face left out (collapsed, or a repeat of an earlier face's vertex set); the
  // adjacency is the mesh's without them.
  PolygonMesher(const PatchMesherInput& input, MeshAdjacency adjacency, std::vector<std::uint8_t> skip)
      : in_(&input),
        adj_(std::move(adjacency)),
        tris_(input.mesh.triangles.data()),
        skip_(std::move(skip)),
        positions_(input.mesh.positions),
        plane_(input.patch_plane_normal),
        has_faces_(true),
        from_mesh_(true) {}

  // Out of core: everything from records (PolygonGraphInput); no faces.
  // graph's loops, roles, ids and per-patch arrays are moved from (or freed); its positions and
  // plane normals must outlive the mesher.
  explicit PolygonMesher(PolygonGraphInput& graph)
      : in_(nullptr),
        tris_(nullptr),
        positions_(graph.positions),
        source_(graph.position_source),
        plane_(graph.plane_normal),
        has_faces_(false),
        from_mesh_(false) {
    vertex_count_ = source_ ? graph.vertex_count : graph.positions.size();
    patch_count_ = graph.patches;
    // Input faces fetched for some patches: a face list per patch, as group_faces makes it.
    face_available_.assign(patch_count_, 0);
    patch_offset_.assign(patch_count_ + 1, 0);
    for (const PatchFaces& pf : graph.patch_faces) {
      if (pf.patch < patch_count_) patch_offset_[pf.patch + 1] += static_cast<std::uint32_t>(pf.triangles.size());
    }
    for (std::size_t q = 0; q < patch_count_; ++q) patch_offset_[q + 1] += patch_offset_[q];
    own_tris_.resize(patch_offset_[patch_count_]);
    patch_faces_.resize(own_tris_.size());
    for (const PatchFaces& pf : graph.patch_faces) {
      if (pf.patch >= patch_count_) continue;
      face_available_[pf.patch] = 1;
      std::uint32_t at = patch_offset_[pf.patch];
      for (const auto& t : pf.triangles) {
        own_tris_[at] = {{t[0], t[1], t[2]}};
        patch_faces_[at] = at;
        ++at;
      }
    }
    tris_ = own_tris_.data();
    patch_loop_offset_.assign(patch_count_ + 1, 0);
    if (graph.loop_source) {
      loop_source_ = std::move(graph.loop_source);
      loop_patch_ = std::move(graph.loop_patch);
      loop_offset_ = std::move(graph.loop_offset);
    } else {
      loops_.reserve(graph.loops.size());
      for (PatchLoop& l : graph.loops) {
        loop_patch_.push_back(l.patch);
        loops_.push_back({std::move(l.vertices), std::move(l.is_break)});
      }
    }
    graph.loops = {};
    for (std::uint32_t p : loop_patch_) ++patch_loop_offset_[p + 1];
    for (std::size_t q = 0; q < patch_count_; ++q) patch_loop_offset_[q + 1] += patch_loop_offset_[q];
    degree_ = std::move(graph.degree);
    keep_.assign(graph.role.size(), Keep::kNo);
    for (std::size_t v = 0; v < graph.role.size(); ++v) {
      if (graph.role[v] == VertexRole::kSample) keep_[v] = Keep::kSample;
      else if (graph.role[v] == VertexRole::kCorner) keep_[v] = Keep::kCorner;
      else if (graph.role[v] == VertexRole::kGuard) keep_[v] = Keep::kGuard;
    }
    std::vector<VertexRole>().swap(graph.role);  // keep_ holds what the mesher needs of it
    interior_of_patch_ = std::move(graph.interior_samples);
    for (const auto& list : interior_of_patch_) result_.stats.interior_samples += list.size();
    patch_area_.assign(graph.patch_area.begin(), graph.patch_area.end());
    release(graph.patch_area);
    patch_has_faces_ = std::move(graph.patch_has_faces);
    global_ = std::move(graph.global);
    result_.mesh.graph = graph.graph;
    corners_given_ = degree_.empty();
  }

  format::Result<PolygonMesherResult> run() {
    if (from_mesh_) {
      group_faces();
      walk_loops();
      count_boundary_loops();
      count_feature_degrees();
      choose_kept();
    }
    count_corners();
    choose_guards();
    if (!loop_status().is_ok()) return loop_status();
    mode_.assign(patch_count_, PatchMode::kReduced);
    refinements_.assign(patch_count_, 0);
    for (std::size_t round = 0; round < kMaxRounds; ++round) {
      ++result_.stats.rounds;
      std::vector<std::uint32_t> failed;
      bool retry = false;
      triangulate_all(failed, retry);
      // Out of core, within a budget: a round grows its tables, and the allocator keeps what
      // their growth freed; handed back after each round, the rounds' peak is what they hold,
      // not that plus the old copies.
      if (!from_mesh_) release_free_memory();
      if (!loop_status().is_ok()) return loop_status();
      if (failed.empty() && !retry) return finish();
      // Out of core, a patch that reaches the steps needing its input faces without them: stop
      // and name every such patch; the caller fetches their faces and runs the mesher again
      // (the same rounds repeat: nothing before these steps depends on faces).
      for (std::uint32_t p : failed) {
        if (!has_faces(p) && (mode_[p] == PatchMode::kCollapsed || mode_[p] == PatchMode::kDensified))
          result_.needs_faces.push_back(p);
      }
      if (!result_.needs_faces.empty()) {
        if (source_ && !source_->status().is_ok()) return source_->status();
        return std::move(result_);
      }
      for (std::uint32_t p : failed) densify(p);
      if (!loop_status().is_ok()) return loop_status();
    }
    return format::Status::error(format::Code::kProcessing, "polygon mesher",
                                 "patches still failing after " + std::to_string(kMaxRounds) + " rounds");
  }

 private:
  std::uint32_t vertex(std::uint32_t f, int i) const { return tris_[f].v[i]; }
  // A vertex's position: in memory, or fetched once from the source. By value: the cache grows.
  format::Vec3f pos(std::uint32_t v) {
    if (!source_) return positions_[v];
    bool inserted = false;
    const std::uint32_t slot = fetched_slot_.emplace(v, static_cast<std::uint32_t>(fetched_.size()), &inserted);
    if (inserted) fetched_.push_back(source_->position(v));
    return fetched_[slot];
  }
  std::uint32_t neighbor(std::uint32_t f, int i) const { return adj_.edge_neighbor[3 * std::size_t{f} + i]; }

  // The order every canonical choice below uses (a chain's direction, a loop's start, a
  // stretch's middle, the order patches are triangulated in, the output's vertex order): by
  // position, x then y then z, and by id only between vertices at the same position. Choices by
  // id would follow the input's numbering, and a renumbered copy of a mesh (shuffled, welded
  // from a soup) would come out different.
  bool before(std::uint32_t u, std::uint32_t v) { return u != v && order_key(u) < order_key(v); }
  PositionKey order_key(std::uint32_t v) { return position_key(pos(v), v); }
  // The first of `vertices` in that order (the lowest index among repeats); 0 when empty.
  // key(v): v's PositionKey.
  template <class Key>
  static std::size_t least(std::span<const std::uint32_t> vertices, Key&& key) {
    if (vertices.empty()) return 0;
    std::size_t best = 0;
    PositionKey best_key = key(vertices[0]);
    for (std::size_t k = 1; k < vertices.size(); ++k) {
      const PositionKey here = key(vertices[k]);
      if (here < best_key) {
        best = k;
        best_key = here;
      }
    }
    return best;
  }
  std::size_t least(std::span<const std::uint32_t> vertices) {
    return least(vertices, [&](std::uint32_t v) { return order_key(v); });
  }
  // Vertex ids (any order, repeats allowed) numbered 0, 1, ... in the order of before().
  struct Numbering {
    std::vector<std::uint32_t> by_id;     // the distinct ids, ascending
    std::vector<std::uint32_t> rank;      // by_id[i]'s number
    std::vector<std::uint32_t> in_order;  // the ids by number
    format::VertexIndex operator()(std::uint32_t v) const {
      return rank[std::lower_bound(by_id.begin(), by_id.end(), v) - by_id.begin()];
    }
    // A triangle of ids in new numbers, turned to start at its least (the same orientation).
    std::array<format::VertexIndex, 3> turned(const std::array<std::uint32_t, 3>& t) const {
      std::array<format::VertexIndex, 3> g{(*this)(t[0]), (*this)(t[1]), (*this)(t[2])};
      std::rotate(g.begin(), std::min_element(g.begin(), g.end()), g.end());
      return g;
    }
  };
  Numbering number_in_order(std::vector<std::uint32_t> ids) {
    Numbering n;
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    n.by_id = std::move(ids);
    std::vector<PositionKey> key;
    key.reserve(n.by_id.size());
    for (std::uint32_t v : n.by_id) key.push_back(order_key(v));
    std::vector<std::uint32_t> order(n.by_id.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
    n.rank.resize(order.size());
    n.in_order.resize(order.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) {
      n.rank[order[i]] = i;
      n.in_order[i] = n.by_id[order[i]];
    }
    return n;
  }
  // least() over a loop read out of core, whose positions need not stay cached: read in one
  // batch into scratch (a loop with no stop has no vertex the rounds keep, bar its guards).
  std::size_t least_on_loop(std::span<const std::uint32_t> loop) {
    if (!source_) return least(loop);
    std::vector<std::uint32_t> ids(loop.begin(), loop.end());
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    std::vector<format::Vec3f> at(ids.size());
    source_->positions(ids, at);
    return least(loop, [&](std::uint32_t v) {
      return position_key(at[std::lower_bound(ids.begin(), ids.end(), v) - ids.begin()], v);
    });
  }
  // Out of core: the positions of `ids` that are not cached yet, read in one batch into the cache.
  void fetch(std::vector<std::uint32_t>& ids) {
    if (!source_) return;
    std::erase_if(ids, [&](std::uint32_t v) { return fetched_slot_.contains(v); });
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    const std::size_t first = fetched_.size();
    fetched_.resize(first + ids.size());
    source_->positions(ids, std::span(fetched_).subspan(first));
    for (std::size_t i = 0; i < ids.size(); ++i) fetched_slot_.emplace(ids[i], static_cast<std::uint32_t>(first + i));
  }

  std::size_t loop_count() const { return loop_patch_.size(); }
  // Loop l's vertices: in memory, or read from the loop source into buffer (until the next
  // call with that buffer). Empty when the read fails or names a vertex out of range; then
  // loop_status() says why.
  std::span<const std::uint32_t> loop_vertices(std::size_t l, std::vector<std::uint32_t>& buffer) {
    if (!loop_source_) return loops_[l].vertices;
    buffer.resize(loop_offset_[l + 1] - loop_offset_[l]);
    bool ok = loop_source_->read(loop_offset_[l], buffer);
    for (std::size_t k = 0; ok && k < buffer.size(); ++k) ok = buffer[k] < vertex_count_;
    if (ok) return buffer;
    if (loop_error_.is_ok() && loop_source_->status().is_ok())
      loop_error_ = format::Status::error(format::Code::kProcessing, "polygon mesher", "a loop vertex is out of range");
    buffer.clear();
    return {};
  }
  format::Status loop_status() const {
    if (!loop_error_.is_ok() || !loop_source_) return loop_error_;
    return loop_source_->status();
  }
  bool is_border(std::uint32_t f, int i) const {
    const std::uint32_t g = neighbor(f, i);
    return g == MeshAdjacency::kNoFace || in_->face_patch[g] != in_->face_patch[f];
  }

  // Faces by patch (CSR, ascending face ids); collapsed faces take no part.
  void group_faces() {
    const std::size_t nf = in_->mesh.triangles.size();
    std::uint32_t max_patch = 0;
    for (std::size_t f = 0; f < nf; ++f) max_patch = std::max(max_patch, in_->face_patch[f]);
    patch_count_ = nf == 0 ? 0 : std::size_t{max_patch} + 1;
    patch_offset_.assign(patch_count_ + 1, 0);
    for (std::size_t f = 0; f < nf; ++f) {
      if (skip_[f]) {
        ++result_.mesh.skipped_input_faces;
        continue;
      }
      ++patch_offset_[in_->face_patch[f] + 1];
    }
    for (std::size_t p = 0; p < patch_count_; ++p) patch_offset_[p + 1] += patch_offset_[p];
    patch_faces_.resize(patch_offset_[patch_count_]);
    std::vector<std::uint32_t> cursor(patch_offset_.begin(), patch_offset_.end() - 1);
    for (std::size_t f = 0; f < nf; ++f) {
      if (!skip_[f]) patch_faces_[cursor[in_->face_patch[f]]++] = static_cast<std::uint32_t>(f);
    }
  }

  // The half-edge after (f, i) on the border of f's patch (by_patch) or on a break edge (not
  // by_patch): turn around its end vertex through the faces until such a half-edge leaves it.
  std::pair<std::uint32_t, int> next_border(std::uint32_t f, int i, bool by_patch = true) const {
    return next_loop_half_edge(adj_, tris_, f, i, [&](std::uint32_t g, int j) {
      return by_patch ? is_border(g, j) : neighbor(g, j) == MeshAdjacency::kNoFace;
    });
  }

  // Loops of break edges (holes of the input), for the report.
  void count_boundary_loops() {
    std::vector<std::uint8_t>& visited = visited_;  // walk_loops' buffer, warm
    std::fill(visited.begin(), visited.end(), 0);
    for (std::uint32_t f0 : patch_faces_) {
      for (int i0 = 0; i0 < 3; ++i0) {
        if (visited[3 * std::size_t{f0} + i0] || neighbor(f0, i0) != MeshAdjacency::kNoFace) continue;
        ++result_.mesh.graph.boundary_loops;
        std::uint32_t f = f0;
        int i = i0;
        for (std::size_t guard = 0; guard < visited.size() && !visited[3 * std::size_t{f} + i]; ++guard) {
          visited[3 * std::size_t{f} + i] = 1;
          const auto [g, j] = next_border(f, i, false);
          if (g == kNone) break;
          f = g;
          i = j;
        }
      }
    }
    visited_ = {};
  }

  void walk_loops() {
    std::vector<std::uint8_t>& visited = visited_;
    visited.assign(3 * in_->mesh.triangles.size(), 0);
    patch_loop_offset_.assign(patch_count_ + 1, 0);
    for (std::uint32_t p = 0; p < patch_count_; ++p) {
      for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k) {
        const std::uint32_t f0 = patch_faces_[k];
        for (int i0 = 0; i0 < 3; ++i0) {
          if (visited[3 * std::size_t{f0} + i0] || !is_border(f0, i0)) continue;
          Loop loop;
          std::uint32_t f = f0;
          int i = i0;
          bool closed = false;
          for (std::size_t guard = 0; guard < visited.size(); ++guard) {
            visited[3 * std::size_t{f} + i] = 1;
            loop.vertices.push_back(vertex(f, i));
            loop.is_break.push_back(neighbor(f, i) == MeshAdjacency::kNoFace);
            const auto [g, j] = next_border(f, i);
            if (g == kNone) break;
            if (g == f0 && j == i0) {
              closed = true;
              break;
            }
            if (visited[3 * std::size_t{g} + j]) break;
            f = g;
            i = j;
          }
          if (!closed) broken_patch_.push_back(p);  // cannot happen on a valid adjacency
          loops_.push_back(std::move(loop));
          loop_patch_.push_back(p);
        }
      }
      patch_loop_offset_[p + 1] = static_cast<std::uint32_t>(loops_.size());
    }
  }

  // Distinct feature edges at each vertex: a manifold border counted once (from the face
  // where it runs from the lower id), every break edge once per face holding it.
  void count_feature_degrees() {
    degree_.assign(positions_.size(), 0);
    for (std::uint32_t p = 0; p < patch_count_; ++p) {
      for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k) {
        const std::uint32_t f = patch_faces_[k];
        for (int i = 0; i < 3; ++i) {
          if (!is_border(f, i)) continue;
          const std::uint32_t a = vertex(f, i), b = vertex(f, (i + 1) % 3);
          if (neighbor(f, i) != MeshAdjacency::kNoFace && a > b) continue;
          ++degree_[a];
          ++degree_[b];
          ++result_.mesh.graph.feature_edges;
        }
      }
    }
  }

  bool is_boundary_turn(const Loop& loop, std::size_t k) {
    const std::size_t n = loop.vertices.size();
    const std::size_t prev = (k + n - 1) % n;
    if (!loop.is_break[prev] || !loop.is_break[k]) return false;
    return turns_at_boundary(pos(loop.vertices[prev]), pos(loop.vertices[k]), pos(loop.vertices[(k + 1) % n]));
  }

  void keep(std::uint32_t v, Keep k) {
    if (keep_[v] < k) keep_[v] = k;
  }

  void choose_kept() {
    const std::size_t nv = positions_.size();
    keep_.assign(nv, Keep::kNo);
    for (std::size_t v = 0; v < nv; ++v) {
      if (in_->vertex_role[v] == VertexRole::kSample) keep_[v] = Keep::kSample;
      else if (in_->vertex_role[v] == VertexRole::kGuard) keep_[v] = Keep::kGuard;
      else if (degree_[v] > 0 && (in_->vertex_role[v] == VertexRole::kCorner || degree_[v] == 1 || degree_[v] >= 3))
        keep_[v] = Keep::kCorner;
    }
    for (const Loop& loop : loops_) {
      for (std::size_t k = 0; k < loop.vertices.size(); ++k) {
        if (degree_[loop.vertices[k]] == 2 && is_boundary_turn(loop, k)) keep(loop.vertices[k], Keep::kCorner);
      }
    }
    // Samples off every feature edge are inserted into their patch.
    interior_of_patch_.assign(patch_count_, {});
    for (std::size_t v = 0; v < nv; ++v) {
      if (keep_[v] != Keep::kSample || degree_[v] != 0 || adj_.star_end(v) == adj_.star_begin(v)) continue;
      const std::uint32_t f = adj_.vertex_corners[adj_.star_begin(v)] / 3;
      interior_of_patch_[in_->face_patch[f]].push_back(static_cast<std::uint32_t>(v));
      ++result_.stats.interior_samples;
    }
  }

  void count_corners() {
    if (corners_given_) return;
    for (std::size_t v = 0; v < degree_.size(); ++v) {
      if (degree_[v] > 0 && (degree_[v] != 2 || keep_[v] != Keep::kNo)) ++result_.mesh.graph.corners;
    }
  }

  // Chains between stops, canonical (the same whichever patch's loop they are read from), and
  // the guard rules over them. The loops are read one at a time (out of core they stay in their
  // file, which grows with the input), each chain leaving a record of what the rules need.
  // A chain's interior vertices have two feature edges each, so its first edge decides its path:
  // two records with the same ends, length and second vertex are one chain, read from its two
  // sides (the path's hash only guards that argument).
  void choose_guards() {
    auto is_stop = [&](std::uint32_t v) { return keep_[v] != Keep::kNo || (!corners_given_ && degree_[v] != 2); };
    struct Chain {
      std::uint32_t front, back, edges, second;  // vertices 0, edges and 1 in the canonical direction
      std::uint64_t hash;                        // of its vertices in that direction
      std::uint32_t third, two_thirds, middle;   // vertices edges / 3, 2 * edges / 3 and edges / 2
      auto key() const { return std::tie(front, back, edges, second, hash); }
    };
    std::vector<Chain> chains;
    std::vector<std::uint32_t> closed_loop_min;  // least vertex of each loop without a stop
    std::vector<std::uint32_t> guards;
    if (source_) {  // the stops' positions decide the chains' directions: read them in one batch
      std::vector<std::uint32_t> stops;
      for (std::uint32_t v = 0; v < keep_.size(); ++v)
        if (is_stop(v)) stops.push_back(v);
      fetch(stops);
    }
    for (std::size_t l = 0; l < loop_count(); ++l) {
      const std::span<const std::uint32_t> loop = loop_vertices(l, loop_buffer_);
      const std::size_t n = loop.size();
      if (n == 0) continue;  // a failed read: run() ends with it
      std::size_t first = n;
      for (std::size_t k = 0; k < n; ++k) {
        if (is_stop(loop[k])) {
          first = k;
          break;
        }
      }
      if (first == n) {
        // A closed loop with no corner: 3 vertices, spread from its least vertex, walking
        // towards its lesser neighbour (the same on both sides of the loop).
        const auto low = static_cast<std::ptrdiff_t>(least_on_loop(loop));
        const std::uint32_t next = loop[(low + 1) % n], prev = loop[(low + n - 1) % n];
        const std::ptrdiff_t step = before(next, prev) ? 1 : -1;
        closed_loop_min.push_back(loop[low]);
        for (std::size_t j = 0; j < std::min<std::size_t>(n, 3); ++j) {
          const std::ptrdiff_t where = (low + step * static_cast<std::ptrdiff_t>(j * n / 3)) % static_cast<std::ptrdiff_t>(n);
          guards.push_back(loop[(where + static_cast<std::ptrdiff_t>(n)) % static_cast<std::ptrdiff_t>(n)]);
        }
        continue;
      }
      for (std::size_t k = first, seen = 0; seen < n;) {
        const std::size_t start = k;
        std::uint32_t edges = 0;
        do {
          k = (k + 1) % n;
          ++seen;
          ++edges;
        } while (!is_stop(loop[k]));
        bool reversed = false;
        // Vertex i (0 .. edges) of the chain, read backwards from its end when reversed.
        auto at = [&](std::uint32_t i) { return loop[(start + (reversed ? edges - i : i)) % n]; };
        const std::uint32_t a = at(0), b = at(edges);
        reversed = before(b, a) || (a == b && edges > 2 && before(at(edges - 1), at(1)));
        std::uint64_t hash = 0;
        for (std::uint32_t i = 0; i <= edges; ++i) hash = mix64(hash + at(i) + 0x9E3779B97F4A7C15ull);
        chains.push_back({at(0), at(edges), edges, at(1), hash, at(edges / 3), at(2 * edges / 3), at(edges / 2)});
      }
    }
    loop_buffer_ = {};
    // By end points, then path: chains joining the same two stops are neighbours.
    std::sort(chains.begin(), chains.end(), [](const Chain& x, const Chain& y) { return x.key() < y.key(); });
    chains.erase(std::unique(chains.begin(), chains.end(), [](const Chain& x, const Chain& y) { return x.key() == y.key(); }),
                 chains.end());
    std::sort(closed_loop_min.begin(), closed_loop_min.end());
    result_.mesh.graph.closed_loops =
        std::unique(closed_loop_min.begin(), closed_loop_min.end()) - closed_loop_min.begin();
    result_.mesh.graph.chains = chains.size();
    for (std::size_t i = 0; i < chains.size();) {
      const std::uint32_t front = chains[i].front, back = chains[i].back;
      std::size_t j = i + 1;
      while (j < chains.size() && chains[j].front == front && chains[j].back == back) ++j;
      for (std::size_t k = i; k < j; ++k) {
        const Chain& q = chains[k];
        const std::uint32_t m = q.edges;
        if (front == back) {
          // A loop through one corner: two more vertices make it a triangle.
          if (m >= 3) {
            guards.push_back(q.third);
            guards.push_back(q.two_thirds);
          } else if (m == 2) {
            guards.push_back(q.middle);
          }
        } else if (j - i > 1 && m >= 2) {
          guards.push_back(q.middle);  // one of several chains joining the same two corners
        }
      }
      i = j;
    }
    for (std::uint32_t g : guards) {
      if (keep_[g] == Keep::kNo) ++result_.stats.guards;
      keep(g, Keep::kGuard);
    }
  }

  // The next step for a patch that failed: refine its loops (the middle vertex of every stretch
  // between kept vertices; canonical, so the neighbour sharing a chain sees the same vertices),
  // then keep every loop vertex, then keep its input triangles.
  void densify(std::uint32_t p) {
    if (mode_[p] == PatchMode::kReduced || mode_[p] == PatchMode::kRefined) {
      if (mode_[p] == PatchMode::kReduced) ++result_.stats.refined_patches;
      mode_[p] = PatchMode::kRefined;
      bool added = false;
      if (refinements_[p] < kMaxRefinements) {
        ++refinements_[p];
        for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l)
          added |= refine(loop_vertices(l, loop_buffer_));
      }
      if (added) return;
    }
    if (mode_[p] == PatchMode::kRefined) {
      mode_[p] = PatchMode::kCollapsed;
      ++result_.stats.collapsed_patches;
    } else if (mode_[p] == PatchMode::kCollapsed) {
      mode_[p] = PatchMode::kDensified;
      ++result_.stats.densified_patches;
      for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l)
        for (std::uint32_t v : loop_vertices(l, loop_buffer_)) keep(v, Keep::kGuard);
    } else if (mode_[p] == PatchMode::kDensified && has_faces(p)) {
      mode_[p] = PatchMode::kOriginal;
      ++result_.stats.original_patches;
      for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k)
        for (std::uint32_t v : tris_[patch_faces_[k]].v) keep(v, Keep::kGuard);
    }
  }

  // Keeps the middle vertex (by index, from the lesser end) of every stretch of the loop
  // between two kept vertices that has inner vertices. The choice depends on the stretch alone,
  // whichever side it is read from. Returns whether anything was added.
  bool refine(std::span<const std::uint32_t> loop) {
    const std::size_t n = loop.size();
    std::vector<std::size_t> at;
    for (std::size_t k = 0; k < n; ++k)
      if (keep_[loop[k]] != Keep::kNo) at.push_back(k);
    std::vector<std::uint32_t> chosen;
    if (at.empty()) return false;  // closed loops always have guards
    for (std::size_t i = 0; i < at.size(); ++i) {
      const std::size_t a = at[i], b = i + 1 < at.size() ? at[i + 1] : at[0] + n;
      const std::size_t m = b - a;  // edges in the stretch
      if (m < 2) continue;
      // Walk from the lesser end so both sides pick the same vertex.
      const std::uint32_t va = loop[a % n], vb = loop[b % n];
      const std::size_t mid = !before(vb, va) ? a + m / 2 : b - m / 2;
      chosen.push_back(loop[mid % n]);
    }
    for (std::uint32_t v : chosen) keep(v, Keep::kGuard);
    result_.stats.guards += chosen.size();
    return !chosen.empty();
  }

  // One round: every patch in id order, against the edges made so far. Fills out_ and lists
  // the patches that failed.
  void triangulate_all(std::vector<std::uint32_t>& failed, bool& retry) {
    out_tris_.clear();
    out_patch_.clear();
    result_.mesh.planar_patches = 0;
    // Reduced loops (kept vertices only), one flat list; last round's are kept for replay.
    std::swap(reduced_offset_, last_reduced_offset_);
    std::swap(reduced_vertices_, last_reduced_vertices_);
    std::swap(records_, last_records_);
    std::swap(queries_, last_queries_);
    std::swap(patch_tris_, last_patch_tris_);
    records_.assign(patch_count_, PatchRecord{});
    queries_.clear();
    patch_tris_.clear();
    reduced_offset_.assign(loop_count() + 1, 0);
    reduced_vertices_.clear();
    for (std::size_t l = 0; l < loop_count(); ++l) {
      if (mode_[loop_patch_[l]] != PatchMode::kOriginal) {
        for (std::uint32_t v : loop_vertices(l, loop_buffer_))
          if (keep_[v] != Keep::kNo) reduced_vertices_.push_back(v);
      }
      reduced_offset_[l + 1] = static_cast<std::uint32_t>(reduced_vertices_.size());
    }
    loop_buffer_ = {};
    // Chain edges first: a reduced loop edge appears once per side (twice for a border, once
    // for a break edge); more means two chains landed on one edge. edges_ holds every edge
    // made so far, its value the number of reduced loop sides it is on.
    edges_.reset(reduced_vertices_.size());
    // About one triangle per reduced loop vertex and two queries: room up front, so that the
    // first round does not copy and first-touch these arrays again each time they double.
    out_tris_.reserve(reduced_vertices_.size());
    out_patch_.reserve(reduced_vertices_.size());
    patch_tris_.reserve(reduced_vertices_.size());
    queries_.reserve(2 * reduced_vertices_.size());
    for (std::size_t l = 0; l < loop_count(); ++l) {
      const std::span<const std::uint32_t> r = reduced(l);
      for (std::size_t k = 0; k < r.size(); ++k) ++edges_.emplace(edge_key(r[k], r[(k + 1) % r.size()]), 0);
    }
    failing_.assign(patch_count_, 0);
    for (std::uint32_t p : broken_patch_) failing_[p] = 1;
    for (std::size_t l = 0; l < loop_count(); ++l) {
      const std::span<const std::uint32_t> r = reduced(l);
      const std::uint32_t p = loop_patch_[l];
      if (mode_[p] == PatchMode::kOriginal) continue;
      if (r.size() < 3) failing_[p] = 1;
      for (std::size_t k = 0; k < r.size(); ++k) {
        const std::uint32_t a = r[k], b = r[(k + 1) % r.size()];
        if (a == b || *edges_.find(edge_key(a, b)) > 2) failing_[p] = 1;
      }
    }
    if (patch_order_.empty()) order_patches();
    if (source_) prefetch_positions();
    // Patches that keep their input triangles go first: their edges are fixed.
    for (std::uint32_t p : patch_order_) {
      if (mode_[p] != PatchMode::kOriginal || !has_faces(p)) continue;
      for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k) {
        const auto& t = tris_[patch_faces_[k]];
        out_tris_.push_back({t.v[0], t.v[1], t.v[2]});
        out_patch_.push_back(p);
        for (int i = 0; i < 3; ++i) edges_.insert(edge_key(t.v[i], t.v[(i + 1) % 3]));
      }
    }
    // Then those built by collapses on their own faces, every loop vertex kept.
    for (std::uint32_t p : patch_order_) {
      if (mode_[p] != PatchMode::kCollapsed) continue;
      const Collapse c = collapse_patch(p);
      if (c == Collapse::kFailed) failed.push_back(p);
      if (c == Collapse::kRetry) retry = true;
    }
    for (std::uint32_t p : patch_order_) {
      if (mode_[p] == PatchMode::kOriginal || mode_[p] == PatchMode::kCollapsed ||
          (from_mesh_ ? patch_offset_[p] == patch_offset_[p + 1] : !patch_has_faces_[p]))
        continue;
      if (failing_[p] || !replay_or_triangulate_patch(p)) {
        failed.push_back(p);
      } else {
        ++result_.mesh.planar_patches;
      }
    }
  }

  // The order patches are triangulated in, each against the edges made before it: by the least
  // kept vertex on its loops and the one after it on that loop (the patch on the left, so two
  // patches sharing that vertex differ there), as the first round's reduced loops give them.
  // Patches with no loop go last, by id. Fixed for the later rounds.
  void order_patches() {
    if (source_) {
      std::vector<std::uint32_t> ids(reduced_vertices_);
      fetch(ids);
    }
    // Per patch: (no loop, least kept vertex's key, the next one's key), then its id.
    using Key = std::tuple<bool, PositionKey, PositionKey>;
    std::vector<Key> key(patch_count_, Key{true, {}, {}});
    for (std::size_t l = 0; l < loop_count(); ++l) {
      const std::span<const std::uint32_t> r = reduced(l);
      if (r.empty()) continue;
      const std::size_t k = least(r);
      key[loop_patch_[l]] = std::min(key[loop_patch_[l]], Key{false, order_key(r[k]), order_key(r[(k + 1) % r.size()])});
    }
    patch_order_.resize(patch_count_);
    for (std::uint32_t p = 0; p < patch_count_; ++p) patch_order_[p] = p;
    std::sort(patch_order_.begin(), patch_order_.end(),
              [&](std::uint32_t x, std::uint32_t y) { return std::tie(key[x], x) < std::tie(key[y], y); });
  }

  // triangulate_patch(p), or its result from the last round when that is provably what it
  // would give again. triangulate_patch is a deterministic function of the patch's reduced
  // loops, its interior samples, positions and normals (all fixed but the loops) and of the
  // answers its forbidden-edge test gets (edges_ does not change while a patch is
  // triangulated). So when the loops are the same as last round and every edge it asked about
  // then is still present or absent as it was, it would make the same calls, get the same
  // answers and give the same triangles (or fail again): those are replayed. Later rounds
  // differ from the first only around the few patches that were refined.
  bool replay_or_triangulate_patch(std::uint32_t p) {
    PatchRecord& record = records_[p];
    if (can_replay(p)) {
      const PatchRecord& last = last_records_[p];
      record.query_begin = static_cast<std::uint32_t>(queries_.size());
      queries_.append(last_queries_, last.query_begin, last.query_end);
      record.query_end = static_cast<std::uint32_t>(queries_.size());
      record.outcome = last.outcome;
      record.tri_begin = static_cast<std::uint32_t>(patch_tris_.size());
      for (std::uint32_t t = last.tri_begin; t < last.tri_end; ++t) emit(p, last_patch_tris_[t]);
      record.tri_end = static_cast<std::uint32_t>(patch_tris_.size());
      if (record.outcome == Outcome::kMeanPlane) ++result_.stats.mean_plane_patches;
      return record.outcome != Outcome::kFailed;
    }
    record.query_begin = static_cast<std::uint32_t>(queries_.size());
    record.tri_begin = static_cast<std::uint32_t>(patch_tris_.size());
    const std::size_t mean_before = result_.stats.mean_plane_patches;
    logging_ = true;
    const bool ok = triangulate_patch(p);
    logging_ = false;
    record.query_end = static_cast<std::uint32_t>(queries_.size());
    record.tri_end = static_cast<std::uint32_t>(patch_tris_.size());
    record.outcome = !ok ? Outcome::kFailed
                         : (result_.stats.mean_plane_patches != mean_before ? Outcome::kMeanPlane : Outcome::kPlane);
    return ok;
  }

  bool can_replay(std::uint32_t p) const {
    if (p >= last_records_.size() || last_records_[p].outcome == Outcome::kNone) return false;
    for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l) {
      const auto now = reduced(l);
      const auto then = std::span(last_reduced_vertices_)
                            .subspan(last_reduced_offset_[l], last_reduced_offset_[l + 1] - last_reduced_offset_[l]);
      if (!std::equal(now.begin(), now.end(), then.begin(), then.end())) return false;
    }
    const PatchRecord& last = last_records_[p];
    for (std::uint32_t q = last.query_begin; q < last.query_end; ++q) {
      if (edges_.contains(last_queries_.key(q)) != last_queries_.answer(q)) return false;
    }
    return true;
  }

  // Adds a triangle of patch p to the output and its edges to edges_.
  void emit(std::uint32_t p, const std::array<std::uint32_t, 3>& g) {
    out_tris_.push_back(g);
    out_patch_.push_back(p);
    patch_tris_.push_back(g);
    for (int i = 0; i < 3; ++i) edges_.insert(edge_key(g[i], g[(i + 1) % 3]));
  }

  // Out of core: reads, in one batch in ascending id order, the positions this round's planar
  // triangulations will ask for that are not cached yet (the loop vertices and interior
  // samples of every patch that reaches triangulate_patch). The cache ends up holding the same
  // values as when they were read one by one.
  void prefetch_positions() {
    prefetch_ids_.clear();
    for (std::uint32_t p = 0; p < patch_count_; ++p) {
      if (mode_[p] == PatchMode::kOriginal || mode_[p] == PatchMode::kCollapsed || failing_[p] || !patch_has_faces_[p])
        continue;
      for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l)
        for (std::uint32_t v : reduced(l))
          if (!fetched_slot_.contains(v)) prefetch_ids_.push_back(v);
      for (std::uint32_t v : interior_of_patch_[p])
        if (!fetched_slot_.contains(v)) prefetch_ids_.push_back(v);
    }
    fetch(prefetch_ids_);
  }

  // Loop l reduced to its kept vertices (this round's; empty for a patch keeping its faces).
  std::span<const std::uint32_t> reduced(std::size_t l) const {
    return std::span(reduced_vertices_).subspan(reduced_offset_[l], reduced_offset_[l + 1] - reduced_offset_[l]);
  }

  // A patch whose loops are simple in no plane: the collapse mesher on the patch's own faces,
  // its kept loop vertices fixed, the other loop vertices collapsed along the loop and interior
  // vertices into any neighbour where legal — a pure function of the patch's faces and the kept
  // set. kRetry when a loop vertex could not be removed: it becomes kept (so the neighbour
  // across that chain keeps it too) and the round is redone. kFailed when the collapses fail or
  // would make an edge that exists elsewhere.
  enum class Collapse { kDone, kRetry, kFailed };
  Collapse collapse_patch(std::uint32_t p) {
    if (!has_faces(p)) return Collapse::kFailed;
    // Local ids in the order of before(), faces turned and sorted as finish() does: the
    // collapses depend on the patch, not on the input's numbering.
    std::vector<std::uint32_t> ids;
    for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k)
      for (std::uint32_t v : tris_[patch_faces_[k]].v) ids.push_back(v);
    const Numbering local = number_in_order(std::move(ids));
    const std::vector<std::uint32_t>& vertices = local.in_order;
    Mesh sub;
    for (std::uint32_t v : vertices) sub.positions.push_back(pos(v));
    for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k) {
      const auto& t = tris_[patch_faces_[k]].v;
      const auto g = local.turned({t[0], t[1], t[2]});
      sub.triangles.push_back({{g[0], g[1], g[2]}});
    }
    std::sort(sub.triangles.begin(), sub.triangles.end(),
              [](const format::Triangle& a, const format::Triangle& b) {
                return std::tie(a.v[0], a.v[1], a.v[2]) < std::tie(b.v[0], b.v[1], b.v[2]);
              });
    std::vector<VertexRole> roles(vertices.size(), VertexRole::kNone);
    std::vector<std::uint8_t> on_loop(vertices.size(), 0);
    for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l) {
      for (std::uint32_t v : loop_vertices(l, loop_buffer_)) {
        on_loop[local(v)] = 1;
        if (keep_[v] != Keep::kNo) roles[local(v)] = VertexRole::kGuard;
      }
    }
    for (std::size_t i = 0; i < vertices.size(); ++i)
      if (keep_[vertices[i]] == Keep::kSample) roles[i] = VertexRole::kSample;
    const std::vector<std::uint32_t> one_patch(sub.triangles.size(), 0);
    auto meshed = mesh_patches_by_collapse({sub.view(), one_patch, roles});
    if (!meshed || meshed->skipped_input_faces > 0) return Collapse::kFailed;
    bool retry = false;
    for (std::uint32_t b : meshed->birth) {
      if (on_loop[b] && keep_[vertices[b]] == Keep::kNo) {
        keep(vertices[b], Keep::kGuard);
        ++result_.stats.guards;
        retry = true;
      }
    }
    if (retry) return Collapse::kRetry;
    // Its loop edges are now the reduced loop edges, already in edges_; any other edge must be
    // new.
    std::unordered_set<std::uint64_t> own_loop_edges;
    for (std::uint32_t l = patch_loop_offset_[p]; l < patch_loop_offset_[p + 1]; ++l) {
      std::vector<std::uint32_t> r;
      for (std::uint32_t v : loop_vertices(l, loop_buffer_))
        if (keep_[v] != Keep::kNo) r.push_back(v);
      for (std::size_t k = 0; k < r.size(); ++k) own_loop_edges.insert(edge_key(r[k], r[(k + 1) % r.size()]));
    }
    std::vector<std::array<std::uint32_t, 3>> tris;
    for (const auto& t : meshed->mesh.triangles) {
      std::array<std::uint32_t, 3> g{};
      for (int i = 0; i < 3; ++i) g[i] = vertices[meshed->birth[t.v[i]]];
      for (int i = 0; i < 3; ++i) {
        const std::uint64_t key = edge_key(g[i], g[(i + 1) % 3]);
        if (!own_loop_edges.count(key) && edges_.contains(key)) return Collapse::kFailed;
      }
      tris.push_back(g);
    }
    for (const auto& g : tris) {
      out_tris_.push_back(g);
      out_patch_.push_back(p);
      for (int i = 0; i < 3; ++i) edges_.insert(edge_key(g[i], g[(i + 1) % 3]));
      for (std::uint32_t v : g) keep(v, Keep::kGuard);  // interior vertices the collapses kept
    }
    return Collapse::kDone;
  }

  // The patch's vector area (sum of its faces' cross products): its mean normal.
  PolygonPoint3 mean_normal(std::uint32_t p) const {
    if (!from_mesh_) return p < patch_area_.size() ? patch_area_[p] : PolygonPoint3{0, 0, 0};
    PolygonPoint3 normal{0, 0, 0};
    for (std::uint32_t k = patch_offset_[p]; k < patch_offset_[p + 1]; ++k) {
      const auto& t = tris_[patch_faces_[k]];
      const auto& a = positions_[t.v[0]];
      const auto& b = positions_[t.v[1]];
      const auto& c = positions_[t.v[2]];
      const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
      const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
      normal[0] += uy * vz - uz * vy;
      normal[1] += uz * vx - ux * vz;
      normal[2] += ux * vy - uy * vx;
    }
    return normal;
  }

  // Triangulates patch p in the plane of its Gaussian triangle; where that fails (a patch
  // that a merge gave its neighbour's label need not be a height field over that plane), in
  // the plane of its mean normal.
  bool triangulate_patch(std::uint32_t p) {
    PolygonPoint3 plane{0, 0, 0};
    if (p < plane_.size()) {
      const auto& n = plane_[p];
      plane = {double(n.x), double(n.y), double(n.z)};
    }
    if (!(plane[0] == 0 && plane[1] == 0 && plane[2] == 0) && triangulate_patch(p, plane)) return true;
    if (triangulate_patch(p, mean_normal(p))) {
      ++result_.stats.mean_plane_patches;
      return true;
    }
    return false;
  }

  // The local id of vertex v in the patch being triangulated (ids in order of first use).
  std::uint32_t local_id(std::uint32_t v) {
    // Small patches: a scan; from kScanLimit local vertices on, a hash table.
    constexpr std::size_t kScanLimit = 32;
    const std::size_t n = local_to_vertex_.size();
    if (n < kScanLimit) {
      for (std::size_t i = 0; i < n; ++i)
        if (local_to_vertex_[i] == v) return static_cast<std::uint32_t>(i);
    } else {
      if (local_index_.size() != n) {
        local_index_.reset(2 * n);
        for (std::size_t i = 0; i < n; ++i) local_index_.emplace(local_to_vertex_[i], static_cast<std::uint32_t>(i));
      }
      if (const std::uint32_t* i = local_index_.find(v)) return *i;
      local_index_.emplace(v, static_cast<std::uint32_t>(n));
    }
    const format::Vec3f q = pos(v);
    local_to_vertex_.push_back(v);
    local_points_.push_back({double(q.x), double(q.y), double(q.z)});
    return static_cast<std::uint32_t>(n);
  }

  bool triangulate_patch(std::uint32_t p, const PolygonPoint3& normal) {
    const std::uint32_t lb = patch_loop_offset_[p], le = patch_loop_offset_[p + 1];
    if (lb == le) return false;  // a closed patch with no border: nothing to build it from
    if (!(normal[0] != 0 || normal[1] != 0 || normal[2] != 0) || !std::isfinite(normal[0] + normal[1] + normal[2]))
      return false;
    // Each loop read from its least vertex, the outer loop (the largest area about the normal)
    // first and the holes by their least vertex, local ids in that order: the triangulation is
    // then the same whichever vertex a loop was walked from and however the input numbers them.
    const std::size_t loop_count = le - lb;
    loop_start_.clear();
    loop_area_.clear();
    loop_order_.clear();
    for (std::uint32_t l = lb; l < le; ++l) {
      const std::span<const std::uint32_t> r = reduced(l);
      const std::size_t start = least(r);
      double newell[3] = {0, 0, 0};
      format::Vec3f b = pos(r[start]);
      for (std::size_t i = 0; i < r.size(); ++i) {
        const format::Vec3f a = b;
        b = pos(r[(start + i + 1) % r.size()]);
        newell[0] += double(a.y) * b.z - double(a.z) * b.y;
        newell[1] += double(a.z) * b.x - double(a.x) * b.z;
        newell[2] += double(a.x) * b.y - double(a.y) * b.x;
      }
      loop_start_.push_back(static_cast<std::uint32_t>(start));
      loop_area_.push_back(newell[0] * normal[0] + newell[1] * normal[1] + newell[2] * normal[2]);
      loop_order_.push_back(l - lb);
    }
    const std::size_t outer = std::max_element(loop_area_.begin(), loop_area_.end()) - loop_area_.begin();
    if (!(loop_area_[outer] > 0)) return false;
    std::swap(loop_order_[0], loop_order_[outer]);
    // (Every loop has 3 kept vertices or more here: shorter ones mark the patch failing.)
    auto first_of = [&](std::uint32_t i) { return reduced(lb + i)[loop_start_[i]]; };
    std::sort(loop_order_.begin() + 1, loop_order_.end(), [&](std::uint32_t x, std::uint32_t y) {
      const std::uint32_t a = first_of(x), b = first_of(y);
      return a != b ? before(a, b) : x < y;
    });
    local_to_vertex_.clear();
    local_points_.clear();
    local_index_.reset();
    if (local_loops_.size() < loop_count) local_loops_.resize(loop_count);
    for (std::size_t i = 0; i < loop_count; ++i) {
      std::vector<std::uint32_t>& local = local_loops_[i];
      local.clear();
      const std::span<const std::uint32_t> r = reduced(lb + loop_order_[i]);
      const std::size_t start = loop_start_[loop_order_[i]];
      for (std::size_t k = 0; k < r.size(); ++k) local.push_back(local_id(r[(start + k) % r.size()]));
    }
    const std::size_t loop_points = local_points_.size();
    interior_.assign(interior_of_patch_[p].begin(), interior_of_patch_[p].end());
    std::sort(interior_.begin(), interior_.end(), [&](std::uint32_t a, std::uint32_t b) { return before(a, b); });
    for (std::uint32_t v : interior_) local_id(v);
    if (local_points_.size() != loop_points + interior_.size()) return false;  // a sample on a loop twice
    project_to_plane(local_points_, normal, local_points_[local_loops_[0][0]], plane_points_);
    const std::span<const std::vector<std::uint32_t>> loops = std::span(local_loops_).first(loop_count);
    if (!triangulate_polygon_2d(std::span(plane_points_).first(loop_points), loops, forbidden_, workspace_, tri_).is_ok())
      return false;
    for (std::size_t i = loop_points; i < local_points_.size(); ++i) {
      if (!insert_point(plane_points_, static_cast<std::uint32_t>(i), tri_)) return false;
    }
    for (const auto& t : tri_) emit(p, {local_to_vertex_[t[0]], local_to_vertex_[t[1]], local_to_vertex_[t[2]]});
    return true;
  }

  // Splits the triangle holding point x (strictly inside: 3 triangles; on an edge between two
  // triangles: 4). False when x lies outside, on a loop edge or on a vertex.
  static bool insert_point(const std::vector<PolygonPoint2>& pt, std::uint32_t x, std::vector<PolygonTriangle>& tri) {
    for (std::size_t t = 0; t < tri.size(); ++t) {
      const auto [a, b, c] = tri[t];
      const int s[3] = {orientation_2d(pt[a], pt[b], pt[x]), orientation_2d(pt[b], pt[c], pt[x]),
                        orientation_2d(pt[c], pt[a], pt[x])};
      if (s[0] < 0 || s[1] < 0 || s[2] < 0) continue;
      const int zeros = (s[0] == 0) + (s[1] == 0) + (s[2] == 0);
      if (zeros == 0) {
        tri[t] = {a, b, x};
        tri.push_back({b, c, x});
        tri.push_back({c, a, x});
        return true;
      }
      if (zeros > 1) return false;
      // On edge (u, v) of t, opposite w; the triangle across it holds (v, u).
      const int e = s[0] == 0 ? 0 : (s[1] == 0 ? 1 : 2);
      const std::uint32_t u = tri[t][e], v = tri[t][(e + 1) % 3], w = tri[t][(e + 2) % 3];
      for (std::size_t o = 0; o < tri.size(); ++o) {
        for (int k = 0; k < 3; ++k) {
          if (tri[o][k] != v || tri[o][(k + 1) % 3] != u) continue;
          const std::uint32_t z = tri[o][(k + 2) % 3];
          tri[t] = {u, x, w};
          tri.push_back({x, v, w});
          tri[o] = {v, x, z};
          tri.push_back({x, u, z});
          return true;
        }
      }
      return false;
    }
    return false;
  }

  // Checks the triangles make a valid mesh, then runs the corner collapses on it.
  format::Result<PolygonMesherResult> finish() {
    // The rounds are over: their tables, replay logs and scratch go (capacity and all) before
    // phase 2 builds its mesh, and out of core the allocator hands the pages back, so that
    // phase 2 and the caller's output do not stack on what the rounds held at their peak.
    edges_ = EdgeKeyMap();
    local_index_ = EdgeKeyMap();
    queries_.release();
    last_queries_.release();
    release(patch_tris_, last_patch_tris_, records_, last_records_, reduced_vertices_, last_reduced_vertices_,
            reduced_offset_, last_reduced_offset_, failing_, prefetch_ids_, local_to_vertex_, local_points_, local_loops_,
            loop_area_, loop_start_, loop_order_, interior_, plane_points_, tri_, loop_buffer_, loop_offset_, loop_patch_, patch_loop_offset_, degree_,
            interior_of_patch_, patch_area_, refinements_, patch_order_, mode_);
    if (!from_mesh_) release_free_memory();
    auto fail = [](const std::string& what) {
      return format::Status::error(format::Code::kProcessing, "polygon mesher", what);
    };
    // Sorted keys find a repeat; only then is the first one (in triangle order) looked for.
    std::vector<std::uint64_t> directed;
    directed.reserve(3 * out_tris_.size());
    std::vector<std::array<std::uint32_t, 3>> sorted;
    sorted.reserve(out_tris_.size());
    for (const auto& t : out_tris_) {
      for (int i = 0; i < 3; ++i) directed.push_back(std::uint64_t{t[i]} << 32 | t[(i + 1) % 3]);
      auto key = t;
      std::sort(key.begin(), key.end());
      sorted.push_back(key);
    }
    std::sort(directed.begin(), directed.end());
    if (std::adjacent_find(directed.begin(), directed.end()) != directed.end()) {
      EdgeKeyMap seen;
      for (const auto& t : out_tris_) {
        for (int i = 0; i < 3; ++i) {
          if (!seen.insert(std::uint64_t{t[i]} << 32 | t[(i + 1) % 3]))
            return fail("edge " + std::to_string(t[i]) + "-" + std::to_string(t[(i + 1) % 3]) + " used twice");
        }
      }
    }
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) return fail("a triangle made twice");
    // Output vertices: those used, in the order of before(); faces turned to start at their
    // first vertex in that order, then sorted. Phase two then gets the same mesh whatever the
    // input's numbering and the order the patches were made in.
    std::vector<std::uint32_t> ids;
    ids.reserve(3 * out_tris_.size());
    for (const auto& t : out_tris_) ids.insert(ids.end(), t.begin(), t.end());
    Numbering output = number_in_order(std::move(ids));
    const std::vector<std::uint32_t>& used = output.in_order;
    Mesh mesh;
    std::vector<VertexRole> roles;
    mesh.positions.reserve(used.size());
    roles.reserve(used.size());
    for (std::uint32_t v : used) {
      mesh.positions.push_back(pos(v));
      roles.push_back(keep_[v] == Keep::kSample   ? VertexRole::kSample
                      : keep_[v] == Keep::kCorner ? VertexRole::kCorner
                                                  : VertexRole::kGuard);
    }
    std::vector<std::pair<std::array<format::VertexIndex, 3>, std::uint32_t>> faces;  // and the patch
    faces.reserve(out_tris_.size());
    for (std::size_t f = 0; f < out_tris_.size(); ++f) faces.emplace_back(output.turned(out_tris_[f]), out_patch_[f]);
    release(out_tris_, out_patch_, output.rank, output.by_id);
    std::sort(faces.begin(), faces.end());
    mesh.triangles.reserve(faces.size());
    std::vector<std::uint32_t> face_patch;
    face_patch.reserve(faces.size());
    for (const auto& [g, patch] : faces) {
      mesh.triangles.push_back({{g[0], g[1], g[2]}});
      face_patch.push_back(patch);
    }
    release(faces);
    std::vector<format::Vec3f> plane(plane_.begin(), plane_.end());
    PatchMesherInput phase_two{mesh.view(), face_patch, roles, plane, true};
    auto collapsed = mesh_patches_by_collapse(phase_two);
    if (!collapsed) return collapsed.status();
    if (collapsed->skipped_input_faces > 0) return fail("a vertex of the output would not be manifold");
    if (source_ && !source_->status().is_ok()) return source_->status();
    PolygonMesherResult out;
    out.stats = result_.stats;
    out.mesh = std::move(collapsed).value();
    for (auto& b : out.mesh.birth) b = global_.empty() ? used[b] : global_[used[b]];
    out.mesh.graph = result_.mesh.graph;
    out.mesh.skipped_input_faces = result_.mesh.skipped_input_faces;
    out.mesh.planar_patches = result_.mesh.planar_patches;
    out.mesh.collapse_patches = 0;
    return out;
  }

  const PatchMesherInput* in_;  // in core only
  MeshAdjacency adj_;
  const format::Triangle* tris_;
  std::vector<std::uint8_t> skip_;
  std::span<const format::Vec3f> positions_;
  std::shared_ptr<VertexPositionSource> source_;          // out of core: positions on demand
  EdgeKeyMap fetched_slot_;            // vertex id -> index in fetched_
  std::vector<std::uint32_t> prefetch_ids_;
  std::vector<format::Vec3f> fetched_;  // the positions read from source_
  std::size_t vertex_count_ = 0;
  bool corners_given_ = false;  // out of core without degrees: loop stops are the kept vertices
  std::span<const format::Vec3f> plane_;
  bool has_faces_;
  bool from_mesh_;                           // in core: everything comes from the mesh
  std::vector<std::uint8_t> face_available_;  // out of core: the patch's input faces were fetched
  std::vector<format::Triangle> own_tris_;    // out of core: the fetched faces, by patch
  bool has_faces(std::uint32_t p) const { return from_mesh_ || (p < face_available_.size() && face_available_[p]); }

  std::vector<PolygonPoint3> patch_area_;  // out of core: each patch's vector area, from records
  std::vector<std::uint32_t> global_;      // out of core: input vertex id of each vertex id
  std::vector<std::uint8_t> patch_has_faces_;  // out of core: the patch has a non-collapsed face
  std::size_t patch_count_ = 0;
  std::vector<std::uint32_t> patch_offset_, patch_faces_;
  std::vector<std::uint8_t> visited_;  // in core: per half-edge, for the loop walks
  std::vector<Loop> loops_;  // in memory (in core, or records given so)
  std::shared_ptr<LoopVertexSource> loop_source_;  // or in a file: loop l is its entries loop_offset_[l] ..
  std::vector<std::uint64_t> loop_offset_;
  std::vector<std::uint32_t> loop_patch_;  // per loop, either way
  std::vector<std::uint32_t> loop_buffer_;  // the loop read last from loop_source_
  format::Status loop_error_;
  std::vector<std::uint32_t> patch_loop_offset_;
  std::vector<std::uint32_t> broken_patch_;
  std::vector<std::uint32_t> degree_;
  std::vector<Keep> keep_;
  std::vector<std::vector<std::uint32_t>> interior_of_patch_;
  std::vector<PatchMode> mode_;
  std::vector<std::uint8_t> refinements_;
  std::vector<std::uint32_t> patch_order_;  // order_patches()
  // Every edge made so far this round (value: on how many reduced loop sides it lies).
  EdgeKeyMap edges_;
  std::vector<std::uint32_t> reduced_offset_, reduced_vertices_;  // per loop: its kept vertices
  std::vector<std::uint8_t> failing_;
  // Scratch of triangulate_patch, reused from patch to patch.
  std::vector<std::uint32_t> local_to_vertex_;
  EdgeKeyMap local_index_;
  std::vector<PolygonPoint3> local_points_;
  std::vector<std::vector<std::uint32_t>> local_loops_;
  std::vector<double> loop_area_;
  std::vector<std::uint32_t> loop_start_, loop_order_, interior_;
  std::vector<PolygonPoint2> plane_points_;
  std::vector<PolygonTriangle> tri_;
  PolygonWorkspace workspace_;
  // An edge may not be made twice: the forbidden test of every patch's triangulation.
  const ForbiddenEdge forbidden_ = [this](std::uint32_t u, std::uint32_t v) {
    const std::uint64_t key = edge_key(local_to_vertex_[u], local_to_vertex_[v]);
    const bool answer = edges_.contains(key);
    if (logging_) queries_.push_back(key, answer);
    return answer;
  };
  // What replay_or_triangulate_patch keeps of each patch's triangulation, this round and last.
  enum class Outcome : std::uint8_t { kNone, kPlane, kMeanPlane, kFailed };
  struct PatchRecord {
    std::uint32_t query_begin = 0, query_end = 0;  // in queries_
    std::uint32_t tri_begin = 0, tri_end = 0;      // in patch_tris_
    Outcome outcome = Outcome::kNone;              // kNone: not triangulated this round
  };
  // The forbidden-edge questions a round's triangulations asked, in order: keys and answers
  // apart, 8 bytes and a bit each (a struct of both would take 16).
  class QueryLog {
   public:
    std::size_t size() const { return keys_.size(); }
    std::uint64_t key(std::size_t q) const { return keys_[q]; }
    bool answer(std::size_t q) const { return answers_[q]; }
    void push_back(std::uint64_t key, bool answer) {
      keys_.push_back(key);
      answers_.push_back(answer);
    }
    // Appends entries begin .. end - 1 of `from`.
    void append(const QueryLog& from, std::size_t begin, std::size_t end) {
      keys_.insert(keys_.end(), from.keys_.begin() + begin, from.keys_.begin() + end);
      for (std::size_t q = begin; q < end; ++q) answers_.push_back(from.answers_[q]);
    }
    void clear() {
      keys_.clear();
      answers_.clear();
    }
    void reserve(std::size_t n) {
      keys_.reserve(n);
      answers_.reserve(n);
    }
    void release() {
      std::vector<std::uint64_t>().swap(keys_);
      std::vector<bool>().swap(answers_);
    }

   private:
    std::vector<std::uint64_t> keys_;
    std::vector<bool> answers_;
  };
  bool logging_ = false;
  std::vector<PatchRecord> records_, last_records_;
  QueryLog queries_, last_queries_;
  std::vector<std::array<std::uint32_t, 3>> patch_tris_, last_patch_tris_;
  std::vector<std::uint32_t> last_reduced_offset_, last_reduced_vertices_;
  std::vector<std::array<std::uint32_t, 3>> out_tris_;
  std::vector<std::uint32_t> out_patch_;
  PolygonMesherResult result_;
};

}  // namespace

std::vector<std::uint8_t> faces_the_mesher_skips(std::span<const format::Triangle> tris, const MeshAdjacency& adjacency,
                                                 bool* any_repeat) {
  std::vector<std::uint8_t> skip(tris.size(), 0);
  std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint32_t>> keys;
  auto sorted = [&](std::uint32_t f) {
    std::array<std::uint32_t, 3> key{tris[f].v[0], tris[f].v[1], tris[f].v[2]};
    std::sort(key.begin(), key.end());
    return key;
  };
  for (std::uint32_t f = 0; f < tris.size(); ++f) {
    const format::Triangle& t = tris[f];
    if (is_collapsed(t)) {
      skip[f] = 1;
      continue;
    }
    // f's three vertices are distinct, so a face g on the same vertex set holds all three of its
    // edges: across each one g is the neighbour, or the edge is a break (g and f run it the same
    // way, or a third face shares it). So f is suspect when an edge is a break or one face is
    // across all three (and a face across all three holds all three vertices): the same faces
    // as asking each neighbour whether it holds all three, without reading their corners.
    const std::uint32_t* nb = adjacency.edge_neighbor.data() + 3 * std::size_t{f};
    const bool suspect = nb[0] == MeshAdjacency::kNoFace || nb[1] == MeshAdjacency::kNoFace ||
                         nb[2] == MeshAdjacency::kNoFace || (nb[0] == nb[1] && nb[1] == nb[2]);
    if (suspect) keys.emplace_back(sorted(f), f);
  }
  std::sort(keys.begin(), keys.end());
  bool repeat = false;
  for (std::size_t k = 1; k < keys.size(); ++k) {
    if (keys[k].first == keys[k - 1].first) skip[keys[k].second] = repeat = true;
  }
  if (any_repeat) *any_repeat = repeat;
  return skip;
}

format::Result<PolygonMesherResult> mesh_patch_polygons(const PatchMesherInput& input) {
  const std::size_t vertices = input.mesh.positions.size();
  if (input.face_patch.size() != input.mesh.triangles.size() || input.vertex_role.size() != vertices) {
    return format::Status::error(format::Code::kProcessing, "polygon mesher",
                                 "face_patch or vertex_role does not match the mesh");
  }
  const auto& tris = input.mesh.triangles;
  format::Result<MeshAdjacency> adjacency = build_mesh_adjacency(input.mesh);
  if (!adjacency) return adjacency.status();
  bool any_repeat = false;
  std::vector<std::uint8_t> skip = faces_the_mesher_skips(tris, *adjacency, &any_repeat);
  if (any_repeat) {
    std::vector<format::Triangle> kept(tris.begin(), tris.end());
    for (std::size_t f = 0; f < kept.size(); ++f) {
      if (skip[f]) kept[f] = {{tris[f].v[0], tris[f].v[0], tris[f].v[0]}};  // collapsed: in no star
    }
    adjacency = build_mesh_adjacency({input.mesh.positions, kept});
    if (!adjacency) return adjacency.status();
  }
  PolygonMesher mesher(input, std::move(adjacency).value(), std::move(skip));
  return mesher.run();
}

format::Result<PolygonMesherResult> mesh_patch_loops(PolygonGraphInput graph) {
  const std::size_t nv = graph.position_source ? graph.vertex_count : graph.positions.size();
  if ((!graph.degree.empty() && graph.degree.size() != nv) || graph.role.size() != nv || (!graph.global.empty() && graph.global.size() != nv) ||
      graph.interior_samples.size() != graph.patches || graph.plane_normal.size() != graph.patches ||
      graph.patch_area.size() != graph.patches || graph.patch_has_faces.size() != graph.patches) {
    return format::Status::error(format::Code::kProcessing, "polygon mesher", "patch graph arrays do not match");
  }
  const auto malformed = format::Status::error(format::Code::kProcessing, "polygon mesher", "a loop is malformed");
  std::uint32_t last_patch = 0;
  for (const PatchLoop& l : graph.loops) {
    if (l.patch >= graph.patches || l.patch < last_patch || (!l.is_break.empty() && l.vertices.size() != l.is_break.size()) ||
        l.vertices.empty())
      return malformed;
    last_patch = l.patch;
    for (std::uint32_t v : l.vertices)
      if (v >= nv) return format::Status::error(format::Code::kProcessing, "polygon mesher", "a loop vertex is out of range");
  }
  // Loops in a file: their vertices are checked as they are read.
  if (graph.loop_source) {
    const auto& offset = graph.loop_offset;
    if (!graph.loops.empty() || offset.size() != graph.loop_patch.size() + 1 || offset[0] != 0) return malformed;
    for (std::size_t l = 0; l < graph.loop_patch.size(); ++l) {
      if (graph.loop_patch[l] >= graph.patches || graph.loop_patch[l] < last_patch || offset[l + 1] <= offset[l]) return malformed;
      last_patch = graph.loop_patch[l];
    }
  }
  PolygonMesher mesher(graph);
  return mesher.run();
}

bool turns_at_boundary(const format::Vec3f& prev, const format::Vec3f& at, const format::Vec3f& next) {
  const double ax = double(at.x) - prev.x, ay = double(at.y) - prev.y, az = double(at.z) - prev.z;
  const double bx = double(next.x) - at.x, by = double(next.y) - at.y, bz = double(next.z) - at.z;
  const double la = std::sqrt(ax * ax + ay * ay + az * az), lb = std::sqrt(bx * bx + by * by + bz * bz);
  if (la == 0 || lb == 0) return false;
  return ax * bx + ay * by + az * bz < std::cos(kBoundaryTurnDegrees * std::numbers::pi / 180) * la * lb;
}

}  // namespace gaussmesh::stream
