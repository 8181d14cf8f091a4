// Segmentation for spherical parameterization (paper §6.1, Fig. 20): smoothing until every
// Gaussian triangle has at most g+1 pre-image patches, poles, greedy aggregation of non-pole
// patches, pole faces to the nearest aggregate in the L2,1 metric. See segmentation.h.
#include "stream/analysis/segmentation.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <queue>
#include <set>
#include <string>
#include <utility>

#include "stream/core/mesh_adjacency.h"
#include "stream/core/mesh_topology.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;
using format::Vec3f;

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
constexpr double kLengthTieBreak = 1e-3;  // × centroid distance / bounding-box diagonal

Status bad_input(const std::string& message) { return Status::error(Code::kBadInput, "segment", message); }

// Face areas as the sampler's filter weighs them (0 for faces without a normal of their own).
std::vector<float> face_areas(format::MeshView mesh, const FaceNormals& normals) {
  std::vector<float> area(mesh.triangles.size(), 0.0f);
  for (std::size_t f = 0; f < area.size(); ++f) {
    if (normals.degenerate[f]) continue;
    const auto& t = mesh.triangles[f];
    const Vec3d p0 = to_d(mesh.positions[t.v[0]]);
    const Vec3d n = cross(to_d(mesh.positions[t.v[1]]) - p0, to_d(mesh.positions[t.v[2]]) - p0);
    area[f] = static_cast<float>(0.5 * std::sqrt(dot(n, n)));
  }
  return area;
}

// One iteration of the sampler's low-pass filter (compute_face_normals with one more
// iteration gives the same numbers): normalized area-weighted sum over f and its edge
// neighbours; a zero sum keeps the old normal.
void smooth_once(const MeshAdjacency& adj, const std::vector<float>& area, std::vector<Vec3f>& normal,
                 std::vector<Vec3f>& next) {
  const std::size_t nf = normal.size();
  next.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    Vec3d sum = static_cast<double>(area[f]) * to_d(normal[f]);
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g != MeshAdjacency::kNoFace) sum = sum + static_cast<double>(area[g]) * to_d(normal[g]);
    }
    const Vec3f u = unit_f(sum);
    next[f] = (u.x == 0 && u.y == 0 && u.z == 0) ? normal[f] : u;
  }
  normal.swap(next);
}

// Edge-connected components of faces that `same(f, g)` joins, numbered by their lowest face.
template <class Same>
std::size_t find_components(const MeshAdjacency& adj, std::size_t nf, Same same,
                            std::vector<std::uint32_t>& component, std::vector<std::uint32_t>& stack) {
  component.assign(nf, kNone);
  std::uint32_t count = 0;
  for (std::size_t s = 0; s < nf; ++s) {
    if (component[s] != kNone) continue;
    component[s] = count;
    stack.assign(1, static_cast<std::uint32_t>(s));
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = adj.edge_neighbor[3 * f + i];
        if (g == MeshAdjacency::kNoFace || component[g] != kNone || !same(f, g)) continue;
        component[g] = count;
        stack.push_back(g);
      }
    }
    ++count;
  }
  return count;
}

// The patches of the labels: components of faces with one label. Fills face_patch,
// patch_count, patch_label.
void find_patches(const MeshAdjacency& adj, SegmentationResult& r, std::vector<std::uint32_t>& stack) {
  const auto& label = r.face_label;
  r.patch_count = find_components(
      adj, label.size(), [&](std::uint32_t f, std::uint32_t g) { return label[f] == label[g]; }, r.face_patch,
      stack);
  r.patch_label.assign(r.patch_count, kNoLabel);
  for (std::size_t f = 0; f < label.size(); ++f) r.patch_label[r.face_patch[f]] = label[f];
}

// Discretization noise: faces whose normals lie near a Gaussian edge or vertex form islands of a
// label inside another (a zig-zag of face normals across the edge's great circle), which
// smoothing does not remove and which would count as extra pre-images. A true pre-image of a
// Gaussian triangle T is bounded by faces whose labels surround T: for each edge of T, some
// neighbouring face carries a label whose centre lies beyond that edge's great circle. A patch
// that fails this (or has no label) takes the label of the neighbouring patch it shares most
// edges with (ties: lower patch id); rounds repeat until none is left (at most 32). Returns the
// number of patches relabelled.
std::size_t absorb_noise_patches(const MeshAdjacency& adj, const GaussSphere& gauss, SegmentationResult& r,
                                 std::vector<std::uint32_t>& stack) {
  const std::size_t nf = r.face_label.size();
  std::size_t absorbed = 0;
  std::vector<std::uint8_t> beyond;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;  // (patch, neighbouring patch) per edge
  for (int round = 0; round < 32; ++round) {
    find_patches(adj, r, stack);
    const std::size_t np = r.patch_count;
    if (np <= 1) break;
    beyond.assign(np, 0);
    pairs.clear();
    for (std::uint32_t f = 0; f < nf; ++f) {
      const std::uint32_t p = r.face_patch[f], t = r.face_label[f];
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = adj.edge_neighbor[3 * f + i];
        if (g == MeshAdjacency::kNoFace || r.face_patch[g] == p) continue;
        pairs.push_back({p, r.face_patch[g]});
        const std::uint32_t u = r.face_label[g];
        if (t == kNoLabel || u == kNoLabel || beyond[p] == 7) continue;
        const auto& tv = gauss.triangle_vertices(t);
        const Vec3d& c = gauss.triangle_center(u);
        for (int e = 0; e < 3; ++e) {
          // Triangles are counter-clockwise seen from outside: cross(a, b) points into T.
          if (dot(cross(gauss.vertex(tv[e]), gauss.vertex(tv[(e + 1) % 3])), c) < 0) beyond[p] |= 1u << e;
        }
      }
    }
    std::sort(pairs.begin(), pairs.end());
    // Neighbour sharing most edges with each patch (ties: lower id, the sorted order).
    std::vector<std::uint32_t> best(np, kNone), best_edges(np, 0);
    for (std::size_t k = 0; k < pairs.size();) {
      std::size_t e = k;
      while (e < pairs.size() && pairs[e] == pairs[k]) ++e;
      const auto [p, q] = pairs[k];
      if (e - k > best_edges[p]) best[p] = q, best_edges[p] = static_cast<std::uint32_t>(e - k);
      k = e;
    }
    std::vector<std::uint32_t> target(np, kNone);
    std::size_t noisy = 0;
    for (std::uint32_t p = 0; p < np; ++p) {
      if (beyond[p] == 7 && r.patch_label[p] != kNoLabel) continue;
      target[p] = best[p];
      ++noisy;
    }
    if (noisy == 0) break;
    // Patches that join a patch that is itself noisy wait for a later round, unless every noisy
    // patch would wait.
    std::vector<std::uint32_t> label_of(np);
    std::size_t moved = 0;
    for (int pass = 0; pass < 2 && moved == 0; ++pass) {
      for (std::uint32_t p = 0; p < np; ++p) {
        label_of[p] = r.patch_label[p];
        if (target[p] == kNone) continue;
        if (pass == 0 && target[target[p]] != kNone) continue;
        label_of[p] = r.patch_label[target[p]];
        ++moved;
      }
    }
    for (std::size_t f = 0; f < nf; ++f) r.face_label[f] = label_of[r.face_patch[f]];
    absorbed += moved;
  }
  find_patches(adj, r, stack);
  return absorbed;
}

Status check_topology(format::MeshView mesh, SegmentationResult& out) {
  if (mesh.triangles.empty()) return bad_input("the mesh has no faces");
  auto topo = compute_topology(mesh);
  if (!topo) {
    if (topo.status().code() == Code::kProcessing) return bad_input(topo.status().message());
    return topo.status();
  }
  const MeshTopology& t = *topo;
  if (t.degenerate_faces > 0) {
    return bad_input(std::to_string(t.degenerate_faces) +
                     " faces repeat a vertex; segmentation needs a clean closed manifold");
  }
  if (!t.is_closed()) {
    return bad_input("the mesh is not closed (" + std::to_string(t.boundary_edges) + " boundary edges in " +
                     std::to_string(t.boundary_loops) + " loops); segmentation needs a closed manifold");
  }
  if (!t.is_manifold()) {
    return bad_input("the mesh is not manifold (" + std::to_string(t.non_manifold_edges) + " non-manifold edges, " +
                     std::to_string(t.non_manifold_vertices) + " non-manifold vertices)");
  }
  if (t.orientable != std::optional<bool>(true) || !t.consistently_oriented) {
    return bad_input(t.orientable == std::optional<bool>(true)
                         ? "the faces are not consistently oriented (normals must all point outward)"
                         : "the mesh is not orientable");
  }
  if (t.components != 1) {
    return bad_input("the mesh has " + std::to_string(t.components) +
                     " components; segment one closed component at a time");
  }
  if (!t.genus || *t.genus < 0) return bad_input("the genus is undefined for this mesh");
  out.euler_characteristic = t.euler_characteristic;
  out.genus = static_cast<std::uint32_t>(*t.genus);
  return {};
}

// Step 4: greedy aggregation of the non-pole patches. Returns the aggregate of each patch
// (kNone for pole patches) and the number of aggregates.
std::size_t aggregate_patches(const SegmentationResult& r, const std::vector<std::uint8_t>& patch_is_pole,
                              const std::vector<std::uint32_t>& patch_size,
                              const std::vector<std::uint32_t>& adj_offsets,
                              const std::vector<std::uint32_t>& adj_patches, std::size_t label_count,
                              std::vector<std::uint32_t>& patch_aggregate) {
  const std::size_t np = r.patch_count;
  std::vector<std::uint32_t> order;
  for (std::uint32_t p = 0; p < np; ++p) {
    if (!patch_is_pole[p]) order.push_back(p);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return patch_size[a] > patch_size[b]; });
  patch_aggregate.assign(np, kNone);
  std::vector<std::uint32_t> label_holder(label_count + 1, kNone);  // last slot: kNoLabel
  auto slot = [&](std::uint32_t label) { return label == kNoLabel ? label_count : label; };
  std::uint32_t count = 0;
  std::queue<std::uint32_t> queue;
  for (std::uint32_t seed : order) {
    if (patch_aggregate[seed] != kNone) continue;
    const std::uint32_t a = count++;
    patch_aggregate[seed] = a;
    label_holder[slot(r.patch_label[seed])] = a;
    queue.push(seed);
    while (!queue.empty()) {
      const std::uint32_t p = queue.front();
      queue.pop();
      for (std::uint32_t k = adj_offsets[p]; k < adj_offsets[p + 1]; ++k) {
        const std::uint32_t q = adj_patches[k];
        if (patch_is_pole[q] || patch_aggregate[q] != kNone) continue;
        if (label_holder[slot(r.patch_label[q])] == a) continue;  // the aggregate has this label
        patch_aggregate[q] = a;
        label_holder[slot(r.patch_label[q])] = a;
        queue.push(q);
      }
    }
  }
  return count;
}

// Step 5: every face without a segment takes the segment of its nearest seeded face in the
// L2,1 metric (multi-source Dijkstra; the segment follows the predecessor).
void assign_by_dijkstra(format::MeshView mesh, const MeshAdjacency& adj, const std::vector<Vec3f>& normal,
                        std::vector<std::uint32_t>& segment) {
  const std::size_t nf = segment.size();
  Vec3f lo = mesh.positions[mesh.triangles[0].v[0]], hi = lo;
  for (const Vec3f& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const Vec3d span = to_d(hi) - to_d(lo);
  const double diagonal = std::sqrt(dot(span, span));
  const double length_weight = diagonal > 0 ? kLengthTieBreak / diagonal : 0.0;
  auto centroid = [&](std::uint32_t f) {
    const auto& t = mesh.triangles[f];
    return (1.0 / 3.0) * (to_d(mesh.positions[t.v[0]]) + to_d(mesh.positions[t.v[1]]) + to_d(mesh.positions[t.v[2]]));
  };
  std::vector<double> dist(nf, HUGE_VAL);
  using Entry = std::pair<double, std::uint32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (segment[f] == kNone) continue;
    dist[f] = 0;
    heap.push({0.0, f});
  }
  while (!heap.empty()) {
    const auto [d, f] = heap.top();
    heap.pop();
    if (d > dist[f]) continue;
    const Vec3d cf = centroid(f), nfv = to_d(normal[f]);
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g == MeshAdjacency::kNoFace) continue;
      const Vec3d dn = to_d(normal[g]) - nfv, dc = centroid(g) - cf;
      const double w = std::sqrt(dot(dn, dn)) + length_weight * std::sqrt(dot(dc, dc));
      if (d + w < dist[g]) {
        dist[g] = d + w;
        segment[g] = segment[f];
        heap.push({dist[g], g});
      }
    }
  }
}

// Step 6: merges the smallest segment into its best neighbour until `target` remain.
std::size_t merge_segments(const MeshAdjacency& adj, const std::vector<std::uint32_t>& face_label,
                           const std::vector<std::uint32_t>& face_patch, std::size_t count, std::size_t target,
                           std::vector<std::uint32_t>& segment) {
  const std::size_t nf = segment.size();
  std::vector<std::size_t> faces(count, 0);
  std::vector<std::map<std::uint32_t, std::uint32_t>> labels(count);      // label -> pieces
  std::vector<std::map<std::uint32_t, std::size_t>> neighbours(count);    // segment -> edges
  std::set<std::pair<std::uint32_t, std::uint32_t>> seen_patch;  // (segment, patch)
  for (std::uint32_t f = 0; f < nf; ++f) {
    const std::uint32_t s = segment[f];
    ++faces[s];
    if (seen_patch.insert({s, face_patch[f]}).second) ++labels[s][face_label[f]];
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g != MeshAdjacency::kNoFace && segment[g] != s) ++neighbours[s][segment[g]];
    }
  }
  std::vector<std::uint32_t> parent(count);
  for (std::uint32_t s = 0; s < count; ++s) parent[s] = s;
  std::set<std::pair<std::size_t, std::uint32_t>> by_size;
  for (std::uint32_t s = 0; s < count; ++s) by_size.insert({faces[s], s});
  std::size_t merges = 0;
  while (by_size.size() > target) {
    const std::uint32_t a = by_size.begin()->second;
    if (neighbours[a].empty()) break;  // cannot happen on one connected component
    std::uint32_t best = kNone;
    std::size_t best_shared = 0, best_edges = 0;
    for (const auto& [b, edges] : neighbours[a]) {
      std::size_t shared = 0;
      for (const auto& [label, pieces] : labels[a]) shared += labels[b].count(label);
      if (best == kNone || shared < best_shared || (shared == best_shared && edges > best_edges)) {
        best = b;
        best_shared = shared;
        best_edges = edges;
      }
    }
    // Merge a into best.
    by_size.erase({faces[a], a});
    by_size.erase({faces[best], best});
    faces[best] += faces[a];
    by_size.insert({faces[best], best});
    for (const auto& [label, pieces] : labels[a]) labels[best][label] += pieces;
    for (const auto& [c, edges] : neighbours[a]) {
      neighbours[c].erase(a);
      if (c == best) continue;
      neighbours[c][best] += edges;
      neighbours[best][c] += edges;
    }
    neighbours[a].clear();
    labels[a].clear();
    parent[a] = best;
    ++merges;
  }
  auto root = [&](std::uint32_t s) {
    while (parent[s] != s) s = parent[s];
    return s;
  };
  for (std::uint32_t& s : segment) s = root(s);
  return merges;
}

}  // namespace

format::Result<SegmentationResult> segment_mesh(format::MeshView mesh, const GaussSphere& gauss,
                                                const SegmentationOptions& options) {
  if (options.min_smooth > options.max_smooth) {
    return Status::error(Code::kUsage, "segment", "the starting smoothing exceeds the cap");
  }
  SegmentationResult r;
  GM_RETURN_IF_ERROR(check_topology(mesh, r));
  auto adjacency = build_mesh_adjacency(mesh);
  if (!adjacency) return adjacency.status();
  const MeshAdjacency& adj = *adjacency;
  const std::size_t nf = mesh.triangles.size();
  const std::size_t nl = gauss.triangle_count();
  const std::uint32_t sheets = r.genus + 1;

  // Step 2: smoothing until every label has at most g+1 patches.
  FaceNormals normals = compute_face_normals(mesh, adj, options.min_smooth);
  const std::vector<float> area = face_areas(mesh, normals);
  std::vector<Vec3f> scratch;
  std::vector<std::uint32_t> stack;
  std::vector<std::uint32_t> preimages(nl);
  r.smooth_iterations = options.min_smooth;
  while (true) {
    r.face_label = compute_face_labels(normals, gauss);
    r.noise_patches = absorb_noise_patches(adj, gauss, r, stack);
    std::fill(preimages.begin(), preimages.end(), 0);
    for (std::uint32_t label : r.patch_label) {
      if (label != kNoLabel) ++preimages[label];
    }
    r.max_preimages = *std::max_element(preimages.begin(), preimages.end());
    if (r.max_preimages <= sheets) break;
    if (r.smooth_iterations >= options.max_smooth) {
      r.smooth_cap_hit = true;
      break;
    }
    // Check again after about a quarter more iterations (all of them, near the start): the
    // filter is cheap, the label and patch pass is not.
    const std::uint32_t next =
        std::min(options.max_smooth, r.smooth_iterations + std::max<std::uint32_t>(1, r.smooth_iterations / 4));
    while (r.smooth_iterations < next) {
      smooth_once(adj, area, normals.normal, scratch);
      ++r.smooth_iterations;
    }
  }

  // Step 3: poles.
  std::vector<std::uint8_t> label_is_pole(nl, 0);
  for (std::size_t l = 0; l < nl; ++l) {
    if (preimages[l] == 0) ++r.empty_labels;
    else if (preimages[l] < sheets) label_is_pole[l] = 1, ++r.poles;
  }
  std::vector<std::uint8_t> patch_is_pole(r.patch_count, 0);
  std::vector<std::uint32_t> patch_size(r.patch_count, 0);
  for (std::uint32_t p = 0; p < r.patch_count; ++p) {
    const std::uint32_t l = r.patch_label[p];
    patch_is_pole[p] = l == kNoLabel ? 1 : label_is_pole[l];  // faces without a normal go with the poles
    r.pole_patches += patch_is_pole[p];
  }
  r.face_pole.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    ++patch_size[r.face_patch[f]];
    r.face_pole[f] = patch_is_pole[r.face_patch[f]];
    r.pole_faces += r.face_pole[f];
  }

  // Patch adjacency graph (CSR, neighbours sorted, no duplicates).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::uint32_t f = 0; f < nf; ++f) {
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g != MeshAdjacency::kNoFace && r.face_patch[g] != r.face_patch[f]) {
        pairs.push_back({r.face_patch[f], r.face_patch[g]});
      }
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<std::uint32_t> adj_offsets(r.patch_count + 1, 0), adj_patches(pairs.size());
  for (const auto& [p, q] : pairs) ++adj_offsets[p + 1];
  for (std::size_t p = 0; p < r.patch_count; ++p) adj_offsets[p + 1] += adj_offsets[p];
  for (std::size_t k = 0; k < pairs.size(); ++k) adj_patches[k] = pairs[k].second;

  // Step 4: greedy aggregation.
  std::vector<std::uint32_t> patch_aggregate;
  r.greedy_aggregates =
      aggregate_patches(r, patch_is_pole, patch_size, adj_offsets, adj_patches, nl, patch_aggregate);

  // Step 5: pole faces to the nearest aggregate.
  std::vector<std::uint32_t> segment(nf);
  std::size_t count = r.greedy_aggregates;
  if (count == 0) {
    std::fill(segment.begin(), segment.end(), 0);
    count = 1;
  } else {
    for (std::size_t f = 0; f < nf; ++f) segment[f] = patch_aggregate[r.face_patch[f]];
    assign_by_dijkstra(mesh, adj, normals.normal, segment);
  }

  // Step 6: fallback merges.
  if (count > sheets) r.merges = merge_segments(adj, r.face_label, r.face_patch, count, sheets, segment);

  // Number segments by their lowest face; sizes; labels held by two or more pieces.
  std::vector<std::uint32_t> renumber(count, kNone);
  r.face_segment.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    std::uint32_t& id = renumber[segment[f]];
    if (id == kNone) id = static_cast<std::uint32_t>(r.segment_count++);
    r.face_segment[f] = id;
  }
  r.segment_faces.assign(r.segment_count, 0);
  for (std::uint32_t s : r.face_segment) ++r.segment_faces[s];
  // Pieces: edge-connected faces with one label and one segment; pole labels are split by
  // design (their faces go to the nearest segment), so only non-pole labels count.
  std::vector<std::uint32_t> piece;
  const std::size_t pieces = find_components(
      adj, nf,
      [&](std::uint32_t f, std::uint32_t g) {
        return r.face_label[f] == r.face_label[g] && r.face_segment[f] == r.face_segment[g];
      },
      piece, stack);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> piece_key(pieces);  // (segment, label)
  for (std::size_t f = 0; f < nf; ++f) piece_key[piece[f]] = {r.face_segment[f], r.face_label[f]};
  std::sort(piece_key.begin(), piece_key.end());
  r.duplicate_labels.assign(r.segment_count, 0);
  for (std::size_t k = 1; k < pieces; ++k) {
    const bool first_repeat = piece_key[k] == piece_key[k - 1] && (k < 2 || piece_key[k - 2] != piece_key[k]);
    const std::uint32_t label = piece_key[k].second;
    if (first_repeat && label != kNoLabel && !label_is_pole[label]) ++r.duplicate_labels[piece_key[k].first];
  }
  return r;
}

}  // namespace gaussmesh::stream
