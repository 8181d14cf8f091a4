// Patch pieces per chunk and their stitch into patches. See chunk_pieces.h.
#include "stream/stitch/chunk_pieces.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "stream/core/canonical_order.h"
#include "stream/core/process_memory.h"
#include "stream/stitch/piece_joins.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kUnassigned = 0xFFFFFFFFu;

format::Status damaged(const std::string& what) {
  return format::Status::error(format::Code::kBadInput, "stitch", what);
}

}  // namespace

std::uint32_t face_owner(const Partition& partition, const ChunkMesh& chunk, std::uint32_t f) {
  if (chunk.owned_face[f]) return chunk.chunk;
  const auto& v = chunk.triangles[f].v;
  const std::uint32_t lowest = std::min({v[0], v[1], v[2]});
  if (lowest < chunk.vertex_owner.size()) return chunk.vertex_owner[lowest];
  return partition.owner_of(chunk.positions[lowest]);
}

void find_chunk_pieces(const Partition& partition, const ChunkMesh& chunk, const MeshAdjacency& adjacency,
                       const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                       ChunkPieces& out, std::vector<std::uint32_t>* piece_index,
                       const std::vector<std::uint32_t>* candidates) {
  const std::size_t nf = chunk.triangles.size();
  const std::uint32_t* nb = adjacency.edge_neighbor.data();
  // Pieces, numbered by their lowest face: one pass in face order joins each owned face to the
  // owned faces before it across its non-feature manifold edges (a union-find whose roots are
  // the lowest faces; feature bits and edge_neighbor are symmetric, so one side of an edge
  // suffices), then a second numbers the roots in face order. A depth-first fill from each seed
  // found the same pieces in the same order, but its neighbour loads jumped about the chunk.
  std::vector<std::uint32_t> piece_of(nf, kUnassigned), parent(nf, kUnassigned);
  const std::size_t first = out.pieces.size();
  auto id = [&](std::uint32_t index) { return PieceId{chunk.chunk} << 32 | index; };
  auto root = [&](std::uint32_t f) {
    while (parent[f] != f) {
      parent[f] = parent[parent[f]];
      f = parent[f];
    }
    return f;
  };
  // foreign: a vertex owned elsewhere, or one with a face owned elsewhere in its star (stars
  // leave collapsed faces out), marked from the faces' side in the same pass.
  std::vector<std::uint8_t> foreign(chunk.positions.size(), 0);
  for (std::uint32_t v = 0; v < foreign.size(); ++v) foreign[v] = !chunk.owned_vertex[v];
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f]) {
      const auto& t = chunk.triangles[f].v;
      if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) foreign[t[0]] = foreign[t[1]] = foreign[t[2]] = 1;
      continue;
    }
    parent[f] = f;
    for (int i = 0; i < 3; ++i) {
      if (feature[f] >> i & 1) continue;
      const std::uint32_t g = nb[3 * std::size_t{f} + i];
      if (g >= f || !chunk.owned_face[g]) continue;  // kNoFace is >= f too
      const std::uint32_t a = root(f), b = root(g);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<std::uint64_t> hash(chunk.positions.size());  // position_hash of every vertex
  for (std::size_t v = 0; v < hash.size(); ++v) hash[v] = position_hash(chunk.positions[v]);
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f]) continue;
    const std::uint32_t r = root(f);
    if (r == f) {
      PieceRecord piece;
      piece.piece = id(static_cast<std::uint32_t>(out.pieces.size() - first));
      piece.label = labels[f];
      piece.min_face = chunk.global_face[f];
      piece.min_key = ~std::uint64_t{0};
      piece_of[f] = static_cast<std::uint32_t>(out.pieces.size() - first);
      out.pieces.push_back(piece);
    } else {
      piece_of[f] = piece_of[r];
    }
    PieceRecord& piece = out.pieces[first + piece_of[f]];
    ++piece.faces;
    // The piece's first face by (key, global id): faces come in ascending global id.
    const auto& t = chunk.triangles[f].v;
    const std::uint64_t key = face_order_key(hash[t[0]], hash[t[1]], hash[t[2]]);
    if (key < piece.min_key) {
      piece.min_key = key;
      piece.min_face = chunk.global_face[f];
    }
  }
  // Candidates: owned vertices with >= 3 feature edges, counted as evaluate_vertex counts them.
  const std::uint32_t* corners = adjacency.vertex_corners.data();
  const std::uint8_t* flags = adjacency.slot_flags.data();
  std::vector<std::uint8_t> in_star(nf, 0);
  auto is_candidate = [&](std::uint32_t v) {
    // Entering break edges: one per open fan, at its last slot (mesh_adjacency.h), so counted
    // from the slot flags.
    std::uint32_t count = 0;
    for (std::uint32_t k = adjacency.star_begin(v); k < adjacency.star_end(v); ++k) {
      const std::uint32_t c = corners[k];
      count += feature[c / 3] >> (c % 3) & 1;
      count += (flags[k] & (MeshAdjacency::kFanStart | MeshAdjacency::kFanClosed)) == MeshAdjacency::kFanStart;
    }
    return count >= 3;
  };
  auto add_candidate = [&](std::uint32_t v) {
    const std::uint32_t sb = adjacency.star_begin(v), se = adjacency.star_end(v);
    out.candidates.push_back({chunk.global_vertex[v], static_cast<std::uint32_t>(out.star.size()), se - sb});
    for (std::uint32_t k = sb; k < se; ++k) {
      const std::uint32_t f = corners[k] / 3, i = corners[k] % 3;
      const std::uint32_t g = nb[3 * std::size_t{f} + i];
      StarEntry e;
      e.face = chunk.global_face[f];
      e.owner = face_owner(partition, chunk, f);
      if (g != MeshAdjacency::kNoFace) {
        e.next = chunk.global_face[g];
        e.next_owner = face_owner(partition, chunk, g);
      }
      e.entering_break = nb[3 * std::size_t{f} + (i + 2) % 3] == MeshAdjacency::kNoFace ? 1 : 0;
      out.star.push_back(e);
      in_star[f] = 1;
      if (g != MeshAdjacency::kNoFace) in_star[g] = 1;
    }
  };
  if (candidates) {
    for (const std::uint32_t v : *candidates)
      if (v < chunk.owned_vertex.size() && chunk.owned_vertex[v]) add_candidate(v);
  } else {
    for (std::uint32_t v = 0; v < chunk.owned_vertex.size(); ++v)
      if (chunk.owned_vertex[v] && is_candidate(v)) add_candidate(v);
  }
  // One pass over the owned faces: border edges (to faces owned elsewhere); one entry (lower
  // piece << 32 | higher piece) per feature edge between two owned faces, counted after a sort
  // (a map insertion per edge was a fifth of this function on noisy input); answers for other
  // chunks (owned faces with a foreign vertex) and for this chunk's own candidate stars; and the
  // collapsed faces.
  std::vector<std::uint64_t> shared;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!chunk.owned_face[f]) continue;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = nb[3 * std::size_t{f} + i];
      if (g == MeshAdjacency::kNoFace) continue;  // a break edge joins nothing
      const bool is_feature = feature[f] >> i & 1;
      if (!chunk.owned_face[g]) {
        out.border.push_back({chunk.global_face[f], chunk.global_face[g], id(piece_of[f]), is_feature});
      } else if (is_feature && f < g) {
        shared.push_back(std::uint64_t{std::min(piece_of[f], piece_of[g])} << 32 | std::max(piece_of[f], piece_of[g]));
      }
    }
    const auto& t = chunk.triangles[f];
    const bool shared_vertex = foreign[t.v[0]] || foreign[t.v[1]] || foreign[t.v[2]];
    if (shared_vertex || in_star[f]) out.border_faces.push_back({chunk.global_face[f], id(piece_of[f])});
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) {
      CollapsedFaceRecord r;
      r.piece = id(piece_of[f]);
      for (int i = 0; i < 3; ++i) r.vertices[i] = chunk.global_vertex[t.v[i]];
      out.collapsed.push_back(r);
    }
  }
  std::sort(shared.begin(), shared.end());
  for (std::size_t k = 0; k < shared.size();) {
    std::size_t end = k;
    while (end < shared.size() && shared[end] == shared[k]) ++end;
    out.adjacency.push_back({id(static_cast<std::uint32_t>(shared[k] >> 32)), id(static_cast<std::uint32_t>(shared[k])), end - k});
    k = end;
  }
  if (piece_index) piece_index->swap(piece_of);
}

std::int64_t StitchedPatches::piece_index(PieceId piece) const {
  const std::uint64_t chunk = piece >> 32, index = piece & 0xFFFFFFFFu;
  if (chunk + 1 >= chunk_first.size()) return -1;
  const std::uint64_t at = chunk_first[chunk] + index;
  return at < chunk_first[chunk + 1] ? static_cast<std::int64_t>(at) : -1;
}

std::int64_t StitchedPatches::patch_of_piece(PieceId piece) const {
  const std::int64_t k = piece_index(piece);
  return k < 0 ? -1 : std::int64_t{piece_patch[k]};
}

format::Status chunk_face_pieces(const Partition& partition, const ChunkMesh& chunk,
                                 const std::vector<std::uint32_t>& piece_index, const PieceJoinFiles& joins,
                                 std::vector<PieceId>& pieces) {
  const std::size_t nf = chunk.triangles.size();
  if (piece_index.size() != nf) return damaged("piece index of chunk " + std::to_string(chunk.chunk) + " has the wrong size");
  pieces.assign(nf, kNoPiece);
  std::vector<std::uint32_t> owners, local;
  std::vector<std::uint64_t> faces;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (chunk.owned_face[f]) {
      pieces[f] = PieceId{chunk.chunk} << 32 | piece_index[f];
    } else {
      owners.push_back(face_owner(partition, chunk, f));
      faces.push_back(chunk.global_face[f]);
      local.push_back(f);
    }
  }
  std::vector<PieceId> found(faces.size());
  GM_RETURN_IF_ERROR(joins.look_up(owners, faces, found));
  for (std::size_t k = 0; k < local.size(); ++k) pieces[local[k]] = found[k];
  return {};
}

format::Result<StitchedPatches> stitch_pieces(std::vector<ChunkPieces>& chunks, const PieceJoinFiles& joins,
                                              const MemoryBudget& budget, std::uint32_t threads) {
  // Pieces in one array, chunk after chunk, each chunk's in index order: a piece's dense index
  // is its chunk's first plus its index (no sort, no id table). The chunks' copies are freed.
  StitchedPatches out;
  struct Piece {
    std::uint64_t min_key, min_face;  // then, on a root: the patch's first face by (key, id)
    std::uint64_t faces;              // then, on a root: the patch's faces
    std::uint32_t label;
    auto first() const { return std::pair(min_key, min_face); }
  };
  std::vector<Piece> pieces;
  // Feature edges between pieces, (a, b, edges) with a < b; summed up now and then so that
  // what is held grows with the piece pairs, not the edges.
  struct Shared {
    std::uint32_t a, b;
    std::uint64_t edges;
  };
  std::vector<Shared> shared;
  std::size_t compacted = 0;
  auto compact = [&] {
    std::sort(shared.begin(), shared.end(), [](const Shared& x, const Shared& y) { return std::pair(x.a, x.b) < std::pair(y.a, y.b); });
    std::size_t w = 0;
    for (std::size_t k = 0; k < shared.size(); ++k) {
      if (w > 0 && shared[w - 1].a == shared[k].a && shared[w - 1].b == shared[k].b) {
        shared[w - 1].edges += shared[k].edges;
      } else {
        shared[w++] = shared[k];
      }
    }
    shared.resize(w);
    compacted = w;
  };
  // Unsummed entries beyond twice the summed ones: 1/64 of the budget (a fixed count would take a
  // large share of a small budget once doubled), at least 4,096.
  const std::size_t slack = std::max<std::uint64_t>(budget.fraction(1, 64) / sizeof(Shared), 4096);
  auto add_shared = [&](std::uint32_t a, std::uint32_t b, std::uint64_t edges) {
    make_room_for_one(shared, compacted, slack, compact);
    shared.push_back({std::min(a, b), std::max(a, b), edges});
  };
  // Pieces and their feature edges inside a chunk; what the sample pass spilled comes back from the
  // files, a chunk at a time. Adjacency records name pieces of their own chunk.
  std::vector<PieceAdjacencyRecord> spilled_adjacency;
  out.chunk_first.assign(chunks.size() + 1, 0);
  for (std::size_t k = 0; k < chunks.size(); ++k) {
    ChunkPieces& c = chunks[k];
    out.chunk_first[k] = static_cast<std::uint32_t>(pieces.size());
    spilled_adjacency.clear();
    if (c.pieces.empty()) GM_RETURN_IF_ERROR(joins.read_pieces(static_cast<std::uint32_t>(k), c.pieces, spilled_adjacency));
    if (c.pieces.empty()) {
      if (!c.adjacency.empty() || !spilled_adjacency.empty()) return damaged("an adjacency record names an unknown piece");
      continue;
    }
    if (pieces.size() + c.pieces.size() >= 0xFFFFFFFFu)
      return format::Status::error(format::Code::kResources, "stitch", "more than 2^32 - 1 patch pieces");
    const auto chunk = static_cast<std::uint32_t>(k);
    const std::size_t first = pieces.size();
    for (std::size_t i = 0; i < c.pieces.size(); ++i) {
      const PieceRecord& r = c.pieces[i];
      if (r.piece != (PieceId{chunk} << 32 | i)) return damaged("a chunk's piece ids are not its indices");
      pieces.push_back({r.min_key, r.min_face, r.faces, r.label});
    }
    for (const auto* list : {&c.adjacency, &spilled_adjacency}) {
      for (const PieceAdjacencyRecord& r : *list) {
        const std::uint64_t a = r.a & 0xFFFFFFFFu, b = r.b & 0xFFFFFFFFu;
        if (r.a >> 32 != chunk || r.b >> 32 != chunk || a >= c.pieces.size() || b >= c.pieces.size())
          return damaged("an adjacency record names an unknown piece");
        add_shared(static_cast<std::uint32_t>(first + a), static_cast<std::uint32_t>(first + b), r.edges);
      }
    }
    std::vector<PieceRecord>().swap(c.pieces);
    std::vector<PieceAdjacencyRecord>().swap(c.adjacency);
  }
  const std::size_t np = pieces.size();
  out.chunk_first[chunks.size()] = static_cast<std::uint32_t>(np);
  out.piece_patch.resize(np);  // sized now: piece_index() reads it
  auto dense = [&](PieceId id) { return out.piece_index(id); };
  std::vector<std::uint32_t> parent(np);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  // Border edges: both sides of every edge, joined on the unordered face pair a bucket at a
  // time.
  GM_RETURN_IF_ERROR(joins.join_border_edges(
      budget, [&](const BorderEdgeRecord& x, const BorderEdgeRecord& y) -> format::Status {
        const std::int64_t a = dense(x.piece), b = dense(y.piece);
        if (a < 0 || b < 0) return damaged("a border edge names an unknown piece");
        if (x.feature) {
          add_shared(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), 1);
        } else {
          if (pieces[a].label != pieces[b].label) return damaged("two pieces of different labels are joined");
          const std::uint32_t ra = find(static_cast<std::uint32_t>(a)), rb = find(static_cast<std::uint32_t>(b));
          if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
        }
        return format::Status();
      },
      threads));
  release_free_memory();  // the buckets the join read and sorted
  // Patches, numbered by their first face by (key, id), as find_patches numbers them: each root
  // gathers its pieces' first face and size.
  for (std::uint32_t i = 0; i < np; ++i) {
    const std::uint32_t r = find(i);
    if (r == i) continue;
    if (pieces[i].first() < pieces[r].first()) {
      pieces[r].min_key = pieces[i].min_key;
      pieces[r].min_face = pieces[i].min_face;
    }
    pieces[r].faces += pieces[i].faces;
  }
  std::vector<std::uint32_t> roots;
  for (std::uint32_t i = 0; i < np; ++i)
    if (parent[i] == i) roots.push_back(i);
  std::sort(roots.begin(), roots.end(), [&](std::uint32_t a, std::uint32_t b) { return pieces[a].first() < pieces[b].first(); });
  out.patches.reserve(roots.size());
  for (std::size_t k = 0; k < roots.size(); ++k) {
    const Piece& r = pieces[roots[k]];
    out.patches.push_back({r.min_key, r.min_face, r.faces, r.label});
    out.piece_patch[roots[k]] = static_cast<std::uint32_t>(k);
  }
  std::vector<std::uint32_t>().swap(roots);
  std::vector<Piece>().swap(pieces);
  for (std::uint32_t i = 0; i < np; ++i) out.piece_patch[i] = out.piece_patch[find(i)];  // roots are lower: done first
  std::vector<std::uint32_t>().swap(parent);
  // Piece pairs to patch pairs.
  for (Shared& x : shared) {
    const std::uint32_t p = out.piece_patch[x.a], q = out.piece_patch[x.b];
    if (p == q) return damaged("a feature edge inside one patch");
    x = {std::min(p, q), std::max(p, q), x.edges};
  }
  compact();
  out.adjacency.reserve(shared.size());
  for (const Shared& x : shared) out.adjacency.push_back({x.a, x.b, x.edges});
  std::vector<Shared>().swap(shared);
  // Candidates' stars in patches: each face's piece from its owner's answers, for a group of
  // chunks at a time (each answer file read once per group, the group's requests in memory),
  // then the chunks' stars are dropped.
  const std::size_t group_entries = std::max<std::uint64_t>(bucket_bytes(budget) / 64, 1024);  // ~60 B an entry
  std::vector<std::uint32_t> owners;
  std::vector<std::uint64_t> faces;
  std::vector<PieceId> found;
  auto patch_of = [&](PieceId piece) { return piece == kNoPiece ? -1 : out.patch_of_piece(piece); };
  // A chunk's candidates and their star entries: in memory, or (spilled by the sample pass) from its
  // candidate and star files.
  auto spilled = [&](std::size_t c) { return chunks[c].candidates.empty() && chunks[c].star.empty(); };
  auto entries_of = [&](std::size_t c) {
    if (spilled(c)) return joins.star_entries(static_cast<std::uint32_t>(c));
    std::uint64_t n = 0;
    for (const CandidateRecord& r : chunks[c].candidates) n += r.count;
    return n;
  };
  std::size_t total_candidates = 0, total_entries = 0;
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    total_candidates += spilled(c) ? joins.candidate_entries(static_cast<std::uint32_t>(c)) : chunks[c].candidates.size();
    total_entries += entries_of(c);
  }
  out.candidates.reserve(total_candidates);
  out.star.reserve(total_entries);
  out.entering_break.reserve(total_entries);
  for (std::size_t first = 0; first < chunks.size();) {
    std::size_t last = first, entries = 0;
    while (last < chunks.size() && (last == first || entries + entries_of(last) <= group_entries)) entries += entries_of(last++);
    owners.clear();
    faces.clear();
    for (std::size_t c = first; c < last; ++c) {
      if (spilled(c)) {
        const std::uint32_t id = static_cast<std::uint32_t>(c);
        GM_RETURN_IF_ERROR(joins.read_candidates(id, chunks[c].candidates));
        GM_RETURN_IF_ERROR(joins.read_stars(id, chunks[c].star));
      }
      for (const CandidateRecord& r : chunks[c].candidates) {
        if (std::size_t{r.first} + r.count > chunks[c].star.size()) return damaged("a candidate's star is out of range");
        for (std::uint32_t k = r.first; k < r.first + r.count; ++k) {
          const StarEntry& e = chunks[c].star[k];
          owners.push_back(e.owner);
          faces.push_back(e.face);
          if (e.next == kNoFaceId) continue;
          owners.push_back(e.next_owner);
          faces.push_back(e.next);
        }
      }
    }
    found.resize(faces.size());
    GM_RETURN_IF_ERROR(joins.look_up(owners, faces, found));
    std::size_t at = 0;
    for (std::size_t c = first; c < last; ++c) {
      for (const CandidateRecord& r : chunks[c].candidates) {
        out.candidates.push_back({r.vertex, static_cast<std::uint32_t>(out.star.size()), r.count});
        for (std::uint32_t k = r.first; k < r.first + r.count; ++k) {
          const StarEntry& e = chunks[c].star[k];
          StitchedPatches::Star s;
          const std::int64_t p = patch_of(found[at++]);
          const std::int64_t q = e.next == kNoFaceId ? 0 : patch_of(found[at++]);
          if (p < 0 || q < 0) return damaged("no piece for a face in the star of vertex " + std::to_string(r.vertex));
          s.patch = static_cast<std::uint32_t>(p);
          if (e.next != kNoFaceId) s.next_patch = static_cast<std::uint32_t>(q);
          out.star.push_back(s);
          out.entering_break.push_back(e.entering_break);
        }
      }
      std::vector<StarEntry>().swap(chunks[c].star);  // "= {}" would keep the capacity
      std::vector<CandidateRecord>().swap(chunks[c].candidates);
    }
    first = last;
  }
  for (const ChunkPieces& c : chunks) {
    for (const CollapsedFaceRecord& r : c.collapsed) {
      const std::int64_t d = dense(r.piece);
      if (d < 0) return damaged("a collapsed face names an unknown piece");
      StitchedPatches::Collapsed col;
      col.patch = out.piece_patch[d];
      col.vertices.assign(std::begin(r.vertices), std::end(r.vertices));
      std::sort(col.vertices.begin(), col.vertices.end());
      col.vertices.erase(std::unique(col.vertices.begin(), col.vertices.end()), col.vertices.end());
      out.collapsed.push_back(std::move(col));
    }
  }
  std::sort(out.candidates.begin(), out.candidates.end(),
            [](const auto& a, const auto& b) { return a.vertex < b.vertex; });
  return out;
}

PatchGraphInput take_merge_input(StitchedPatches& stitched, CandidateEdges& edges) {
  PatchGraphInput input;
  input.patch_label.reserve(stitched.patches.size());
  input.patch_size.reserve(stitched.patches.size());
  for (const StitchedPatch& p : stitched.patches) {
    input.patch_label.push_back(p.label);
    input.patch_size.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(p.faces, 0xFFFFFFFFu)));
  }
  std::vector<StitchedPatch>().swap(stitched.patches);
  {
    std::vector<PatchPair> pairs;
    pairs.reserve(stitched.adjacency.size());
    for (const auto& a : stitched.adjacency)
      pairs.push_back({a.p, a.q, static_cast<std::uint32_t>(std::min<std::uint64_t>(a.edges, 0xFFFFFFFFu))});
    std::vector<StitchedPatches::Adjacent>().swap(stitched.adjacency);
    patch_neighbors_from_pairs(pairs, input);
  }
  // Each candidate counts for the distinct patches of its star and of the collapsed faces
  // holding it.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> collapsed;  // (vertex, patch)
  for (const auto& c : stitched.collapsed)
    for (std::uint32_t v : c.vertices) collapsed.emplace_back(v, c.patch);
  std::vector<StitchedPatches::Collapsed>().swap(stitched.collapsed);
  std::sort(collapsed.begin(), collapsed.end());
  // Sized once by their bounds (a candidate's patches are its star's and its collapsed faces'),
  // not by doubling: the bounds are close to the sizes.
  input.candidate_patches.reserve(stitched.star.size() + collapsed.size());
  input.candidate_offsets.reserve(stitched.candidates.size() + 1);
  input.candidate_offsets.push_back(0);
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;  // no face across
  edges = CandidateEdges();
  edges.first.reserve(stitched.candidates.size() + 1);
  edges.first.push_back(0);
  edges.fixed.reserve(stitched.candidates.size());
  edges.narrow.reserve(stitched.star.size());
  std::vector<std::uint32_t> list;
  std::vector<std::array<std::uint8_t, 2>> narrow;
  for (const auto& c : stitched.candidates) {
    list.clear();
    for (std::uint32_t k = c.first; k < c.first + c.count; ++k) list.push_back(stitched.star[k].patch);
    for (auto it = std::lower_bound(collapsed.begin(), collapsed.end(), std::pair(c.vertex, 0u));
         it != collapsed.end() && it->first == c.vertex; ++it)
      list.push_back(it->second);
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    input.candidate_patches.insert(input.candidate_patches.end(), list.begin(), list.end());
    input.candidate_offsets.push_back(static_cast<std::uint32_t>(input.candidate_patches.size()));
    // Its edges: a byte per patch while the list is short and holds both patches (a face across
    // an edge at the vertex is in its star, but the records come from disk).
    std::uint32_t fixed = 0;
    bool wide = list.size() > 256;
    narrow.clear();
    for (std::uint32_t k = c.first; k < c.first + c.count; ++k) {
      const auto& e = stitched.star[k];
      fixed += stitched.entering_break[k] + (e.next_patch == kNone);
      if (e.next_patch == kNone || e.next_patch == e.patch || wide) continue;
      const auto a = std::lower_bound(list.begin(), list.end(), e.patch);
      const auto b = std::lower_bound(list.begin(), list.end(), e.next_patch);
      if (a == list.end() || *a != e.patch || b == list.end() || *b != e.next_patch) {
        wide = true;
        continue;
      }
      narrow.push_back({static_cast<std::uint8_t>(a - list.begin()), static_cast<std::uint8_t>(b - list.begin())});
    }
    const auto k = static_cast<std::uint32_t>(edges.fixed.size());
    edges.fixed.push_back(static_cast<std::uint8_t>(std::min<std::uint32_t>(fixed, 3) | (wide ? CandidateEdges::kWide : 0)));
    if (wide) {
      const auto begin = static_cast<std::uint32_t>(edges.wide.size());
      for (std::uint32_t j = c.first; j < c.first + c.count; ++j) {
        const auto& e = stitched.star[j];
        if (e.next_patch != kNone && e.next_patch != e.patch) edges.wide.emplace_back(e.patch, e.next_patch);
      }
      edges.wide_candidates.push_back({k, begin, static_cast<std::uint32_t>(edges.wide.size())});
    } else {
      edges.narrow.insert(edges.narrow.end(), narrow.begin(), narrow.end());
    }
    edges.first.push_back(static_cast<std::uint32_t>(edges.narrow.size()));
  }
  return input;
}

PatchMergeResult merge_stitched_patches(const CandidateEdges& edges, PatchGraphInput input) {
  // Exact test: a candidate's record after a merge differs only in its candidacy, recounted
  // from its star's edges with the current labels (evaluate_vertex's count).
  auto reevaluate = [&](PatchMergeGraph& graph, std::span<const std::uint32_t> touched,
                        std::vector<std::uint8_t>& still) {
    for (std::size_t t = 0; t < touched.size(); ++t) {
      const std::uint32_t* patches = input.candidate_patches.data() + input.candidate_offsets[touched[t]];
      still[t] = edges.keeps_candidacy(touched[t], patches, [&](std::uint32_t p) { return graph.label(p); });
    }
  };
  PatchMergeGraph graph;
  PatchMergeResult result;
  graph.reset_taking_neighbors(input);
  // The graph copied the labels and chained the neighbour lists: neither is read again.
  std::vector<std::uint32_t>().swap(input.patch_label);
  std::vector<std::uint32_t>().swap(input.neighbor_offsets);
  graph.merge(reevaluate);
  graph.finish(result);
  return result;
}

}  // namespace gaussmesh::stream
