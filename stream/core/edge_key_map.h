// A hash table from 64-bit edge keys to 32-bit values for the meshers' edge sets: flat, no
// allocation per key, and no iteration, so that no hash order can reach an output.
#pragma once

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace gaussmesh::stream {

// An open-addressing hash table from 64-bit edge keys (two 32-bit ids, as the polygon
// triangulator and the polygon mesher make them) to a 32-bit value: linear probing,
// backward-shift erase, one flat array, no allocation per key. For lookups only: it has no
// iteration, so no hash order can reach an output. The all-ones key (an edge from id
// 0xFFFFFFFF to itself) marks free slots and cannot be stored.
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

}  // namespace gaussmesh::stream
