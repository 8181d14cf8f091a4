// Triangulation of one planar polygon with holes, for the per-patch mesher (paper §5: "each
// patch polygon is triangulated in the plane of its Gaussian triangle"): projection onto the
// plane, exact 2D orientation predicates, holes joined by verified bridges, best-shape ear
// clipping on the resulting weakly simple polygon, then Delaunay edge flips. The result is a
// pure function of the inputs (no hash or pointer order), so the same patch is triangulated
// identically in core and out of core.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "format/status.h"

namespace gaussmesh::stream {

using PolygonPoint3 = std::array<double, 3>;
using PolygonPoint2 = std::array<double, 2>;
using PolygonTriangle = std::array<std::uint32_t, 3>;

// forbidden(u, v), called with u < v (point indices): true when {u, v} must not become a new
// edge (a diagonal or a hole bridge). Polygon boundary edges are never asked about. An empty
// function forbids nothing.
using ForbiddenEdge = std::function<bool(std::uint32_t, std::uint32_t)>;

// An open-addressing hash table from 64-bit edge keys (two 32-bit ids, as the triangulator and
// the per-patch mesher make them) to a 32-bit value: linear probing, backward-shift erase, one
// flat array, no allocation per key. For lookups only: it has no iteration, so no hash order can
// reach an output. The all-ones key (an edge from id 0xFFFFFFFF to itself) marks free slots and
// cannot be stored.
class EdgeKeyMap {
 public:
  static constexpr std::uint64_t kFree = ~std::uint64_t{0};

  // Empties the table and sizes it for about `expected` keys (it still grows past that). Keeps
  // the allocation unless it is far too small or far too large.
  void reset(std::size_t expected = 0) {
    std::size_t want = 16;
    while (want < 2 * expected) want *= 2;
    if (slots_.size() < want || slots_.size() > 8 * want) {
      slots_.assign(want, Slot{kFree, 0});
    } else {
      for (Slot& s : slots_) s.key = kFree;
    }
    shift_ = shift_for(slots_.size());
    size_ = 0;
  }
  std::size_t size() const { return size_; }
  bool contains(std::uint64_t key) const { return find(key) != nullptr; }
  // The value stored for key, or nullptr.
  const std::uint32_t* find(std::uint64_t key) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = home(key);; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i].key == key) return &slots_[i].value;
      if (slots_[i].key == kFree) return nullptr;
    }
  }
  // The value for key, inserted as `initial` when absent; `inserted` says which.
  std::uint32_t& emplace(std::uint64_t key, std::uint32_t initial, bool* inserted = nullptr) {
    assert(key != kFree);
    if (slots_.empty() || 2 * (size_ + 1) > slots_.size()) grow();
    std::size_t i = home(key);
    for (; slots_[i].key != kFree; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i].key == key) {
        if (inserted) *inserted = false;
        return slots_[i].value;
      }
    }
    slots_[i] = {key, initial};
    ++size_;
    if (inserted) *inserted = true;
    return slots_[i].value;
  }
  // Adds key (value 0 if new); true when it was not there.
  bool insert(std::uint64_t key) {
    bool inserted = false;
    emplace(key, 0, &inserted);
    return inserted;
  }
  // Removes key; true when it was there.
  bool erase(std::uint64_t key) {
    if (slots_.empty()) return false;
    const std::size_t mask = slots_.size() - 1;
    std::size_t i = home(key);
    for (; slots_[i].key != key; i = (i + 1) & mask)
      if (slots_[i].key == kFree) return false;
    // Backward shift: pull later keys of the probe run into the hole when their home allows.
    for (std::size_t j = (i + 1) & mask; slots_[j].key != kFree; j = (j + 1) & mask) {
      const std::size_t h = home(slots_[j].key);
      if (((j - h) & mask) >= ((j - i) & mask)) {
        slots_[i] = slots_[j];
        i = j;
      }
    }
    slots_[i].key = kFree;
    --size_;
    return true;
  }

 private:
  struct Slot {
    std::uint64_t key;
    std::uint32_t value;
  };
  static int shift_for(std::size_t capacity) {
    int bits = 0;
    while ((std::size_t{1} << bits) < capacity) ++bits;
    return 64 - bits;
  }
  std::size_t home(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  void grow() {
    std::vector<Slot> old = std::move(slots_);
    slots_.assign(old.empty() ? 16 : 2 * old.size(), Slot{kFree, 0});
    shift_ = shift_for(slots_.size());
    size_ = 0;
    for (const Slot& s : old)
      if (s.key != kFree) emplace(s.key, s.value);
  }

  std::vector<Slot> slots_;
  int shift_ = 64;
  std::size_t size_ = 0;
};

// Exact sign (-1, 0, +1) of the 2D orientation of (a, b, c): +1 when c lies to the left of the
// directed line a -> b (counter-clockwise turn). Exact for all finite doubles (CGAL's filtered
// predicate, LGPL kernel).
int orientation_2d(const PolygonPoint2& a, const PolygonPoint2& b, const PolygonPoint2& c);

// The plane coordinates triangulate_polygon works in: (p - origin) expressed in an orthonormal
// frame (u, v) with u x v = normal / |normal|, so counter-clockwise in 2D is counter-clockwise
// seen from the tip of `normal`. The frame is a fixed function of `normal` alone.
// Precondition: normal is finite and non-zero (asserted).
std::vector<PolygonPoint2> project_to_plane(std::span<const PolygonPoint3> points,
                                            const PolygonPoint3& normal, const PolygonPoint3& origin);
// The same into `out` (resized to points.size()), for callers that reuse one buffer.
void project_to_plane(std::span<const PolygonPoint3> points, const PolygonPoint3& normal,
                      const PolygonPoint3& origin, std::vector<PolygonPoint2>& out);

// Triangulates the polygon whose boundary loops index into `points`.
//
// loops[0] is the outer boundary, loops[1..] are holes; each loop is a cyclic list of point
// indices without a repeated closing index. Loop orientation is not trusted: the outer loop is
// made counter-clockwise and holes clockwise as seen from `normal` (pointing at the viewer).
// A loop may pass through one point twice (touching itself), and a hole may touch the outer
// loop or another hole at a vertex; collinear consecutive vertices are kept as real vertices.
// Points are projected with project_to_plane(points, normal, points[loops[0][0]]); every
// combinatorial decision is an exact predicate on those projected doubles.
//
// Returns triangles as indices into `points`, each strictly counter-clockwise (exactly, in the
// projected coordinates), using only loop vertices (no Steiner points). For n loop vertices
// (a repeated point counted each time it appears) and h holes there are exactly n + 2h - 2
// triangles when no loops touch; every hole that shares a vertex with another loop, and every
// loop pinch that splits the polygon, has 2 fewer. Every loop edge is in exactly one triangle,
// every new edge in exactly two; no new edge is forbidden or duplicates an existing one.
//
// Errors (code kProcessing, where "polygon triangulation"): bad arguments (no loop, a loop
// with fewer than 3 vertices, an index out of range, non-finite coordinates or normal), a
// zero-length edge, loops that cross or overlap in the projection, a hole that cannot be
// joined (outside the outer loop, or every bridge forbidden), or no valid ear left (degenerate
// remainder, or every remaining ear would need a forbidden or duplicate edge). The caller is
// expected to have a fallback. Work is bounded: O(n^2) time worst case, O(n) memory.
format::Result<std::vector<PolygonTriangle>> triangulate_polygon(
    std::span<const PolygonPoint3> points, std::span<const std::vector<std::uint32_t>> loops,
    const PolygonPoint3& normal, const ForbiddenEdge& forbidden = {});

// The same on points already in the plane (counter-clockwise = positive orientation_2d).
format::Result<std::vector<PolygonTriangle>> triangulate_polygon_2d(
    std::span<const PolygonPoint2> points, std::span<const std::vector<std::uint32_t>> loops,
    const ForbiddenEdge& forbidden = {});

// Scratch buffers for triangulating many polygons one after the other (one workspace per
// thread): once they have grown, a small polygon costs no allocation. Holds no result.
class PolygonWorkspace {
 public:
  PolygonWorkspace();
  ~PolygonWorkspace();
  PolygonWorkspace(const PolygonWorkspace&) = delete;
  PolygonWorkspace& operator=(const PolygonWorkspace&) = delete;
  struct Buffers;  // defined in polygon_triangulation.cpp
  Buffers& buffers() { return *buffers_; }

 private:
  std::unique_ptr<Buffers> buffers_;
};

// triangulate_polygon_2d with a workspace: the triangles (the same, in the same order) replace
// the contents of `triangles`; on an error `triangles` holds no meaningful result.
format::Status triangulate_polygon_2d(std::span<const PolygonPoint2> points,
                                      std::span<const std::vector<std::uint32_t>> loops,
                                      const ForbiddenEdge& forbidden, PolygonWorkspace& workspace,
                                      std::vector<PolygonTriangle>& triangles);

}  // namespace gaussmesh::stream
