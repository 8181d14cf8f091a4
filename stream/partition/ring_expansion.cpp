// The ring rounds: each vertex's chunk set grown ring by ring over the face spill, so that a chunk
// holds every face within its overlap rings.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "stream/partition/face_scan.h"
#include "stream/partition/partition_run.h"

namespace gaussmesh::stream::detail {

// Rounds 1..k-1 of T_i(v) = union over faces f at v of union over corners w of f of T_{i-1}(w),
// with T_0(v) = {owner(v)}; only entries added in round i-1 (the frontier) travel in round i.
Status PartitionRun::expand_rings() {
  const std::uint32_t k = options_.rings;
  std::vector<std::uint32_t> incoming;
  for (std::uint32_t round = 1; round < k; ++round) {
    CachedBitmap& next = *frontier_[round % 2];
    const CachedBitmap& previous = *frontier_[(round + 1) % 2];
    const bool keep_frontier = round + 1 < k;
    std::uint64_t added = 0;
    auto add = [&](std::uint32_t v, std::uint32_t owner, std::uint32_t chunk) {
      if (chunk == owner || sets_->contains(v, chunk)) return;
      sets_->add(v, chunk | round << 24);
      has_extras_->set(v);
      if (keep_frontier) next.set(v);
      ++added;
    };
    // Tag 1: a face the round must look at. Round 1: its corners' owners differ (a few percent
    // of the faces); later rounds: a corner is in the frontier, read from the file the cache
    // has just flushed.
    if (round > 1) cache_->flush(previous.file());
    auto tag_of = [&](const Triangle& t, FaceWindows& w) -> std::uint32_t {
      if (round == 1) {
        const std::uint32_t o = w.owners.u32(t.v[0]);
        return w.owners.u32(t.v[1]) != o || w.owners.u32(t.v[2]) != o;
      }
      return w.bitmap->bit(t.v[0]) || w.bitmap->bit(t.v[1]) || w.bitmap->bit(t.v[2]);
    };
    GM_RETURN_IF_ERROR(scan_faces(round > 1 ? previous.file() : -1, 1, tag_of, [&](std::uint64_t, const Triangle& t, std::uint32_t tag) {
      if (tag == 0) return;
      std::uint32_t owner[3];
      if (round == 1) {
        for (int j = 0; j < 3; ++j) owner[j] = owners_->get(t.v[j]);
        if (owner[0] == owner[1] && owner[1] == owner[2]) return;
        for (int j = 0; j < 3; ++j)
          for (int i = 0; i < 3; ++i) add(t.v[j], owner[j], owner[i]);
        return;
      }
      const bool in[3] = {previous.test(t.v[0]), previous.test(t.v[1]), previous.test(t.v[2])};
      if (!in[0] && !in[1] && !in[2]) return;
      incoming.clear();
      for (int j = 0; j < 3; ++j) {
        if (!in[j] || (j > 0 && t.v[j] == t.v[0]) || (j > 1 && t.v[j] == t.v[1])) continue;
        sets_->for_each(t.v[j], [&](std::uint32_t e) {
          if (entry_ring(e) == round - 1) incoming.push_back(entry_chunk(e));
        });
      }
      std::sort(incoming.begin(), incoming.end());
      incoming.erase(std::unique(incoming.begin(), incoming.end()), incoming.end());
      for (int j = 0; j < 3; ++j) {
        const std::uint32_t o = owners_->get(t.v[j]);
        for (std::uint32_t c : incoming) add(t.v[j], o, c);
      }
    }, [] { return false; }));
    frontier_[(round + 1) % 2]->clear();
    GM_RETURN_IF_ERROR(cache_->status());
    if (added == 0) break;  // nothing new: later rounds add nothing either
  }
  return {};
}

}  // namespace gaussmesh::stream::detail
