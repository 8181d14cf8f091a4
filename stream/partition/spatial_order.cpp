// The in-core form of the spatial renumbering (spatial_order.h); the out-of-core form is
// PartitionRun::reorder (reorder.cpp), which reaches the same numbering in bounded memory.
#include "stream/partition/spatial_order.h"

#include <algorithm>

#include "stream/partition/cell_grid.h"

namespace gaussmesh::stream {

std::uint64_t reorder_spatially(std::vector<format::Vec3f>& positions, std::vector<format::Triangle>& faces, bool weld) {
  detail::FiniteBounds bounds;
  for (const format::Vec3f& p : positions) bounds.add(p);
  format::Vec3f lo, hi;
  bounds.get(lo, hi);
  const detail::Grid grid = detail::Grid::make(lo, hi);  // the partition's, from the ingest's bounds

  // Vertices: a counting sort by the Morton code of their cell, then each cell ordered.
  std::vector<std::uint32_t> start(grid.cells() + 1, 0), code(grid.cells());
  for (std::uint32_t c = 0; c < grid.cells(); ++c) code[c] = grid.morton(c);
  for (const format::Vec3f& p : positions) ++start[code[grid.cell(p)] + 1];
  for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  std::vector<OrderedVertex> order(positions.size());
  {
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (std::uint32_t v = 0; v < positions.size(); ++v) {
      const format::Vec3f& p = positions[v];
      order[next[code[grid.cell(p)]]++] = {VertexKey::of(grid.sub_code(p, kReorderFineBits), p, v), p};
    }
  }
  std::vector<std::uint32_t> renamed(positions.size());
  std::vector<format::Vec3f> moved;
  moved.reserve(positions.size());
  for (std::size_t c = 0; c + 1 < start.size(); ++c) {
    order_run(std::span<OrderedVertex>(order.data() + start[c], start[c + 1] - start[c]), weld,
              [&](const OrderedVertex& v, bool joined) {
                if (!joined) moved.push_back(v.p);
                renamed[v.key.id] = static_cast<std::uint32_t>(moved.size() - 1);
              });
  }
  const std::uint64_t welded = positions.size() - moved.size();
  positions.swap(moved);
  moved = {};
  order = {};

  // Faces: corners renamed, each turned to start at its lowest, a stable counting sort by that
  // corner, each group ordered.
  std::vector<std::uint64_t> first(positions.size() + 1, 0);
  for (format::Triangle& t : faces) {
    for (std::uint32_t& v : t.v)
      if (v < renamed.size()) v = renamed[v];
    t = lowest_first(t);
    ++first[std::min<std::size_t>(lowest_corner(t), positions.size() - 1) + 1];
  }
  for (std::size_t i = 1; i < first.size(); ++i) first[i] += first[i - 1];
  std::vector<format::Triangle> sorted(faces.size());
  for (const format::Triangle& t : faces) sorted[first[std::min<std::size_t>(lowest_corner(t), positions.size() - 1)]++] = t;
  for (std::size_t v = 0, begin = 0; v < positions.size(); ++v) {  // first[v]: the end of v's group now
    order_face_group(std::span<format::Triangle>(sorted.data() + begin, first[v] - begin));
    begin = first[v];
  }
  faces.swap(sorted);
  return welded;
}

}  // namespace gaussmesh::stream
