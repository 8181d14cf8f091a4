// The paper sample test out of core: candidates re-evaluated from their star geometry after the
// merge, candidate chains per chunk and their join across chunks (paper §4 "Noisy Sample
// Filtering"). See paper_chains.h.
#include "stream/stitch/paper_chains.h"
#include "stream/core/disjoint_sets.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <numeric>

namespace gaussmesh::stream {
namespace {

constexpr std::uint8_t kVertexRecord = 0x80;
constexpr std::uint8_t kDegenerateSlot = 0x04;

format::Status damaged(const std::string& where, const std::string& what) {
  return format::Status::error(format::Code::kBadInput, where, what);
}

struct GeometryRecord {
  std::uint32_t id = 0;
  format::Vec3f a, b;
  std::uint8_t flags = 0;
};

void put(std::byte* r, const GeometryRecord& g) {
  std::memcpy(r, &g.id, 4);
  std::memcpy(r + 4, &g.a, 12);
  std::memcpy(r + 16, &g.b, 12);
  r[28] = std::byte{g.flags};
}

GeometryRecord get(const std::byte* r) {
  GeometryRecord g;
  std::memcpy(&g.id, r, 4);
  std::memcpy(&g.a, r + 4, 12);
  std::memcpy(&g.b, r + 16, 12);
  g.flags = static_cast<std::uint8_t>(r[28]);
  return g;
}

// Calls body(record bytes) for every record of a segment, checking the count.
template <class Body>
format::Status for_each_record(const ChunkRecordSegment& s, std::uint32_t kind, std::uint32_t size, Body&& body) {
  if (s.records == 0) return format::Status();
  auto reader = format::RecordReader::open(s.path, kind, size, s.segment);
  if (!reader) return reader.status();
  if ((*reader)->records() != s.records) return damaged(s.path, "holds another number of records than was written");
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    for (std::size_t k = 0; k + size <= frame->size(); k += size) GM_RETURN_IF_ERROR(body(frame->data() + k));
  }
  return format::Status();
}

format::Result<ChunkRecordSegment> write_records(std::span<const std::byte> bytes, std::uint32_t kind, std::uint32_t size,
                                                 const std::vector<format::RecordField>& columns,
                                                 format::RecordSegmentFile& file) {
  ChunkRecordSegment out;
  if (bytes.empty()) return out;
  format::RecordWriterOptions options;
  options.columns = columns;
  options.frame_bytes = std::size_t{128} << 10;
  auto writer = format::RecordWriter::create_in(file, kind, size, options);
  if (!writer) return writer.status();
  GM_RETURN_IF_ERROR((*writer)->append(bytes));
  GM_RETURN_IF_ERROR((*writer)->finish());
  out.path = file.path();
  out.segment = (*writer)->segment();
  out.records = bytes.size() / size;
  return out;
}

}  // namespace

format::Result<ChunkRecordSegment> write_star_geometry(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                                                       const FaceNormals& normals, std::span<const VertexRecord> records,
                                                       format::RecordSegmentFile& file) {
  std::vector<std::byte> bytes;
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  auto append = [&](const GeometryRecord& g) {
    bytes.resize(bytes.size() + kStarGeometryRecordBytes);
    put(bytes.data() + bytes.size() - kStarGeometryRecordBytes, g);
  };
  for (const VertexRecord& r : records) {
    if (!r.is_candidate) continue;
    const std::uint32_t v = r.vertex;
    append({chunk.global_vertex[v], chunk.positions[v], {}, kVertexRecord});
    for (std::uint32_t k = adjacency.star_begin(v); k < adjacency.star_end(v); ++k) {
      const std::uint32_t f = corners[k] / 3, i = corners[k] % 3;
      GeometryRecord g;
      g.a = normals.normal[f];
      g.b = chunk.positions[chunk.triangles[f].v[(i + 1) % 3]];
      g.flags = static_cast<std::uint8_t>((adjacency.slot_flags[k] & 3u) | (normals.degenerate[f] ? kDegenerateSlot : 0));
      append(g);
    }
  }
  return write_records(bytes, kStarGeometryRecordKind, kStarGeometryRecordBytes,
                       {{4, true}, {4, false}, {4, false}, {4, false}, {4, false}, {4, false}, {4, false}, {1, false}},
                       file);
}

format::Status reevaluate_candidates(const ChunkRecordSegment& geometry, std::uint32_t chunk, const GaussSphere& gauss,
                                     const MergedStar& star, std::vector<PaperCandidate>& out) {
  // The stars of the chunk's live candidates as one small mesh: per candidate its vertex, then
  // per slot a face (candidate, neighbour, neighbour) with the slot's normal, label and feature
  // bit (edge 0, leaving the candidate), and the adjacency's slots and flags as they were.
  Mesh mini;
  FaceNormals normals;
  std::vector<std::uint32_t> labels;
  std::vector<std::uint8_t> feature;
  MeshAdjacency adjacency;
  adjacency.vertex_offsets.push_back(0);
  std::vector<std::uint32_t> list;                           // mini ids of the candidates
  std::vector<std::pair<std::uint32_t, format::Vec3f>> who;  // per entry of list: global id, position
  std::vector<StarSlotLabel> slots;
  bool live = false;
  std::size_t slot = 0;
  const std::string where = "star geometry of chunk " + std::to_string(chunk);
  auto close_star = [&]() -> format::Status {
    if (live && slot != slots.size())
      return damaged(where, "vertex " + std::to_string(who.back().first) + ": " + std::to_string(slot) +
                                " slots against a star of " + std::to_string(slots.size()));
    if (live) adjacency.vertex_offsets.push_back(static_cast<std::uint32_t>(adjacency.vertex_corners.size()));
    live = false;
    return format::Status();
  };
  GM_RETURN_IF_ERROR(for_each_record(geometry, kStarGeometryRecordKind, kStarGeometryRecordBytes,
                                     [&](const std::byte* bytes) -> format::Status {
    const GeometryRecord g = get(bytes);
    if (g.flags & kVertexRecord) {
      GM_RETURN_IF_ERROR(close_star());
      if (!who.empty() && g.id <= who.back().first) return damaged(where, "candidates not ascending");
      slots.clear();
      slot = 0;
      live = star(g.id, slots);
      if (!live) return format::Status();
      // The neighbours' vertices come after the candidate's, each with an empty star.
      list.push_back(static_cast<std::uint32_t>(mini.positions.size()));
      who.emplace_back(g.id, g.a);
      mini.positions.push_back(g.a);
      return format::Status();
    }
    if (!live) return format::Status();
    if (slot >= slots.size()) return damaged(where, "vertex " + std::to_string(who.back().first) + ": more slots than its star");
    const auto face = static_cast<std::uint32_t>(mini.triangles.size());
    const auto neighbour = static_cast<format::VertexIndex>(mini.positions.size());
    mini.positions.push_back(g.b);
    mini.triangles.push_back({{list.back(), neighbour, neighbour}});
    normals.normal.push_back(g.a);
    normals.degenerate.push_back((g.flags & kDegenerateSlot) ? 1 : 0);
    labels.push_back(slots[slot].label);
    feature.push_back(slots[slot].feature ? 1 : 0);
    adjacency.vertex_corners.push_back(3 * face);
    adjacency.slot_flags.push_back(static_cast<std::uint8_t>(g.flags & 3u));
    ++slot;
    return format::Status();
  }));
  GM_RETURN_IF_ERROR(close_star());
  // vertex_offsets so far holds one entry per candidate's end; spread it over the mini ids
  // (neighbours have empty stars).
  std::vector<std::uint32_t> offsets(mini.positions.size() + 1, 0);
  {
    std::size_t c = 0;
    std::uint32_t at = 0;
    for (std::size_t v = 0; v < mini.positions.size(); ++v) {
      offsets[v] = at;
      if (c < list.size() && list[c] == v) at = adjacency.vertex_offsets[++c];
    }
    offsets[mini.positions.size()] = at;
  }
  adjacency.vertex_offsets.swap(offsets);
  std::vector<VertexRecord> records;
  evaluate_vertex_list(mini.view(), adjacency, normals, labels, feature, gauss, false, list, records);
  if (records.size() != list.size()) return damaged(where, "a candidate is none under the merged labels");
  for (std::size_t k = 0; k < records.size(); ++k) {
    const VertexRecord& r = records[k];
    if (r.vertex != list[k] || !r.is_candidate) return damaged(where, "a candidate is none under the merged labels");
    out.push_back({who[k].first, chunk, who[k].second, r.gauss_vertex, r.characteristic, r.cover_mask, r.is_tree});
  }
  return format::Status();
}

format::Status find_chunk_chains(const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                                 std::span<const std::uint32_t> label, std::span<const std::uint8_t> known,
                                 const std::function<bool(std::uint32_t)>& is_candidate,
                                 std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
                                 std::vector<ChainFragment>& fragments) {
  const std::size_t nv = chunk.positions.size();
  const bool loop_chunk = !chunk.core_face.empty();
  const std::string where = "chain: chunk " + std::to_string(chunk.chunk);
  if (label.size() != chunk.triangles.size() || known.size() != chunk.triangles.size() ||
      (loop_chunk && chunk.loop_vertex.size() != nv))
    return format::Status::error(format::Code::kProcessing, where, "one label per face expected");
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  const auto& tris = chunk.triangles;
  const auto& global = chunk.global_vertex;
  constexpr std::uint32_t kNoNode = 0xFFFFFFFFu;
  // The other ends of the feature edges at v, one entry per fan side (find_candidate_adjacency's
  // feature_neighbors under the merged labels), as local ids.
  auto sides = [&](std::uint32_t v, std::vector<std::uint32_t>& out) -> format::Status {
    out.clear();
    for (std::uint32_t k = adjacency.star_begin(v); k < adjacency.star_end(v); ++k) {
      const std::uint32_t f = corners[k] / 3, i = corners[k] % 3;
      const std::uint32_t g = nb[3 * std::size_t{f} + i];
      if (!known[f] || (g != MeshAdjacency::kNoFace && !known[g]))
        return damaged(where, "a face around vertex " + std::to_string(global[v]) + " has no merged patch");
      if (g == MeshAdjacency::kNoFace || label[g] != label[f]) out.push_back(tris[f].v[(i + 1) % 3]);
      if (nb[3 * std::size_t{f} + (i + 2) % 3] == MeshAdjacency::kNoFace) out.push_back(tris[f].v[(i + 2) % 3]);
    }
    return format::Status();
  };
  // Nodes: the owned non-candidates on a feature edge (exactly two sides each).
  std::vector<std::uint32_t> node(nv, kNoNode), node_vertex, around;
  std::vector<std::uint8_t> candidate(nv, 0);
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (!chunk.owned_vertex[v] || (loop_chunk && !chunk.loop_vertex[v])) continue;
    GM_RETURN_IF_ERROR(sides(v, around));
    const bool cand = is_candidate(global[v]);
    if (cand != (around.size() >= 3))
      return damaged(where, "vertex " + std::to_string(global[v]) + " has " + std::to_string(around.size()) +
                                " feature-edge sides but is " + (cand ? "" : "not ") + "a candidate");
    candidate[v] = cand;
    if (cand) {
      for (std::uint32_t x : around)
        if (is_candidate(global[x])) pairs.emplace_back(std::min(global[v], global[x]), std::max(global[v], global[x]));
    } else if (!around.empty()) {
      node[v] = static_cast<std::uint32_t>(node_vertex.size());
      node_vertex.push_back(v);
    }
  }
  DisjointSets sets(node_vertex.size());
  struct End {
    std::uint32_t node;
    std::uint64_t end;
    bool link;
  };
  std::vector<End> ends;
  for (std::uint32_t n = 0; n < node_vertex.size(); ++n) {
    const std::uint32_t v = node_vertex[n];
    GM_RETURN_IF_ERROR(sides(v, around));
    for (std::uint32_t x : around) {
      if (is_candidate(global[x])) {
        ends.push_back({n, global[x], false});
      } else if (chunk.owned_vertex[x]) {
        if (node[x] == kNoNode) return damaged(where, "vertex " + std::to_string(global[x]) + " is on a chain but was not seen");
        sets.unite(n, node[x]);
      } else {
        ends.push_back({n, std::uint64_t{global[v]} << 32 | global[x], true});
      }
    }
  }
  for (End& e : ends) e.node = sets.find(e.node);
  std::stable_sort(ends.begin(), ends.end(), [](const End& a, const End& b) { return a.node < b.node; });
  for (std::size_t k = 0; k < ends.size();) {
    std::size_t m = k + 1;
    while (m < ends.size() && ends[m].node == ends[k].node) ++m;
    if (m - k != 2) return damaged(where, "a chain through vertex " + std::to_string(global[node_vertex[ends[k].node]]) +
                                              " has " + std::to_string(m - k) + " ends");
    const End& a = ends[k];
    const End& b = ends[k + 1];
    if (!a.link && !b.link) {
      if (a.end != b.end)
        pairs.emplace_back(static_cast<std::uint32_t>(std::min(a.end, b.end)), static_cast<std::uint32_t>(std::max(a.end, b.end)));
    } else {
      fragments.push_back({{a.end, b.end}, static_cast<std::uint8_t>((a.link ? 1 : 0) | (b.link ? 2 : 0))});
    }
    k = m;
  }
  return format::Status();
}

format::Result<ChunkRecordSegment> write_chain_fragments(std::span<const ChainFragment> fragments,
                                                         format::RecordSegmentFile& file) {
  std::vector<std::byte> bytes(fragments.size() * kChainFragmentRecordBytes);
  for (std::size_t k = 0; k < fragments.size(); ++k) {
    std::byte* r = bytes.data() + k * kChainFragmentRecordBytes;
    std::memcpy(r, &fragments[k].end[0], 8);
    std::memcpy(r + 8, &fragments[k].end[1], 8);
    r[16] = std::byte{fragments[k].links};
  }
  return write_records(bytes, kChainFragmentRecordKind, kChainFragmentRecordBytes, {{8, false}, {8, false}, {1, false}},
                       file);
}

format::Status join_chain_fragments(std::span<const ChunkRecordSegment> files, const MemoryBudget& budget,
                                    std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs) {
  std::uint64_t total = 0;
  for (const ChunkRecordSegment& f : files) total += f.records;
  if (total == 0) return format::Status();
  if (total >= 0xFFFFFFFFu) return format::Status::error(format::Code::kResources, "chain", "too many chain fragments");
  auto for_each_fragment = [&](auto&& body) -> format::Status {
    std::uint32_t index = 0;
    for (const ChunkRecordSegment& f : files) {
      GM_RETURN_IF_ERROR(for_each_record(f, kChainFragmentRecordKind, kChainFragmentRecordBytes, [&](const std::byte* r) {
        ChainFragment c;
        std::memcpy(&c.end[0], r, 8);
        std::memcpy(&c.end[1], r + 8, 8);
        c.links = static_cast<std::uint8_t>(r[16]);
        if (c.links == 0 || c.links > 3) return damaged(f.path, "a chain fragment with no link");
        body(index++, c);
        return format::Status();
      }));
    }
    return format::Status();
  };
  // Links, keyed by their edge (lower << 32 | higher) and the side they come from, a part at a
  // time: the part is a hash of the edge.
  std::uint64_t links = 0;
  GM_RETURN_IF_ERROR(for_each_fragment([&](std::uint32_t, const ChainFragment& c) { links += std::popcount(c.links); }));
  struct Link {
    std::uint64_t edge;
    std::uint32_t fragment;
    std::uint32_t upward;  // from the lower id to the higher
  };
  const std::uint64_t part_bytes = std::max<std::uint64_t>(budget.fraction(1, 16), std::uint64_t{1} << 20);
  const std::uint64_t parts = std::max<std::uint64_t>(1, (links * sizeof(Link) + part_bytes - 1) / part_bytes);
  auto part_of = [&](std::uint64_t edge) { return (edge * 0x9E3779B97F4A7C15ull >> 32) % parts; };
  DisjointSets sets(total);
  std::vector<Link> part;
  for (std::uint64_t p = 0; p < parts; ++p) {
    part.clear();
    GM_RETURN_IF_ERROR(for_each_fragment([&](std::uint32_t index, const ChainFragment& c) {
      for (int k = 0; k < 2; ++k) {
        if (!(c.links >> k & 1)) continue;
        const std::uint32_t from = static_cast<std::uint32_t>(c.end[k] >> 32), to = static_cast<std::uint32_t>(c.end[k]);
        const std::uint64_t edge = std::uint64_t{std::min(from, to)} << 32 | std::max(from, to);
        if (part_of(edge) == p) part.push_back({edge, index, from < to ? 1u : 0u});
      }
    }));
    std::sort(part.begin(), part.end(), [](const Link& a, const Link& b) { return a.edge < b.edge; });
    for (std::size_t k = 0; k < part.size();) {
      std::size_t m = k, up = 0;
      for (; m < part.size() && part[m].edge == part[k].edge; ++m) up += part[m].upward;
      if (2 * up != m - k)
        return damaged("chain", "the feature edge " + std::to_string(part[k].edge >> 32) + "-" +
                                    std::to_string(static_cast<std::uint32_t>(part[k].edge)) +
                                    " is left by chains unevenly from its two sides");
      // Over a span, not indices: GCC 12 at -O3 warned (-Waggressive-loop-optimizations) on those.
      for (const Link& other : std::span(part).subspan(k + 1, m - k - 1)) sets.unite(part[k].fragment, other.fragment);
      k = m;
    }
  }
  std::vector<Link>().swap(part);
  // Candidate ends by chain: two distinct ones make a pair.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ends;  // (chain, candidate)
  GM_RETURN_IF_ERROR(for_each_fragment([&](std::uint32_t index, const ChainFragment& c) {
    for (int k = 0; k < 2; ++k)
      if (!(c.links >> k & 1)) ends.emplace_back(sets.find(index), static_cast<std::uint32_t>(c.end[k]));
  }));
  std::sort(ends.begin(), ends.end());
  for (std::size_t k = 0; k < ends.size();) {
    std::size_t m = k + 1;
    while (m < ends.size() && ends[m].first == ends[k].first) ++m;
    if (m - k != 2) return damaged("chain", "a chain across chunks has " + std::to_string(m - k) + " candidate ends");
    if (ends[k].second != ends[k + 1].second) pairs.emplace_back(ends[k].second, ends[k + 1].second);
    k = m;
  }
  return format::Status();
}

std::uint64_t candidate_pairs_digest(std::span<const std::pair<std::uint32_t, std::uint32_t>> pairs) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  auto mix = [&](std::uint32_t x) {
    for (int k = 0; k < 4; ++k) {
      h ^= (x >> (8 * k)) & 0xFF;
      h *= 0x100000001b3ull;
    }
  };
  for (const auto& [a, b] : pairs) {
    mix(a);
    mix(b);
  }
  return h;
}

}  // namespace gaussmesh::stream
