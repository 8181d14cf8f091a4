// Per-vertex chunk sets: the chunks beyond its owner whose overlap rings hold a vertex, with the
// ring that added each, stored in the block cache.
#pragma once

#include <algorithm>
#include <cstdint>

#include "stream/partition/block_cache.h"

namespace gaussmesh::stream::detail {

// Entry = chunk id (low 24 bits) | ring that added it (high 8 bits). A vertex's owner is never
// stored: it is a function of the position.
constexpr std::uint32_t kChunkMask = 0x00FFFFFFu;
inline std::uint32_t entry_chunk(std::uint32_t entry) { return entry & kChunkMask; }
inline std::uint32_t entry_ring(std::uint32_t entry) { return entry >> 24; }

// Up to three entries inline in a 16-byte slot (one per vertex that has entries, found through a
// 4-byte index per vertex); more move to a chain of 64-byte nodes (14 entries each, newest node
// first). Never truncated: a vertex of any valence keeps all.
struct ExtraSlot {
  std::uint32_t count = 0;
  std::uint32_t e[3] = {0, 0, 0};  // entries, or e[0] = head node id when count > 3
};
struct ExtraNode {
  std::uint32_t next = 0;  // node id + 1 of the next node; 0 ends the chain
  std::uint32_t used = 0;
  std::uint32_t e[14] = {};
};
static_assert(sizeof(ExtraSlot) == 16 && sizeof(ExtraNode) == 64);

class ChunkSets {
 public:
  ChunkSets(BlockCache& cache, int index_file, int slot_file, int node_file)
      : index_(cache, index_file), slots_(cache, slot_file), nodes_(cache, node_file) {}

  // Calls fn(entry) for every entry of v.
  template <class Fn>
  void for_each(std::uint64_t v, Fn&& fn) const {
    const std::uint32_t index = index_.get(v);
    if (index == 0) return;
    const ExtraSlot slot = slots_.get(index - 1);
    if (slot.count <= 3) {
      for (std::uint32_t i = 0; i < slot.count; ++i) fn(slot.e[i]);
      return;
    }
    std::uint64_t node_id = slot.e[0];
    std::uint64_t seen = 0;
    for (;;) {
      const ExtraNode node = nodes_.get(node_id);
      const std::uint32_t used = std::min<std::uint32_t>(node.used, 14);
      for (std::uint32_t i = 0; i < used; ++i) fn(node.e[i]);
      seen += used;
      if (node.next == 0 || seen >= slot.count) break;
      node_id = node.next - 1;
    }
  }
  bool contains(std::uint64_t v, std::uint32_t chunk) const {
    bool found = false;
    for_each(v, [&](std::uint32_t e) { found |= entry_chunk(e) == chunk; });
    return found;
  }
  void add(std::uint64_t v, std::uint32_t entry) {
    std::uint32_t index = index_.get(v);
    ExtraSlot slot;
    if (index == 0) {
      index = static_cast<std::uint32_t>(++slot_count_);
      index_.set(v, index);
    } else {
      slot = slots_.get(index - 1);
    }
    if (slot.count < 3) {
      slot.e[slot.count++] = entry;
    } else if (slot.count == 3) {
      ExtraNode node;
      node.used = 4;
      std::copy(slot.e, slot.e + 3, node.e);
      node.e[3] = entry;
      slot.e[0] = static_cast<std::uint32_t>(node_count_);
      nodes_.set(node_count_++, node);
      ++slot.count;
    } else {
      ExtraNode head = nodes_.get(slot.e[0]);
      if (head.used < 14) {
        head.e[head.used++] = entry;
        nodes_.set(slot.e[0], head);
      } else {
        ExtraNode node;
        node.next = slot.e[0] + 1;
        node.used = 1;
        node.e[0] = entry;
        slot.e[0] = static_cast<std::uint32_t>(node_count_);
        nodes_.set(node_count_++, node);
      }
      ++slot.count;
    }
    slots_.set(index - 1, slot);
  }

 private:
  // Per vertex, 1 + its slot's index (0: no entries): border vertices are few but spread over
  // the whole id range, so a slot per vertex (16 bytes) would make nearly every block of a large
  // file dirty; the index is 4 bytes a vertex and the slots are dense.
  CachedArray<std::uint32_t> index_;
  CachedArray<ExtraSlot> slots_;
  CachedArray<ExtraNode> nodes_;
  std::uint64_t slot_count_ = 0, node_count_ = 0;
};

}  // namespace gaussmesh::stream::detail
