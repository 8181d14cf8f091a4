// Compact mesh adjacency for the sampler (paper §4): vertex stars by counting sort, then one
// pass over the vertices that matches the directed edges of each star locally (the faces
// holding v -> a and a -> v are all in v's star) and walks the fans, in parallel over vertex
// ranges (every vertex writes only its own star slots and the edge slots of its own corners).
#include "stream/core/mesh_adjacency.h"

#include <algorithm>
#include <atomic>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;
using format::Triangle;

bool is_collapsed(const Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }

// Per-thread scratch for one star: the corners' other two vertices. Arrays only grow (sized
// by fit()), and are used through raw pointers: no per-star size bookkeeping, so every array
// has the same size, the one fit() checks.
struct StarScratch {
  std::vector<std::uint32_t> corner, next, prev, partner, next_slot;
  std::vector<std::uint8_t> used;
  std::vector<std::uint32_t> by_next, by_prev;  // slot indices sorted by next / prev (large stars)
  void fit(std::uint32_t degree) {
    if (corner.size() >= degree) return;
    const std::uint32_t size = std::max<std::uint32_t>(degree, 8);
    for (auto* v : {&corner, &next, &prev, &partner, &next_slot}) v->resize(size);
    used.resize(size);
  }
};

// partner[r]: the one slot whose prev is next[r], when exactly one slot has next == next[r]
// and exactly one has prev == next[r]; else kNoFace. Quadratic: for stars of up to 24 slots.
void partner_by_counts(const std::uint32_t* next, const std::uint32_t* prev, std::uint32_t degree, std::uint32_t* partner) {
  for (std::uint32_t r = 0; r < degree; ++r) {
    const std::uint32_t a = next[r];
    std::uint32_t out = 0, in = 0, in_slot = MeshAdjacency::kNoFace;
    for (std::uint32_t d = 0; d < degree; ++d) {
      out += next[d] == a;
      if (prev[d] == a) {
        ++in;
        in_slot = d;
      }
    }
    partner[r] = out == 1 && in == 1 ? in_slot : MeshAdjacency::kNoFace;
  }
}

#if defined(__SSE2__)
// The same for a star of at most 8 slots (almost every star), branch-free: each slot's two
// counts come from four compares of eight lanes. SSE2 is x86-64's baseline; elsewhere
// partner_by_counts runs. The lanes past the star repeat slot 0's ids, masked out of both counts.
// The lanes come in registers, not from the arrays the star's gather has just written slot by
// slot: a 16-byte load there would wait for those 4-byte stores to reach the cache (no store
// forwarding across them).
void partner_small(const std::uint32_t* next, __m128i n_lo, __m128i n_hi, __m128i p_lo, __m128i p_hi, std::uint32_t degree,
                   std::uint32_t* partner) {
  constexpr std::uint32_t kNone = MeshAdjacency::kNoFace;
  const unsigned valid = (1u << degree) - 1;
  auto lanes = [](__m128i lo, __m128i hi, __m128i key) {
    return static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(lo, key)))) |
           static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(hi, key)))) << 4;
  };
  for (std::uint32_t r = 0; r < degree; ++r) {
    const __m128i key = _mm_set1_epi32(static_cast<int>(next[r]));
    const unsigned out = lanes(n_lo, n_hi, key) & valid, in = lanes(p_lo, p_hi, key) & valid;
    // out holds lane r at least; each count is one iff its mask is a single bit.
    const bool one = (out & (out - 1)) == 0 && in != 0 && (in & (in - 1)) == 0;
    partner[r] = one ? static_cast<std::uint32_t>(__builtin_ctz(in)) : kNone;
  }
}
#endif

// Matches the star of one vertex and writes its fans. Returns its directed break edges.
// Slot r holds corner c = 3 f + i with next vertex a = next[r] and previous vertex prev[r].
// Outgoing edge (v, a) is manifold iff exactly one slot has next == a and exactly one has
// prev == a; the face across it is that second slot's face. The incoming edge (prev, v) of
// slot r is manifold iff exactly one slot has prev == prev[r] and one has next == prev[r]:
// the fan continues counter-clockwise into that slot.
std::size_t build_star(const Triangle* tris, std::uint32_t begin, std::uint32_t end, std::uint32_t* corners,
                       std::uint8_t* slot_flags, std::uint32_t* edge_neighbor, StarScratch& s) {
  const std::uint32_t degree = end - begin;
  constexpr std::uint32_t kNone = MeshAdjacency::kNoFace;
  s.fit(degree);
  std::uint32_t* corner = s.corner.data();
  std::uint32_t* next = s.next.data();
  std::uint32_t* prev = s.prev.data();
  std::uint32_t* partner = s.partner.data();
  std::uint32_t* next_slot = s.next_slot.data();
  // The vertices after and before corner c in its face.
  auto around = [tris](std::uint32_t c, std::uint32_t& after, std::uint32_t& before) {
    const Triangle& t = tris[c / 3];
    const std::uint32_t i = c % 3;
    after = t.v[i == 2 ? 0 : i + 1];
    before = t.v[i == 0 ? 2 : i - 1];
  };
  auto gather = [&](std::uint32_t r) {
    corner[r] = corners[begin + r];
    around(corner[r], next[r], prev[r]);
  };
  // For each slot: the slot across its outgoing edge (partner) and the slot that continues the
  // fan across its incoming edge (next_slot), kNone when that edge is a break. next_slot is
  // partner's inverse: the incoming edge (p, v) of slot r is manifold iff exactly one slot has
  // prev == p and exactly one d has next == p, and then partner[d] == r — the same two counts.
  std::size_t breaks = 0;
#if defined(__SSE2__)
  if (degree <= 8) {
    // Eight slots gathered into registers (those past the star repeat slot 0: their lanes are
    // masked), the lanes built from them and stored whole into the scratch arrays (which hold at
    // least 8 entries: StarScratch::fit).
    std::uint32_t c8[8], n8[8], p8[8];
#pragma GCC unroll 8
    for (std::uint32_t r = 0; r < 8; ++r) {
      c8[r] = corners[begin + (r < degree ? r : 0)];
      around(c8[r], n8[r], p8[r]);
    }
    struct Lanes {
      __m128i lo, hi;
    };
    const auto lanes = [](const std::uint32_t (&v)[8], std::uint32_t* out) {
      const Lanes l{_mm_setr_epi32(static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3])),
                    _mm_setr_epi32(static_cast<int>(v[4]), static_cast<int>(v[5]), static_cast<int>(v[6]), static_cast<int>(v[7]))};
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out), l.lo);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 4), l.hi);
      return l;
    };
    lanes(c8, corner);
    const Lanes n = lanes(n8, next), p = lanes(p8, prev);
    partner_small(next, n.lo, n.hi, p.lo, p.hi, degree, partner);
  } else
#endif
  if (degree <= 24) {
    for (std::uint32_t r = 0; r < degree; ++r) gather(r);
    partner_by_counts(next, prev, degree, partner);
  } else {
    for (std::uint32_t r = 0; r < degree; ++r) gather(r);
    // Large stars (fan apexes): sorted slot lists instead of the quadratic scan.
    s.by_next.resize(degree);
    s.by_prev.resize(degree);
    for (std::uint32_t r = 0; r < degree; ++r) s.by_next[r] = s.by_prev[r] = r;
    std::sort(s.by_next.begin(), s.by_next.end(), [&](std::uint32_t x, std::uint32_t y) { return next[x] < next[y]; });
    std::sort(s.by_prev.begin(), s.by_prev.end(), [&](std::uint32_t x, std::uint32_t y) { return prev[x] < prev[y]; });
    auto count_slots = [&](const std::vector<std::uint32_t>& sorted, const std::uint32_t* key, std::uint32_t a,
                           std::uint32_t& one) {
      auto lo = std::lower_bound(sorted.begin(), sorted.end(), a, [&](std::uint32_t slot, std::uint32_t k) { return key[slot] < k; });
      auto hi = std::upper_bound(lo, sorted.end(), a, [&](std::uint32_t k, std::uint32_t slot) { return k < key[slot]; });
      if (hi - lo == 1) one = *lo;
      return static_cast<std::uint32_t>(hi - lo);
    };
    for (std::uint32_t r = 0; r < degree; ++r) {
      std::uint32_t in_slot = kNone, ignore = kNone;
      const std::uint32_t out = count_slots(s.by_next, next, next[r], ignore);
      const std::uint32_t in = count_slots(s.by_prev, prev, next[r], in_slot);
      partner[r] = out == 1 && in == 1 ? in_slot : kNone;
    }
  }
  for (std::uint32_t r = 0; r < degree; ++r) next_slot[r] = kNone;
  for (std::uint32_t r = 0; r < degree; ++r) {
    const std::uint32_t d = partner[r];
    breaks += d == kNone;
    if (d != kNone) next_slot[d] = r;
    edge_neighbor[corner[r]] = d == kNone ? kNone : corner[d] / 3;
  }
  // The common star, one closed fan: the cycle from slot 0 takes every slot (partner is then a
  // permutation, so next_slot is too). The general walk below gives the same slots and flags.
  if (breaks == 0) {
    std::uint32_t r = 0, n = 0;
    do {
      slot_flags[begin + n] = 0;  // cleared here: a separate fill would be a memset call per star
      corners[begin + n++] = corner[r];
      r = next_slot[r];
    } while (r != 0 && n < degree);
    if (n == degree) {
      slot_flags[begin] = MeshAdjacency::kFanStart | MeshAdjacency::kFanClosed;
      return 0;
    }
  }

  // Fans: walk counter-clockwise from each open end (a slot whose outgoing edge is a break),
  // then the remaining cycles, each from its lowest slot. Written straight into the star.
  std::uint8_t* used = s.used.data();
  std::fill(used, used + degree, std::uint8_t{0});
  std::uint32_t written = begin;
  auto walk = [&](std::uint32_t r, bool closed) {
    std::uint8_t flag = static_cast<std::uint8_t>(MeshAdjacency::kFanStart | (closed ? MeshAdjacency::kFanClosed : 0));
    const std::uint32_t start = r;
    while (true) {
      used[r] = 1;
      slot_flags[written] = flag;
      corners[written++] = corner[r];
      flag = 0;
      const std::uint32_t nr = next_slot[r];
      if (nr == kNone || nr == start || used[nr]) break;
      r = nr;
    }
  };
  for (std::uint32_t r = 0; r < degree; ++r)
    if (partner[r] == kNone) walk(r, false);
  for (std::uint32_t r = 0; r < degree; ++r)
    if (!used[r]) walk(r, true);
  return breaks;
}

}  // namespace

format::Status build_mesh_adjacency(format::MeshView mesh, MeshAdjacency& adj) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  if (3 * nf >= MeshAdjacency::kNoFace || nv >= MeshAdjacency::kNoFace) {
    return Status::error(Code::kResources, "adjacency", "mesh too large for 32-bit corner ids");
  }
  adj.collapsed_faces = 0;
  adj.break_edges = 0;
  adj.vertex_offsets.assign(nv + 1, 0);
  const Triangle* tris = mesh.triangles.data();
  std::uint32_t* count = adj.vertex_offsets.data() + 1;
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = tris[f];
    if (t.v[0] >= nv || t.v[1] >= nv || t.v[2] >= nv) {
      const int i = t.v[0] >= nv ? 0 : (t.v[1] >= nv ? 1 : 2);
      return Status::error(Code::kBadInput, "face " + std::to_string(f),
                           "vertex index " + std::to_string(t.v[i]) + " out of range (" +
                               std::to_string(nv) + " vertices)");
    }
    if (is_collapsed(t)) {
      ++adj.collapsed_faces;
      continue;
    }
    ++count[t.v[0]];
    ++count[t.v[1]];
    ++count[t.v[2]];
  }
  for (std::size_t v = 0; v < nv; ++v) adj.vertex_offsets[v + 1] += adj.vertex_offsets[v];
  const std::size_t slots = adj.vertex_offsets[nv];
  adj.vertex_corners.resize(slots);
  adj.slot_flags.resize(slots);
  {
    // Fill cursors: vertex_offsets shifted by one, restored by the fill itself.
    std::uint32_t* cursor = adj.vertex_offsets.data();
    std::uint32_t* corners = adj.vertex_corners.data();
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = tris[f];
      if (is_collapsed(t)) continue;
      const std::uint32_t c = static_cast<std::uint32_t>(3 * f);
      corners[cursor[t.v[0]]++] = c;
      corners[cursor[t.v[1]]++] = c + 1;
      corners[cursor[t.v[2]]++] = c + 2;
    }
    // Now cursor[v] == old offset[v + 1]: shift back.
    for (std::size_t v = nv; v > 0; --v) adj.vertex_offsets[v] = adj.vertex_offsets[v - 1];
    adj.vertex_offsets[0] = 0;
  }
  // Every corner of a non-collapsed face is written by its vertex's pass; collapsed faces
  // keep kNoFace on all three edges.
  adj.edge_neighbor.resize(3 * nf);
  if (adj.collapsed_faces > 0) std::fill(adj.edge_neighbor.begin(), adj.edge_neighbor.end(), MeshAdjacency::kNoFace);

  std::atomic<std::size_t> breaks{0};
  const std::uint32_t* offsets = adj.vertex_offsets.data();
  std::uint32_t* corners = adj.vertex_corners.data();
  std::uint8_t* flags = adj.slot_flags.data();
  std::uint32_t* neighbor = adj.edge_neighbor.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
    StarScratch s;
    std::size_t local = 0;
    for (std::size_t v = range.begin(); v < range.end(); ++v) {
      if (offsets[v] == offsets[v + 1]) continue;
      local += build_star(tris, offsets[v], offsets[v + 1], corners, flags, neighbor, s);
    }
    breaks += local;
  });
  adj.break_edges = breaks;
  return Status();
}

format::Result<MeshAdjacency> build_mesh_adjacency(format::MeshView mesh) {
  MeshAdjacency adj;
  if (Status s = build_mesh_adjacency(mesh, adj); !s.is_ok()) return s;
  return adj;
}

}  // namespace gaussmesh::stream
