// The loop stitch, the stitch's last step before the mesher (docs/stitch.md): every
// chunk's runs (stream/stitch/loop_chunks.h) joined into patch loops by half-edge ids alone, the
// loops and the vertex positions written to files that the polygon mesher reads on demand.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/meshing/polygon_mesher.h"
#include "stream/stitch/loop_chunks.h"

namespace gaussmesh::stream {

// The stitch's last step before the mesher: runs joined into loops (each patch's loops from
// their lowest half-edge id, as mesh_patch_polygons walks them), vertices renumbered densely in
// global id order. The loops (4 bytes per half-edge) and the positions (dense order) go to
// files in dir that the mesher reads on demand (PolygonGraphInput::loop_source,
// position_source). Records are untrusted: runs that do not close into loops, run files that disagree with their summaries, are kBadInput.
// extra_vertices: (global id, position) of vertices no record names — the inner vertices of
// fetched patch faces — added with no role. Free pages go back to the system between its steps.
struct LoopStitchStats {
  std::size_t runs = 0, half_edges = 0, vertices = 0;
};
format::Result<PolygonGraphInput> stitch_loops(const std::vector<ChunkLoopSummary>& chunks, std::size_t patches,
                                               const std::vector<format::Vec3f>& plane_normal, const std::string& dir,
                                               const std::vector<std::pair<std::uint32_t, format::Vec3f>>& extra_vertices = {},
                                               LoopStitchStats* stats = nullptr);


// The dense id of a global id: its lower bound in `global` (ascending, distinct), searched only
// among the ids that share its high bits, through a table of where each block of 2^shift ids
// starts — a quarter of global's size at most. A binary search over all of global is a large
// share of the loop stitch, which looks up every loop vertex several times (docs/benchmarks.md).
// Holds a reference to global.
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

}  // namespace gaussmesh::stream
