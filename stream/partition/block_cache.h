// The bounded block cache over the partition's vertex-indexed spill files: a fixed arena of
// 4 KiB blocks read and written with pread/pwrite, CLOCK replacement, growth on demand within its
// budget; typed arrays and bitmaps over its files.
#pragma once

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "format/file_io.h"
#include "format/status.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

using format::Code;
using format::Result;
using format::Status;

// Slot size: one page, so that a dirty block goes back as a whole page (a write of part of a
// page the file does not have yet makes the kernel zero the page first, a memset per write) and
// 4-, 16- and 64-byte records tile it. Small blocks make a miss cheap on badly ordered input (a
// miss is one pread of the block); spatially ordered input hits nearly always at any block size
// (docs/partition.md).
constexpr std::size_t kSlotBytes = 4096;

// Asks for transparent huge pages on the whole 2 MiB pages inside [data, data + bytes). The
// scans touch the cache's blocks at random, and with 4 KiB pages its TLB misses are a sizeable
// part of the partition's time. Advice only: without THP, or with THP off, nothing changes.
inline void advise_huge_pages(void* data, std::size_t bytes) {
  constexpr std::uintptr_t kHuge = std::uintptr_t{1} << 21;
  const auto start = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t lo = (start + kHuge - 1) & ~(kHuge - 1), hi = (start + bytes) & ~(kHuge - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
}

// Blocks of several files in a fixed arena of budget bytes. Accessors copy values in and out
// (never hold a block pointer across another access: the next miss may evict it). Blocks never
// written read as zeros. I/O errors are sticky: accessors then see a zero block and status()
// says what failed; callers check it after every batch.
// The cache starts at 1/8 of its budget and doubles when a bigger one would have hit: it
// remembers the keys of its last `usable_` evictions (a ghost list), and when over 1/8 of the
// misses in a window of `usable_` misses ask for one of them, it doubles. Spatially ordered
// input misses on first touches and on the next scan's sweep, long after the eviction, at any
// size, so the cache stays small and leaves the budget's pages untouched; badly ordered input
// asks for recently evicted blocks at once and grows the cache within a few windows
// (docs/partition.md has the figures).
class BlockCache {
 public:
  explicit BlockCache(std::size_t budget_bytes) {
    slot_count_ = std::max<std::size_t>(budget_bytes / kSlotBytes, 16);
    usable_ = std::min(slot_count_, std::max<std::size_t>(slot_count_ / 8, 64));
    arena_.reset(new std::byte[slot_count_ * kSlotBytes]);  // untouched until used
    advise_huge_pages(arena_.get(), slot_count_ * kSlotBytes);
    slots_.assign(slot_count_, Slot{});
    std::size_t capacity = 1;
    while (capacity < 2 * slot_count_) capacity *= 2;
    table_.assign(capacity, kNoSlot);
    table_mask_ = capacity - 1;
    tlb_.fill(Tlb{});
  }
  ~BlockCache() {
    for (File& file : files_)
      if (file.fd >= 0) ::close(file.fd);
  }
  BlockCache(const BlockCache&) = delete;
  BlockCache& operator=(const BlockCache&) = delete;

  Result<int> add_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0) return Status::error(Code::kOutput, path, "cannot create temporary file: " + errno_text());
    files_.push_back(File{fd, path});
    return static_cast<int>(files_.size() - 1);
  }
  // Opens an existing file read-only (a spill written sequentially).
  Result<int> open_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return Status::error(Code::kBadInput, path, "cannot open temporary file: " + errno_text());
    files_.push_back(File{fd, path});
    return static_cast<int>(files_.size() - 1);
  }

  // The block; mark it dirty when it will be written. Valid until the next call.
  // A front-table hit reads nothing but the entry: an evicted block's entry is dropped when the
  // block goes (load, discard), so a matching key always names the block's slot and data, and a
  // hit costs no load from the slot table.
  std::byte* block(int file, std::uint64_t index, bool dirty) {
    const std::uint64_t key = (static_cast<std::uint64_t>(file) + 1) << 48 | index;
    Tlb& entry = tlb_[tlb_index(key)];
    if (entry.key != key) [[unlikely]] {
      const std::uint32_t slot = lookup(file, index, key);
      entry.key = key;
      entry.slot = slot;
      entry.data = arena_.get() + std::size_t{slot} * kSlotBytes;
    }
    if (dirty) slots_[entry.slot].dirty = true;
    return entry.data;
  }

  // Forgets every block of file without writing it back and truncates the file: it reads as
  // zeros again.
  void discard(int file) {
    tlb_.fill(Tlb{});
    for (std::uint32_t slot = 0; slot < slot_count_; ++slot) {
      if (slots_[slot].key >> 48 == static_cast<std::uint64_t>(file) + 1) {
        erase(slots_[slot].key);
        slots_[slot] = Slot{};
        free_.push_back(slot);
      }
    }
    if (::ftruncate(files_[file].fd, 0) != 0 && status_.is_ok()) {
      status_ = Status::error(Code::kOutput, files_[file].path, "truncate failed: " + errno_text());
    }
  }

  // Writes back the dirty blocks of file and keeps them cached, clean: the file then holds
  // what the cache holds, for a FileWindow to read on another thread.
  void flush(int file) {
    for (std::uint32_t slot = 0; slot < slot_count_; ++slot) {
      Slot& s = slots_[slot];
      if (!s.dirty || s.key >> 48 != static_cast<std::uint64_t>(file) + 1) continue;
      const std::uint64_t at = (s.key & ((std::uint64_t{1} << 48) - 1)) * kSlotBytes;
      if (!format::write_all(files_[file].fd, arena_.get() + std::size_t{slot} * kSlotBytes, kSlotBytes, at, true)) {
        if (status_.is_ok()) status_ = Status::error(Code::kOutput, files_[file].path, "write failed: " + errno_text());
      } else {
        bytes_written_ += kSlotBytes;
      }
      s.dirty = false;
    }
  }
  int fd(int file) const { return files_[file].fd; }
  const std::string& path(int file) const { return files_[file].path; }

  const Status& status() const { return status_; }
  std::uint64_t misses() const { return misses_; }
  std::uint64_t bytes_written() const { return bytes_written_; }
  std::uint64_t bytes() const { return std::uint64_t{usable_} * kSlotBytes; }  // its size now
  // Grows no further than `bytes` (never below its size now): what it leaves of its budget goes
  // to the final scan's staged frames.
  void limit(std::uint64_t bytes) {
    slot_count_ = std::clamp<std::size_t>(static_cast<std::size_t>(bytes / kSlotBytes), usable_, slot_count_);
    if (usable_ == slot_count_) {
      ghosts_ = {};
      ghost_count_ = {};
    }
  }

 private:
  static constexpr std::uint32_t kNoSlot = 0xFFFFFFFFu;
  static constexpr std::uint64_t kFree = 0;
  static constexpr std::size_t kTlbSize = 64;
  struct Slot {
    std::uint64_t key = kFree;
    bool dirty = false, referenced = false;
  };
  struct File {
    int fd = -1;
    std::string path;
  };
  struct Tlb {
    std::uint64_t key = kFree;
    std::uint32_t slot = kNoSlot;
    std::byte* data = nullptr;
  };
  static std::size_t tlb_index(std::uint64_t key) {
    const std::uint64_t file = (key >> 48) - 1, index = key & ((std::uint64_t{1} << 48) - 1);
    return static_cast<std::size_t>((index + file * 7) & (kTlbSize - 1));
  }

  std::size_t home(std::uint64_t key) const { return (key * 0x9E3779B97F4A7C15ull >> 20) & table_mask_; }
  std::uint32_t find(std::uint64_t key) const {
    for (std::size_t at = home(key);; at = (at + 1) & table_mask_) {
      const std::uint32_t slot = table_[at];
      if (slot == kNoSlot) return kNoSlot;
      if (slots_[slot].key == key) return slot;
    }
  }
  void insert(std::uint64_t key, std::uint32_t slot) {
    std::size_t at = home(key);
    while (table_[at] != kNoSlot) at = (at + 1) & table_mask_;
    table_[at] = slot;
  }
  // Linear-probing deletion by backward shift (no tombstones).
  void erase(std::uint64_t key) {
    std::size_t at = home(key);
    while (slots_[table_[at]].key != key) at = (at + 1) & table_mask_;
    std::size_t gap = at;
    for (std::size_t next = (gap + 1) & table_mask_; table_[next] != kNoSlot; next = (next + 1) & table_mask_) {
      const std::size_t want = home(slots_[table_[next]].key);
      // Move the entry at next into the gap unless its home lies cyclically in (gap, next].
      const bool stays = gap <= next ? (want > gap && want <= next) : (want > gap || want <= next);
      if (!stays) {
        table_[gap] = table_[next];
        gap = next;
      }
    }
    table_[gap] = kNoSlot;
  }
  std::uint32_t victim() {
    if (!free_.empty()) {
      const std::uint32_t slot = free_.back();
      free_.pop_back();
      return slot;
    }
    if (next_unused_ < usable_) return static_cast<std::uint32_t>(next_unused_++);
    // A block in the front table counts as referenced: its hits set no bit (a store into the slot
    // table per access would cost the scans more than the lookup). After two sweeps (every slot
    // in the front table: a cache of fewer slots than it) the hand takes the slot it is on.
    for (std::size_t step = 0;; ++step) {
      Slot& s = slots_[hand_];
      const std::uint32_t slot = static_cast<std::uint32_t>(hand_);
      hand_ = hand_ + 1 >= usable_ ? 0 : hand_ + 1;
      if (!s.referenced && (tlb_[tlb_index(s.key)].key != s.key || step >= 2 * usable_)) return slot;
      s.referenced = false;
    }
  }
  [[gnu::noinline]] std::uint32_t lookup(int file, std::uint64_t index, std::uint64_t key) {
    const std::uint32_t slot = find(key);
    if (slot == kNoSlot) return load(file, index, key);
    slots_[slot].referenced = true;
    return slot;
  }
  std::uint32_t load(int file, std::uint64_t index, std::uint64_t key) {
    ++misses_;
    if (usable_ < slot_count_) adapt(key);
    const std::uint32_t slot = victim();
    Slot& s = slots_[slot];
    std::byte* data = arena_.get() + std::size_t{slot} * kSlotBytes;
    if (s.key != kFree) {
      if (s.dirty) {
        const File& owner = files_[(s.key >> 48) - 1];
        const std::uint64_t at = (s.key & ((std::uint64_t{1} << 48) - 1)) * kSlotBytes;
        if (!format::write_all(owner.fd, data, kSlotBytes, at, true)) {
          if (status_.is_ok()) status_ = Status::error(Code::kOutput, owner.path, "write failed: " + errno_text());
        } else {
          bytes_written_ += kSlotBytes;
        }
      }
      erase(s.key);
      Tlb& stale = tlb_[tlb_index(s.key)];
      if (stale.key == s.key) stale = Tlb{};
      if (usable_ < slot_count_) remember_eviction(s.key);
    }
    const std::int64_t got = status_.is_ok() ? read_some(files_[file].fd, data, kSlotBytes, index * kSlotBytes) : 0;
    if (got < 0) {
      status_ = Status::error(Code::kOutput, files_[file].path, "read failed: " + errno_text());
      std::memset(data, 0, kSlotBytes);
    } else {
      std::memset(data + got, 0, kSlotBytes - static_cast<std::size_t>(got));
    }
    s.key = key;
    s.dirty = false;
    s.referenced = true;
    insert(key, slot);
    return slot;
  }

  std::size_t slot_count_ = 0, usable_ = 0, next_unused_ = 0, hand_ = 0, table_mask_ = 0;
  std::unique_ptr<std::byte[]> arena_;
  std::vector<Slot> slots_;
  std::vector<std::uint32_t> table_, free_;
  std::array<Tlb, kTlbSize> tlb_;
  std::vector<File> files_;
  Status status_;
  std::uint64_t misses_ = 0, bytes_written_ = 0;
  // Growth (while usable_ < slot_count_): the last usable_ evicted keys, oldest first, with how
  // many times each is among them; the misses and ghost hits of the current window.
  void remember_eviction(std::uint64_t key) {
    ghosts_.push_back(key);
    ++ghost_count_[key];
    while (ghosts_.size() > usable_) {
      auto it = ghost_count_.find(ghosts_.front());
      if (--it->second == 0) ghost_count_.erase(it);
      ghosts_.pop_front();
    }
  }
  void adapt(std::uint64_t key) {
    ghost_hits_ += ghost_count_.count(key);
    if (++window_misses_ < usable_) return;
    if (ghost_hits_ * 8 > window_misses_) {
      usable_ = std::min(2 * usable_, slot_count_);
      if (usable_ == slot_count_) {
        ghosts_ = {};
        ghost_count_ = {};
      }
    }
    window_misses_ = ghost_hits_ = 0;
  }
  std::deque<std::uint64_t> ghosts_;
  std::unordered_map<std::uint64_t, std::uint32_t> ghost_count_;
  std::uint64_t window_misses_ = 0, ghost_hits_ = 0;
};

// A vertex- (or node-) indexed array of T in a cached file.
template <class T>
class CachedArray {
 public:
  static constexpr std::uint64_t kPerBlock = kSlotBytes / sizeof(T);
  static_assert(kSlotBytes % sizeof(T) == 0);
  CachedArray(BlockCache& cache, int file) : cache_(&cache), file_(file) {}
  T get(std::uint64_t i) const {
    const std::byte* block = cache_->block(file_, i / kPerBlock, false);
    T value;
    std::memcpy(&value, block + (i % kPerBlock) * sizeof(T), sizeof(T));
    return value;
  }
  void set(std::uint64_t i, const T& value) {
    std::byte* block = cache_->block(file_, i / kPerBlock, true);
    std::memcpy(block + (i % kPerBlock) * sizeof(T), &value, sizeof(T));
  }

 private:
  BlockCache* cache_;
  int file_;
};

class CachedBitmap {
 public:
  static constexpr std::uint64_t kPerBlock = kSlotBytes * 8;
  CachedBitmap(BlockCache& cache, int file) : cache_(&cache), file_(file) {}
  bool test(std::uint64_t i) const {
    const std::byte* block = cache_->block(file_, i / kPerBlock, false);
    const std::uint64_t bit = i % kPerBlock;
    return (std::to_integer<unsigned>(block[bit / 8]) >> (bit % 8)) & 1u;
  }
  void set(std::uint64_t i) {
    std::byte* block = cache_->block(file_, i / kPerBlock, true);
    const std::uint64_t bit = i % kPerBlock;
    block[bit / 8] |= std::byte{static_cast<unsigned char>(1u << (bit % 8))};
  }
  void clear() { cache_->discard(file_); }
  int file() const { return file_; }

 private:
  BlockCache* cache_;
  int file_;
};

}  // namespace gaussmesh::stream::detail
