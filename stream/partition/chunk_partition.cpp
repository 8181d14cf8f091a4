// Passes 0 and 1 of the out-of-core pipeline (DESIGN §2; docs/partition.md has the design and
// the measurements): ingest to spill files, Morton-ordered cell histogram, ring expansion of
// per-vertex chunk sets, chunk face record files. Vertex-indexed data lives in spill files
// behind one bounded block cache (pread/pwrite, CLOCK replacement, fixed byte budget); faces
// are only ever read sequentially.
#include "stream/partition/chunk_partition.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <system_error>
#include <thread>
#include <type_traits>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "format/file_io.h"
#include "format/record_file.h"
#include "format/temp_registry.h"
#include "stream/partition/id_indexed_file.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Result;
using format::Status;
using format::Triangle;
using format::Vec3f;

static_assert(sizeof(Vec3f) == 12 && sizeof(Triangle) == 12, "spill layouts assume packed values");

std::string errno_text() { return std::strerror(errno); }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Reads up to size bytes at offset; returns the count read (short at end of file), -1 on error.
std::int64_t read_some(int fd, void* out, std::size_t size, std::uint64_t offset) {
  char* bytes = static_cast<char*>(out);
  std::size_t done = 0;
  while (done < size) {
    ssize_t got = ::pread(fd, bytes + done, size - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return -1;
    if (got == 0) break;
    done += static_cast<std::size_t>(got);
  }
  return static_cast<std::int64_t>(done);
}

// ---- Sequential spill files (pass 0 writes, later scans read) --------------------------------

class SpillWriter {
 public:
  ~SpillWriter() {
    if (fd_ >= 0) ::close(fd_);
  }
  Status open(const std::string& path, std::size_t buffer_bytes) {
    path_ = path;
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd_ < 0) return Status::error(Code::kOutput, path, "cannot create temporary file: " + errno_text());
    buffer_.reset(new std::byte[buffer_bytes]);
    capacity_ = buffer_bytes;
    return {};
  }
  Status write(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const std::byte*>(data);
    while (size > 0) {
      if (used_ == capacity_) GM_RETURN_IF_ERROR(flush());
      const std::size_t take = std::min(size, capacity_ - used_);
      std::memcpy(buffer_.get() + used_, bytes, take);
      used_ += take;
      bytes += take;
      size -= take;
    }
    return {};
  }
  Status close() {
    GM_RETURN_IF_ERROR(flush());
    buffer_.reset();
    const int fd = fd_;
    fd_ = -1;
    if (fd >= 0 && ::close(fd) != 0) return Status::error(Code::kOutput, path_, "close failed: " + errno_text());
    return {};
  }
  std::uint64_t bytes() const { return total_; }

 private:
  Status flush() {
    if (used_ == 0) return {};
    if (!format::write_all(fd_, buffer_.get(), used_, 0, false)) {
      return Status::error(Code::kOutput, path_, "write failed: " + errno_text());
    }
    total_ += used_;
    used_ = 0;
    return {};
  }
  int fd_ = -1;
  std::string path_;
  std::unique_ptr<std::byte[]> buffer_;
  std::size_t capacity_ = 0, used_ = 0;
  std::uint64_t total_ = 0;
};

// ---- The bounded block cache over vertex-indexed spill files ---------------------------------

// Slot size: one page, so that a dirty block goes back as a whole page (a write of part of a
// page the file does not have yet makes the kernel zero the page first: with 3 KiB blocks,
// 16 % of the 100M ring rounds' thread was that memset) and 4-, 16- and 64-byte records tile it.
// Small blocks make a miss cheap on badly ordered input (a miss is one pread of the block); on
// spatially ordered input the hit rate is ~99.9 % at any size (docs/partition.md).
constexpr std::size_t kSlotBytes = 4096;

// Asks for transparent huge pages on the whole 2 MiB pages inside [data, data + bytes). The
// scans touch the cache's blocks at random: with 4 KiB pages the TLB misses on this VM cost a
// seventh of the 10M partition (1.03 -> 0.87 s with huge pages). Advice only: without THP, or
// with THP off, nothing changes.
void advise_huge_pages(void* data, std::size_t bytes) {
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
// size (partition alone, 64 MiB: 10M triangles 14.8k misses in 3.75 MiB against 7.0k in 30 MiB,
// 100M 155k against 151k), so the cache stays small and leaves the budget's pages untouched;
// badly ordered input asks for recently evicted blocks at once and grows the cache within a few
// windows (3M shuffled under 64 MiB: 15 MiB, 5.3k misses against 3.3k in 30 MiB; 1M shuffled
// under 16 MiB: the whole 7.5 MiB).
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
  // block goes (load, discard), so a matching key always names the block's slot and data. (It
  // used to check the slot's key too: a load from the slot table per access, 13 % of the ring
  // rounds at 10M.)
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
    // table per access was a quarter of the final scan's own time). After two sweeps (every slot
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

// A read-only window on one of the cache's files (owners.bin, or a bitmap the cache has
// flushed), for one thread: 4 KiB blocks in two-way sets (the least recently used way goes), a
// pread per miss, zeros past the end of the file (blocks never written read as zeros, as in the
// cache). The ring rounds' tags read through these on the read-ahead thread, beside the
// single-threaded cache. Direct-mapped, two hot blocks on one slot (at 100M, a base face's
// interior ids and one of its edges' ids) missed on every other face: round 1 found 177 of
// 1,140 frames missing more than once per 256 faces. A failed read reads as zeros and keeps its
// error (error()), which the tagger returns after the frame.
class FileWindow {
 public:
  static constexpr std::size_t kBlockBytes = 4096;
  FileWindow(int fd, std::size_t bytes) : fd_(fd) {
    std::size_t sets = 2;
    while (sets * 4 * kBlockBytes <= bytes) sets *= 2;
    mask_ = sets - 1;
    keys_.assign(2 * sets, kEmpty);
    evict_.assign(sets, 0);
    data_.reset(new std::byte[2 * sets * kBlockBytes]);
  }
  std::uint32_t u32(std::uint64_t i) {
    std::uint32_t value;
    std::memcpy(&value, at(4 * i), 4);
    return value;
  }
  bool bit(std::uint64_t i) { return (std::to_integer<unsigned>(*at(i / 8)) >> (i % 8)) & 1u; }
  // The first read error's text, empty when every read worked.
  const std::string& error() const { return error_; }
  std::uint64_t misses() const { return misses_; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  const std::byte* at(std::uint64_t byte) {
    const std::uint64_t block = byte / kBlockBytes;
    // A face's corners, and the next face's, mostly lie in one block (1,024 owners, 32,768
    // frontier bits): the last block found answers first.
    if (block == last_block_) return last_data_ + byte % kBlockBytes;
    const std::size_t set = static_cast<std::size_t>(block & mask_);
    std::size_t slot = 2 * set;
    if (keys_[slot] != block) [[unlikely]] {
      if (keys_[slot + 1] == block) {
        ++slot;
      } else {
        ++misses_;
        slot += evict_[set];
        std::byte* data = data_.get() + slot * kBlockBytes;
        const std::int64_t got = read_some(fd_, data, kBlockBytes, block * kBlockBytes);
        if (got < 0 && error_.empty()) error_ = errno_text();
        const std::size_t kept = got > 0 ? static_cast<std::size_t>(got) : 0;
        std::memset(data + kept, 0, kBlockBytes - kept);
        keys_[slot] = block;
      }
    }
    evict_[set] = static_cast<std::uint8_t>((slot & 1) ^ 1);  // the other way goes next
    last_block_ = block;
    last_data_ = data_.get() + slot * kBlockBytes;
    return last_data_ + byte % kBlockBytes;
  }
  int fd_;
  std::uint64_t mask_ = 0, misses_ = 0;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint8_t> evict_;  // per set: the way a miss replaces
  std::uint64_t last_block_ = kEmpty;  // the block the last lookup found, at last_data_
  const std::byte* last_data_ = nullptr;
  std::unique_ptr<std::byte[]> data_;
  std::string error_;
};

// ---- Per-vertex chunk sets beyond the owner ---------------------------------------------------

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
      ++overflowed_;
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
  std::uint64_t overflowed() const { return overflowed_; }
  std::uint64_t nodes() const { return node_count_; }

 private:
  // Per vertex, 1 + its slot's index (0: no entries): border vertices are few but spread over
  // the whole id range, so a slot per vertex (16 bytes) made nearly every block of an
  // 800 MB file dirty at 100M; the index is 4 bytes a vertex and the slots are dense.
  CachedArray<std::uint32_t> index_;
  CachedArray<ExtraSlot> slots_;
  CachedArray<ExtraNode> nodes_;
  std::uint64_t slot_count_ = 0, node_count_ = 0, overflowed_ = 0;
};

// ---- The cell grid --------------------------------------------------------------------------

constexpr std::uint32_t kCellBits = 18;  // at most 2^18 cells: histogram and table 1 MiB each
constexpr std::uint32_t kMaxSplitBits = 5;  // a split cell has at most 8^5 sub-cells (128 KiB of counts)

struct Grid {
  double lo[3] = {0, 0, 0}, scale[3] = {0, 0, 0};
  std::uint32_t bits[3] = {0, 0, 0};
  std::uint32_t n[3] = {1, 1, 1};

  // Per-axis bits so that cells are as close to cubes as 2^kCellBits cells allow.
  static Grid make(const Vec3f& lo, const Vec3f& hi) {
    Grid g;
    const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    double extent[3];
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = l[a];
      extent[a] = h[a] - l[a];
      if (!(extent[a] > 0) || !std::isfinite(extent[a])) extent[a] = 0;
    }
    for (std::uint32_t b = 0; b < kCellBits; ++b) {
      int best = -1;
      double best_size = 0;
      for (int a = 0; a < 3; ++a) {
        const double size = std::ldexp(extent[a], -static_cast<int>(g.bits[a]));
        if (extent[a] > 0 && size > best_size) {
          best = a;
          best_size = size;
        }
      }
      if (best < 0) break;
      ++g.bits[best];
    }
    for (int a = 0; a < 3; ++a) {
      g.n[a] = 1u << g.bits[a];
      g.scale[a] = extent[a] > 0 ? g.n[a] / extent[a] : 0;
    }
    return g;
  }
  std::size_t cells() const { return std::size_t{n[0]} * n[1] * n[2]; }
  std::uint32_t axis(int a, float value) const {
    const double t = (static_cast<double>(value) - lo[a]) * scale[a];
    if (!(t >= 0)) return 0;  // below, or NaN
    if (t >= n[a]) return n[a] - 1;
    return static_cast<std::uint32_t>(t);
  }
  std::uint32_t cell(const Vec3f& p) const {
    return axis(0, p.x) + n[0] * (axis(1, p.y) + n[1] * axis(2, p.z));
  }
  // Z-order code of p's sub-cell when its cell is split into 2^k parts per axis (axes of zero
  // extent stay whole). The fine coordinate is floor(t * 2^k) on the cell's own t: scaling by a
  // power of two is exact (a multiplication, not std::ldexp, which is a libm call per vertex),
  // so it always lies inside the cell that cell(p) names.
  std::uint32_t sub_code(const Vec3f& p, std::uint32_t k) const {
    const float c[3] = {p.x, p.y, p.z};
    std::uint32_t local[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      if (scale[a] == 0) continue;
      const double t = (static_cast<double>(c[a]) - lo[a]) * scale[a];
      const std::uint64_t parts = std::uint64_t{1} << k;
      std::uint64_t fine = 0;
      if (t >= n[a]) {
        fine = std::uint64_t{n[a]} * parts - 1;
      } else if (t >= 0) {
        fine = std::min<std::uint64_t>(static_cast<std::uint64_t>(t * static_cast<double>(parts)), std::uint64_t{n[a]} * parts - 1);
      }
      local[a] = static_cast<std::uint32_t>(fine - (std::uint64_t{axis(a, c[a])} << k));
    }
    std::uint32_t code = 0;
    for (std::uint32_t level = k; level-- > 0;)
      for (int a = 0; a < 3; ++a) code = code << 1 | ((local[a] >> level) & 1u);
    return code;
  }
  // Z-order code of a cell: bits interleaved from the top level down; an axis with fewer bits
  // joins the interleave at its own top level.
  std::uint32_t morton(std::uint32_t linear) const {
    const std::uint32_t i[3] = {linear % n[0], (linear / n[0]) % n[1], linear / (n[0] * n[1])};
    std::uint32_t code = 0;
    const std::uint32_t top = std::max({bits[0], bits[1], bits[2]});
    for (std::uint32_t level = top; level-- > 0;)
      for (int a = 0; a < 3; ++a)
        if (level < bits[a]) code = code << 1 | ((i[a] >> level) & 1u);
    return code;
  }
};

// ---- Pass 0: ingest ----------------------------------------------------------------------------

// The face spill: faces in input order as a record file (kFaceSpillRecordKind) with column frames,
// the three vertex ids as differences from the previous face's. Neighbouring faces share
// vertices, so the ids compress to a few percent (1.2 GB at 100M triangles as plain triangles,
// ~21 MB as a spill); on this VM writing temporary files runs at 0.3-0.6 GB/s, and the scans
// read it k times.
constexpr std::uint32_t kFaceSpillRecordKind = 0x53464D47u;  // "GMFS"
constexpr std::size_t kFaceSpillFrameBytes = std::size_t{1} << 20;

class FaceSpill {
 public:
  Status open(const std::string& path) {
    format::RecordWriterOptions options;
    options.frame_bytes = kFaceSpillFrameBytes;
    // -1: on the refined cow's 1 MB frames 2.2x faster to compress and 1.5x to decompress than
    // level 1, for 19.3x instead of 21.6x (docs/partition.md, "zstd level on column frames").
    options.level = -1;
    options.columns = {{4, true}, {4, true}, {4, true}};
    auto writer = format::RecordWriter::create(path, kFaceSpillRecordKind, sizeof(Triangle), options);
    if (!writer) return writer.status();
    writer_ = std::move(*writer);
    return {};
  }
  Status write(std::span<const Triangle> batch) { return writer_->append(std::as_bytes(batch)); }
  Status close() { return writer_->finish(); }
  std::uint64_t bytes() const { return writer_ ? writer_->bytes_written() : 0; }

 private:
  std::unique_ptr<format::RecordWriter> writer_;
};

// Reads the frames of a face spill, one frame ahead of the caller on its own thread when
// `ahead` (a run of --threads 1 reads in the caller's thread).
class FrameReadAhead {
 public:
  // tag(faces, tags), when set, fills one tag per face of a frame, on the read-ahead thread when
  // there is one (PartitionRun::scan_faces), before the frame is handed over; its error is the
  // frame's.
  using Tagger = std::function<Status(const std::vector<Triangle>&, std::vector<std::uint32_t>&)>;
  // skip(frame) true: the frame is passed over undecompressed (RecordReader::skip); called on
  // the read-ahead thread, in frame order.
  using Skip = std::function<bool(std::size_t)>;
  FrameReadAhead(format::RecordReader& reader, Tagger tag, Skip skip, bool ahead)
      : reader_(reader), tag_(std::move(tag)), skip_(std::move(skip)) {
    if (ahead) thread_ = std::thread([this] { run(); });
  }
  ~FrameReadAhead() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  FrameReadAhead(const FrameReadAhead&) = delete;
  FrameReadAhead& operator=(const FrameReadAhead&) = delete;
  // The next frame's faces and their tags into out, or, for a skipped frame, none and its
  // record count in skipped; both empty at the end. Or the reader's error.
  Status next(std::vector<Triangle>& out, std::vector<std::uint32_t>& tags, std::uint64_t& skipped) {
    if (!thread_.joinable()) return read(out, tags, skipped);
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return full_; });
    out.swap(ready_);
    tags.swap(ready_tags_);
    skipped = ready_skipped_;
    Status status = status_;
    full_ = false;
    changed_.notify_all();
    return status;
  }

 private:
  // Frames are all the same size but the last: resize keeps the buffer (and fills nothing).
  Status read(std::vector<Triangle>& frame, std::vector<std::uint32_t>& tags, std::uint64_t& skipped) {
    skipped = 0;
    if (skip_(frame_++)) {
      auto passed = reader_.skip();
      frame.clear();
      if (!passed) return passed.status();
      skipped = *passed;
      return {};
    }
    auto got = reader_.next();
    if (!got) {
      frame.clear();
      return got.status();
    }
    frame.resize(got->size() / sizeof(Triangle));
    if (!got->empty()) std::memcpy(frame.data(), got->data(), got->size());
    if (!tag_) return {};
    tags.resize(frame.size());
    return tag_(frame, tags);
  }
  void run() {
    std::vector<Triangle> frame;
    std::vector<std::uint32_t> tags;
    for (bool more = true; more;) {
      std::uint64_t skipped = 0;
      Status status = read(frame, tags, skipped);
      more = status.is_ok() && (!frame.empty() || skipped > 0);
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return !full_ || stopping_; });
      if (stopping_) return;
      ready_.swap(frame);
      ready_tags_.swap(tags);
      ready_skipped_ = skipped;
      status_ = status;
      full_ = true;
      changed_.notify_all();
    }
  }

  format::RecordReader& reader_;
  Tagger tag_;
  Skip skip_;
  std::size_t frame_ = 0;  // the reading side's next frame
  std::uint64_t ready_skipped_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Triangle> ready_;
  std::vector<std::uint32_t> ready_tags_;
  Status status_;
  bool full_ = false, stopping_ = false;
  std::thread thread_;  // last: starts once the rest is built (none when not reading ahead)
};

// Writes the ingest's two spills, on a thread of its own when `background` (the run has
// --threads > 1): the kernel's copy of positions.bin into the page cache (600 MB at 100M
// triangles, half the ingest's time on one thread) and the face spill's compression then run
// beside the reader's parsing. Each batch is copied into one of at most kInFlight buffers (the
// reader's batch is only valid during its call); one consumer keeps each file in order.
class SpillThread {
 public:
  SpillThread(SpillWriter& positions, FaceSpill& faces, bool background) : positions_(positions), faces_(faces) {
    if (background) thread_ = std::thread([this] { run(); });
  }
  ~SpillThread() { stop(); }
  SpillThread(const SpillThread&) = delete;
  SpillThread& operator=(const SpillThread&) = delete;

  Status vertices(std::span<const Vec3f> batch) { return put(false, std::as_bytes(batch)); }
  // Bytes for the first writer (the owner pass's owners.bin).
  Status bytes(std::span<const std::byte> bytes) { return put(false, bytes); }
  Status triangles(std::span<const Triangle> batch) { return put(true, std::as_bytes(batch)); }
  // Waits until everything handed over is written; the first write error.
  Status finish() {
    stop();
    return status_;
  }

 private:
  static constexpr std::size_t kInFlight = 4;
  struct Item {
    bool faces = false;
    std::vector<std::byte> bytes;
  };
  Status write(bool faces, std::span<const std::byte> bytes) {
    if (faces) {
      return faces_.write({reinterpret_cast<const Triangle*>(bytes.data()), bytes.size() / sizeof(Triangle)});
    }
    return positions_.write(bytes.data(), bytes.size());
  }
  Status put(bool faces, std::span<const std::byte> bytes) {
    if (!thread_.joinable()) return status_.is_ok() ? (status_ = write(faces, bytes)) : status_;
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return pending_.size() < kInFlight || !status_.is_ok(); });
    if (!status_.is_ok()) return status_;
    Item item{faces, {}};
    if (!free_.empty()) {
      item.bytes = std::move(free_.back());
      free_.pop_back();
    }
    item.bytes.assign(bytes.begin(), bytes.end());
    pending_.push_back(std::move(item));
    changed_.notify_all();
    return {};
  }
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      changed_.wait(lock, [&] { return !pending_.empty() || stopping_; });
      if (pending_.empty()) return;  // stopping, and everything is written
      Item item = std::move(pending_.front());
      pending_.pop_front();
      const bool write_it = status_.is_ok();
      lock.unlock();
      Status status = write_it ? write(item.faces, item.bytes) : Status{};
      lock.lock();
      if (!status.is_ok() && status_.is_ok()) status_ = status;
      free_.push_back(std::move(item.bytes));
      changed_.notify_all();
    }
  }
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }

  SpillWriter& positions_;
  FaceSpill& faces_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Item> pending_;
  std::vector<std::vector<std::byte>> free_;
  Status status_;  // the first write error (under mutex_ with a thread)
  bool stopping_ = false;
  std::thread thread_;  // last: starts once the rest is built (none without `background`)
};

// Positions of stripes in file 0 go to the spill thread, those in file 1 are written here, on
// the reader's thread: two threads copy into the page cache at once, each into its own file.
class IngestSink final : public format::MeshSink {
 public:
  // input_is_file: the input can be opened again by name, so its own vertex records (when the
  // reader says where they are) stand in for the position files.
  IngestSink(SpillThread& spills, SpillWriter& positions_here,
             const std::function<void(const char*, std::uint64_t, std::uint64_t)>& progress, bool input_is_file)
      : spills_(spills), positions_here_(positions_here), progress_(progress), input_is_file_(input_is_file) {}
  Status on_header(const format::MeshHeader& header) override {
    declared_faces_ = header.declared_faces.value_or(0);
    if (input_is_file_) raw_vertices_ = header.raw_vertices;
    return {};
  }
  // Where the input holds the positions, when no copy is written.
  const std::optional<format::MeshHeader::RawVertices>& raw_vertices() const { return raw_vertices_; }
  Status on_vertices(std::span<const Vec3f> batch) override {
    if (vertices_ + batch.size() > format::kMaxVertices) {
      return Status::error(Code::kResources, "", "more than " + std::to_string(format::kMaxVertices) +
                                                     " vertices: chunk records hold 32-bit vertex ids");
    }
    for (const Vec3f& p : batch) {
      const float c[3] = {p.x, p.y, p.z};
      for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(c[a])) continue;
        lo_[a] = std::min(lo_[a], c[a]);
        hi_[a] = std::max(hi_[a], c[a]);
      }
    }
    if (raw_vertices_) {
      vertices_ += batch.size();
      return {};
    }
    while (!batch.empty()) {
      const auto v = static_cast<std::uint32_t>(vertices_);  // below kMaxVertices (checked above)
      const std::size_t part = std::min<std::size_t>(batch.size(), kPositionStripeVertices - v % kPositionStripeVertices);
      const std::span<const Vec3f> stripe = batch.first(part);
      GM_RETURN_IF_ERROR(position_file(v) == 0 ? spills_.vertices(stripe)
                                               : positions_here_.write(stripe.data(), stripe.size_bytes()));
      vertices_ += part;
      batch = batch.subspan(part);
    }
    return {};
  }
  Status on_triangles(std::span<const Triangle> batch) override {
    faces_count_ += batch.size();
    if (progress_) progress_("ingest", faces_count_, std::max(declared_faces_, faces_count_));
    return spills_.triangles(batch);
  }
  std::uint64_t vertices() const { return vertices_; }
  std::uint64_t faces() const { return faces_count_; }
  void bounds(Vec3f& lo, Vec3f& hi) const {
    float l[3], h[3];
    for (int a = 0; a < 3; ++a) {
      const bool any = lo_[a] <= hi_[a];
      l[a] = any ? lo_[a] : 0;
      h[a] = any ? hi_[a] : 0;
    }
    lo = {l[0], l[1], l[2]};
    hi = {h[0], h[1], h[2]};
  }

 private:
  SpillThread& spills_;
  SpillWriter& positions_here_;
  const std::function<void(const char*, std::uint64_t, std::uint64_t)>& progress_;
  const bool input_is_file_;
  std::optional<format::MeshHeader::RawVertices> raw_vertices_;
  std::uint64_t vertices_ = 0, faces_count_ = 0;
  std::uint64_t declared_faces_ = 0;  // the header's count (polygons): untrusted, for progress only
  float lo_[3] = {INFINITY, INFINITY, INFINITY}, hi_[3] = {-INFINITY, -INFINITY, -INFINITY};
};

// ---- Sequential scans ----------------------------------------------------------------------------

// Closes a descriptor when it goes out of scope.
struct FdCloser {
  int fd;
  ~FdCloser() { ::close(fd); }
};

std::int64_t modified_ns(const struct stat& st) {
  return static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

// Opens the input to read its vertex records back; kBadInput when it is gone, or its size or
// modification time is not what the ingest saw.
Result<int> open_input_positions(const VertexFiles::InputPositions& in) {
  const int fd = ::open(in.path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::error(Code::kBadInput, in.path, "cannot open the input again to read its positions: " + errno_text());
  struct stat st{};
  if (::fstat(fd, &st) != 0 || static_cast<std::uint64_t>(st.st_size) != in.size || modified_ns(st) != in.modified_ns) {
    ::close(fd);
    return Status::error(Code::kBadInput, in.path, "the input changed during the run");
  }
  return fd;
}

// A position from one of the input's vertex records.
Vec3f input_position(const VertexFiles::InputPositions& in, const std::byte* record) {
  float c[3];
  for (int a = 0; a < 3; ++a) std::memcpy(&c[a], record + in.xyz[a], 4);
  return {c[0], c[1], c[2]};
}

// One batch of a position scan: `want` records of `stride` bytes from byte `offset` of fd, read
// piece by piece on the pieces' threads (pieces(n, fn) calls fn(begin, end) over [0, n)), each
// piece's records into `records` (or, bare x, y, z records, straight into `out`) and converted
// there, then piece(begin, end) runs on them. Until session 16 the batch was read whole before its
// pieces ran: the kernel's copy out of the page cache was each scan's serial part (the plan's
// scans at ~1.6 cores). A failed or short read is the first failing piece's `fail(offset, got)`.
template <class Pieces, class Piece, class Fail>
Status read_position_batch(int fd, std::uint64_t offset, std::size_t want, std::size_t stride, const VertexFiles::InputPositions* in,
                           std::byte* records, Vec3f* out, Pieces&& pieces, Piece&& piece, Fail&& fail) {
  std::mutex mutex;
  std::size_t failed_at = want;
  Status failed;
  pieces(want, [&](std::size_t begin, std::size_t end) {
    void* target = records != nullptr ? static_cast<void*>(records + begin * stride) : static_cast<void*>(out + begin);
    const std::uint64_t at = offset + begin * stride;
    const std::int64_t got = read_some(fd, target, (end - begin) * stride, at);
    if (got != static_cast<std::int64_t>((end - begin) * stride)) {
      std::lock_guard<std::mutex> lock(mutex);
      if (begin < failed_at) {
        failed_at = begin;
        failed = fail(at, got);
      }
      return;
    }
    if (records != nullptr)
      for (std::size_t i = begin; i < end; ++i) out[i] = input_position(*in, records + i * stride);
    piece(begin, end);
  });
  return failed;
}

// scan_positions from the input's own records: batches of at most 768 KiB of records.
template <class Pieces, class Piece, class Batch>
Status scan_input_positions(const VertexFiles::InputPositions& in, std::uint64_t expected, Pieces&& pieces, Piece&& piece,
                            Batch&& batch) {
  auto opened = open_input_positions(in);
  if (!opened) return opened.status();
  FdCloser closer{*opened};
  // Records of x, y, z alone are read straight into the positions.
  const bool bare = in.stride == sizeof(Vec3f) && in.xyz[0] == 0 && in.xyz[1] == 4 && in.xyz[2] == 8;
  // At most a stripe's vertices a batch, as from the position files (the owner pass's buffer
  // holds a stripe).
  const std::size_t per_batch = std::clamp<std::size_t>(kPositionStripeVertices * sizeof(Vec3f) / in.stride, 1, kPositionStripeVertices);
  std::unique_ptr<std::byte[]> records(bare ? nullptr : new std::byte[per_batch * in.stride]);
  std::unique_ptr<Vec3f[]> buffer(new Vec3f[per_batch]);
  for (std::uint64_t done = 0; done < expected;) {
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(per_batch, expected - done));
    const std::span<const Vec3f> positions(buffer.get(), want);
    GM_RETURN_IF_ERROR(read_position_batch(
        *opened, in.first_byte + done * in.stride, want, in.stride, &in, records.get(), buffer.get(), pieces,
        [&](std::size_t begin, std::size_t end) { piece(done, positions, begin, end); },
        [&](std::uint64_t at, std::int64_t got) {
          return Status::error(Code::kBadInput, in.path + ": byte " + std::to_string(at),
                               got < 0 ? "read failed: " + errno_text() : "the input changed during the run");
        }));
    GM_RETURN_IF_ERROR(batch(done, positions));
    done += want;
  }
  return {};
}

// Reads the positions of vertices 0 .. expected - 1 in order, a stripe (768 KiB) at a time
// from the two position files, or from the input's records (VertexFiles::input). Each batch is
// read and handled in pieces (pieces(n, fn), fn(begin, end)): piece(first_index, batch, begin,
// end) once its piece is read, then batch(first_index, batch) once all are. (A larger buffer,
// once freed, raises glibc's mmap threshold, and later buffers of that size come from the heap
// and stay resident: 4 MiB here raised the 10M run's peak by 2.6 MB.)
template <class Pieces, class Piece, class Batch>
Status scan_positions(const VertexFiles& files, std::uint64_t expected, Pieces&& pieces, Piece&& piece, Batch&& batch) {
  if (files.input) return scan_input_positions(*files.input, expected, pieces, piece, batch);
  int fds[kPositionFiles];
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) fds[i] = -1;
  struct Closer {
    int* fds;
    ~Closer() {
      for (std::uint32_t i = 0; i < kPositionFiles; ++i)
        if (fds[i] >= 0) ::close(fds[i]);
    }
  } closer{fds};
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) {
    fds[i] = ::open(files.positions[i].c_str(), O_RDONLY | O_CLOEXEC);
    if (fds[i] < 0) return Status::error(Code::kBadInput, files.positions[i], "cannot open temporary file: " + errno_text());
  }
  std::unique_ptr<Vec3f[]> buffer(new Vec3f[kPositionStripeVertices]);
  for (std::uint64_t done = 0; done < expected;) {
    const auto v = static_cast<std::uint32_t>(done);
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(kPositionStripeVertices, expected - done));
    const std::uint32_t file = position_file(v);
    const std::span<const Vec3f> positions(buffer.get(), want);
    GM_RETURN_IF_ERROR(read_position_batch(
        fds[file], position_record(v) * sizeof(Vec3f), want, sizeof(Vec3f), nullptr, nullptr, buffer.get(), pieces,
        [&](std::size_t begin, std::size_t end) { piece(done, positions, begin, end); },
        [&](std::uint64_t at, std::int64_t got) {
          return Status::error(Code::kBadInput, files.positions[file] + ": byte " + std::to_string(at),
                               got < 0 ? "read failed: " + errno_text() : "temporary file is shorter than written");
        }));
    GM_RETURN_IF_ERROR(batch(done, positions));
    done += want;
  }
  return {};
}

void remove_tree(const std::string& dir) {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// ---- Chunk output -------------------------------------------------------------------------------

// Records bound for a set of chunk writers, staged in one frame-sized buffer per chunk. A full
// buffer is one frame: compressed straight from the buffer (RecordWriter::append never copies a
// whole frame), inline or by `workers` compression threads fed through queues. Writer i belongs
// to worker i % workers, and the caller gives the writers of one worker one shared zstd context
// (write_chunks): a chunk's frames stay in order (one consumer per writer, FIFO) and no context
// is used by two threads. Memory: (chunks + spare) frames.
//
// Why several workers: when records carried positions (57 bytes), one compression thread bounded
// the pass (100M triangles under 64 MiB: ~6 GB of records; the scan ~14 s of CPU, compression
// ~22 s, the scan waiting for free buffers). With 21-byte records each of two threads uses ~4 s
// at 100M: compression stays off the scan's path.
class ChunkOutput {
 public:
  // Spare frames for the compression threads: enough that the scan seldom waits for one when
  // frames are small (many chunks per scan make every frame small).
  static std::size_t spare_frames(std::size_t chunks) { return std::max<std::size_t>(4, chunks / 8); }

  ChunkOutput(std::vector<std::unique_ptr<format::RecordWriter>>& writers, std::size_t frame_bytes, std::size_t workers)
      : writers_(writers), frame_bytes_(frame_bytes), jobs_(std::max<std::size_t>(workers, 1)) {
    const std::size_t spare = workers > 0 ? spare_frames(writers.size()) : 0;
    const std::size_t buffers = writers.size() + spare;
    wake_batch_ = std::clamp<std::size_t>(spare / (2 * std::max<std::size_t>(workers, 1)), 1, 16);
    arena_.reset(new std::byte[buffers * frame_bytes]);  // touched only as records arrive
    for (std::size_t i = 0; i < writers.size(); ++i) staged_.push_back({arena_.get() + i * frame_bytes, 0});
    for (std::size_t i = writers.size(); i < buffers; ++i) free_.push_back(arena_.get() + i * frame_bytes);
    wake_worker_ = std::make_unique<std::condition_variable[]>(jobs_.size());
    try {
      for (std::size_t w = 0; w < workers; ++w) workers_.emplace_back([this, w] { work(w); });
    } catch (const std::system_error&) {
      stop();  // no thread, or fewer than asked: compress inline (nothing was queued yet)
      stopping_ = false;
    }
  }
  ~ChunkOutput() { stop(); }

  // Room for one record of size bytes in chunk index i (0-based within the writers): the caller
  // writes the record there, then calls added(i, size). Writing fields straight into the frame
  // (not into a record that is then copied) keeps the scan clear of store-forwarding stalls: a
  // 16-byte load of a record just written by an 8- and a 12-byte store cost two thirds of the
  // scan's own time.
  std::byte* slot(std::size_t i) { return staged_[i].data + staged_[i].used; }
  void added(std::size_t i, std::size_t size) {
    Staged& s = staged_[i];
    s.used += size;
    if (s.used + size > frame_bytes_) submit(i);
  }
  bool failed() const { return failed_.load(std::memory_order_relaxed); }
  // Writes what is staged, waits for the compression threads, finishes every writer.
  Status finish() {
    stop();
    for (std::size_t i = 0; i < staged_.size() && status_.is_ok(); ++i) {
      if (staged_[i].used > 0) status_ = writers_[i]->append({staged_[i].data, staged_[i].used});
      staged_[i].used = 0;
    }
    for (auto& writer : writers_) {
      if (!status_.is_ok()) break;
      status_ = writer->finish();
    }
    return status_;
  }

 private:
  struct Staged {
    std::byte* data;
    std::size_t used;
  };
  struct Job {
    std::size_t writer;
    std::byte* data;
    std::size_t used;
  };

  void submit(std::size_t i) {
    Staged& s = staged_[i];
    if (workers_.empty()) {
      if (status_.is_ok()) status_ = writers_[i]->append({s.data, s.used});
      if (!status_.is_ok()) failed_ = true;
      s.used = 0;
      return;
    }
    const std::size_t w = i % workers_.size();
    std::unique_lock<std::mutex> lock(mutex_);
    jobs_[w].push_back({i, s.data, s.used});
    // A sleeping worker is woken once wake_batch_ frames wait for it (it then drains its queue),
    // not per frame: at 100M triangles the scan hands over ~440k frames of ~5 KB, and a futex
    // wake and a context switch per frame kept the scan thread 40 % idle. When no buffer is
    // free, every worker with work is woken before the scan waits.
    if (jobs_[w].size() >= wake_batch_) wake_worker_[w].notify_one();
    if (free_.empty()) {
      for (std::size_t v = 0; v < jobs_.size(); ++v)
        if (!jobs_[v].empty()) wake_worker_[v].notify_one();
    }
    buffer_free_.wait(lock, [&] { return !free_.empty(); });
    s.data = free_.back();
    s.used = 0;
    free_.pop_back();
  }
  void work(std::size_t w) {
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_worker_[w].wait(lock, [&] { return !jobs_[w].empty() || stopping_; });
        if (jobs_[w].empty()) return;
        job = jobs_[w].front();
        jobs_[w].pop_front();
      }
      Status status = failed() ? Status{} : writers_[job.writer]->append({job.data, job.used});
      std::lock_guard<std::mutex> lock(mutex_);
      if (!status.is_ok() && status_.is_ok()) {
        status_ = status;
        failed_ = true;
      }
      free_.push_back(job.data);
      buffer_free_.notify_one();
    }
  }
  void stop() {
    if (workers_.empty()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    for (std::size_t w = 0; w < jobs_.size(); ++w) wake_worker_[w].notify_one();
    for (std::thread& worker : workers_) worker.join();
    workers_.clear();
  }

  std::vector<std::unique_ptr<format::RecordWriter>>& writers_;
  const std::size_t frame_bytes_;
  std::size_t wake_batch_ = 1;  // frames queued for a sleeping worker before it is woken: half its share of the spare frames, 1 to 16
  std::unique_ptr<std::byte[]> arena_;
  std::vector<Staged> staged_;
  std::vector<std::byte*> free_;
  std::vector<std::deque<Job>> jobs_;  // one queue per worker
  std::mutex mutex_;
  std::unique_ptr<std::condition_variable[]> wake_worker_;
  std::condition_variable buffer_free_;
  std::vector<std::thread> workers_;
  bool stopping_ = false;
  std::atomic<bool> failed_{false};
  Status status_;  // first error (written by a worker under mutex_, read after stop())
};

// ---- Pass 1 -------------------------------------------------------------------------------------

// The chunk of p: its cell's, or for a split cell its sub-cell's (Partition::OwnerMap).
std::uint32_t owner_in(const Grid& grid, const std::vector<std::uint32_t>& cell_chunk,
                       const std::vector<Partition::SplitCell>& splits, const Vec3f& p) {
  const std::uint32_t cell = grid.cell(p);
  if (cell >= cell_chunk.size()) return 0;
  const std::uint32_t entry = cell_chunk[cell];
  if (!(entry & Partition::kSplitCell)) return entry;
  const std::uint32_t index = entry & ~Partition::kSplitCell;
  if (index >= splits.size()) return 0;
  const Partition::SplitCell& split = splits[index];
  const std::uint32_t code = grid.sub_code(p, split.k);
  return split.first + static_cast<std::uint32_t>(std::upper_bound(split.starts.begin(), split.starts.end(), code) -
                                                  split.starts.begin());
}

struct Planner {
  Grid grid;
  std::vector<std::uint32_t> cell_chunk;  // linear cell -> chunk, or kSplitCell | split
  std::vector<Partition::SplitCell> splits;
  std::uint32_t chunks = 0;
  std::vector<std::uint64_t> owned_vertices;
  std::uint32_t owner(const Vec3f& p) const { return owner_in(grid, cell_chunk, splits, p); }
};

static_assert(sizeof(Vec3f) == kPositionRecordBytes && sizeof(std::uint32_t) == kOwnerRecordBytes);

class PartitionRun {
 public:
  PartitionRun(const PartitionOptions& options, Partition& out) : options_(options), out_(out) {}
  Status run(const std::string& input_path, const format::ReadOptions& read);

 private:
  Status ingest(const std::string& input_path, const format::ReadOptions& read);
  Status plan();
  // Calls fn(face id, triangle, tag) for every face in order, tag = tag_of(triangle, windows)
  // (0 when tag_of is nullptr) computed first for each frame on the read-ahead thread (FaceWindows: owners.bin and, when
  // bitmap >= 0, that cache file, read through the windows; tag_of must not touch the cache).
  // After each frame, stops early when the cache or a window has failed or stop() says so.
  struct FaceWindows {
    FileWindow owners;
    std::optional<FileWindow> bitmap;
  };
  // `unknown` is the tag that tells fn to look the face up itself: the faces of frames whose
  // windows miss more than once per 256 faces get it (badly ordered input, where the cache may
  // still hold what the small windows cannot; see the tagger).
  // skip(frame), asked once per frame in order on the read-ahead thread (so it may read only
  // what no one writes during the scan), true: the frame is passed over undecompressed and fn
  // is not called for its faces (an earlier scan has checked them). begin(frame) is called on
  // this thread before the faces of each frame that is not skipped.
  template <class Tag, class Fn, class Stop>
  Status scan_faces(int bitmap, std::uint32_t unknown, Tag&& tag_of, Fn&& fn, Stop&& stop,
                    FrameReadAhead::Skip skip = [](std::size_t) { return false; },
                    const std::function<void(std::size_t)>& begin = [](std::size_t) {});
  std::size_t window_bytes() const;
  Status expand_rings();
  Status write_chunks();
  // Calls fn(begin, end) on pieces of [0, n), on the run's threads when there are several
  // (fn must be safe to run at once on disjoint pieces).
  template <class Fn>
  void for_pieces(std::size_t n, Fn&& fn);
  // Per-vertex counts over positions.bin: count(histogram, position) for every vertex, each
  // thread into its own array of `size` zeros, summed into the result.
  template <class Count>
  Result<std::vector<std::uint32_t>> count_positions(std::size_t size, Count&& count);

  const PartitionOptions& options_;
  const char* scan_pass_ = "rings";  // what scan_faces reports to options_.progress
  Partition& out_;
  std::shared_ptr<VertexFiles> vertex_files_;  // positions (pass 0) and owners (the owner pass)
  std::string faces_path_, owners_path_;
  Planner planner_;
  std::unique_ptr<BlockCache> cache_;
  std::unique_ptr<CachedArray<std::uint32_t>> owners_;  // owners.bin: the scans need only owners
  int owners_file_ = -1;                                 // its file in the cache (FaceWindows read it too)
  std::unique_ptr<ChunkSets> sets_;
  std::unique_ptr<CachedBitmap> has_extras_;
  std::unique_ptr<CachedBitmap> frontier_[2];
  std::uint64_t bytes_spilled_ = 0;
  std::unique_ptr<tbb::task_arena> arena_;  // the plan's scans with threads > 1
};

Status PartitionRun::ingest(const std::string& input_path, const format::ReadOptions& read) {
  vertex_files_ = std::make_shared<VertexFiles>();
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) vertex_files_->positions[i] = out_.dir + "/positions-" + std::to_string(i) + ".bin";
  faces_path_ = out_.dir + "/faces.gmr";
  SpillWriter positions[kPositionFiles];
  FaceSpill faces;
  for (std::uint32_t i = 0; i < kPositionFiles; ++i) GM_RETURN_IF_ERROR(positions[i].open(vertex_files_->positions[i], std::size_t{1} << 20));
  GM_RETURN_IF_ERROR(faces.open(faces_path_));
  SpillThread spills(positions[0], faces, options_.threads > 1);
  struct stat input{};
  const bool input_is_file = input_path != "-" && ::stat(input_path.c_str(), &input) == 0 && S_ISREG(input.st_mode);
  IngestSink sink(spills, positions[1], options_.progress, input_is_file);
  Status status = format::read_mesh_file(input_path, read, sink);
  // A write error stops the reader (the sink returns it) and is the run's error.
  if (Status written = spills.finish(); !written.is_ok()) return written;
  if (!status.is_ok()) {
    // A sink error has no place of its own: name the input.
    if (status.where().empty()) return Status::error(status.code(), input_path == "-" ? "<stdin>" : input_path, status.message());
    return status;
  }
  for (SpillWriter& p : positions) {
    GM_RETURN_IF_ERROR(p.close());
    bytes_spilled_ += p.bytes();
  }
  GM_RETURN_IF_ERROR(faces.close());
  if (const auto& raw = sink.raw_vertices()) {
    VertexFiles::InputPositions in;
    in.path = input_path;
    in.first_byte = raw->first_byte;
    in.stride = raw->stride;
    for (int a = 0; a < 3; ++a) in.xyz[a] = raw->xyz[a];
    in.size = static_cast<std::uint64_t>(input.st_size);  // as before the read: a change during it counts too
    in.modified_ns = modified_ns(input);
    if (in.first_byte + sink.vertices() * std::uint64_t{in.stride} > in.size)
      return Status::error(Code::kBadInput, input_path, "the input changed during the run");
    vertex_files_->input = std::move(in);
  }
  out_.vertices = sink.vertices();
  out_.faces = sink.faces();
  sink.bounds(out_.lo, out_.hi);
  bytes_spilled_ += faces.bytes();
  return {};
}

// The plan's scans of the positions compute per vertex (a cell, a sub-cell code, an owner) and
// run on the run's threads: at 100M triangles, five scans of 50M vertices took 2.8 s on one
// thread. Pieces are small enough that the tests' shapes take the threaded path.
constexpr std::size_t kPlanPieceVertices = std::size_t{1} << 13;

template <class Fn>
void PartitionRun::for_pieces(std::size_t n, Fn&& fn) {
  if (options_.threads <= 1 || n <= kPlanPieceVertices) {
    fn(std::size_t{0}, n);
    return;
  }
  if (!arena_) arena_ = std::make_unique<tbb::task_arena>(static_cast<int>(options_.threads));
  arena_->execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPlanPieceVertices),
                      [&](const tbb::blocked_range<std::size_t>& r) { fn(r.begin(), r.end()); });
  });
}

template <class Count>
Result<std::vector<std::uint32_t>> PartitionRun::count_positions(std::size_t size, Count&& count) {
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> local([size] { return std::vector<std::uint32_t>(size, 0); });
  GM_RETURN_IF_ERROR(scan_positions(
      *vertex_files_, out_.vertices, [&](std::size_t n, auto&& fn) { for_pieces(n, fn); },
      [&](std::uint64_t, std::span<const Vec3f> batch, std::size_t begin, std::size_t end) {
        std::uint32_t* histogram = local.local().data();
        for (std::size_t i = begin; i < end; ++i) count(histogram, batch[i]);
      },
      [](std::uint64_t, std::span<const Vec3f>) { return Status{}; }));
  // The first thread's counts become the sum (no copy more than the threads' own).
  std::vector<std::uint32_t> sum;
  for (std::vector<std::uint32_t>& part : local) {
    if (sum.empty()) {
      sum.swap(part);
      continue;
    }
    for (std::size_t i = 0; i < size; ++i) sum[i] += part[i];
  }
  if (sum.empty()) sum.assign(size, 0);  // no vertex: no thread counted
  return sum;
}

Status PartitionRun::plan() {
  Planner& p = planner_;
  p.grid = Grid::make(out_.lo, out_.hi);
  const std::size_t cells = p.grid.cells();
  auto counted = count_positions(cells, [&](std::uint32_t* histogram, const Vec3f& v) { ++histogram[p.grid.cell(v)]; });
  if (!counted) return counted.status();
  const std::vector<std::uint32_t> histogram = std::move(*counted);
  // Chunk size: faces per chunk from the budget, of which a chunk owns at most 3/4; vertices per
  // chunk from the input's vertex/face ratio.
  const std::uint64_t chunk_faces = options_.max_chunk_faces > 0
                                        ? options_.max_chunk_faces
                                        : std::max<std::uint64_t>(options_.memory_bytes / options_.threads / kChunkBytesPerFace, 1);
  const double owned_faces = std::max(0.75 * static_cast<double>(chunk_faces), 1.0);
  const double ratio = out_.faces > 0 ? static_cast<double>(out_.vertices) / static_cast<double>(out_.faces) : 1.0;
  const std::uint64_t target = std::max<std::uint64_t>(static_cast<std::uint64_t>(std::ceil(owned_faces * ratio)), 1);
  // Split cells: a cell with more than a quarter of a chunk's vertices (dense input: the cells'
  // size is fixed, so their counts grow with the input) gets 8^k sub-cells, k the least that
  // brings a surface's share of it (a quarter per level) to an eighth of a chunk, at most
  // kMaxSplitBits; one more scan of positions.bin counts their vertices. Without this the
  // largest chunk grew with the input (100M triangles under 64M: a cell of 66k vertices, twice
  // a chunk; the largest chunk owned 2.2 chunks' vertices, 1.23 with split cells).
  // A cell whose vertices gather in a small part of it (a cluster, not a surface across the
  // cell) leaves sub-cells above a quarter of a chunk: its k goes up by two and the sub-cells are
  // counted again, at most twice. The sub-cell counts stay within an eighth of the budget: k is
  // capped lower when many cells are dense, and not raised past it.
  auto dense = [&](std::uint32_t vertices) { return vertices > target / 4 && vertices >= 2; };
  auto split_bits = [&](std::uint32_t vertices, std::uint32_t cap) {
    std::uint32_t k = 1;
    while (k < cap && (vertices >> (2 * k)) > target / 8) ++k;
    return k;
  };
  const std::uint64_t max_entries = options_.memory_bytes / 8 / sizeof(std::uint32_t);
  std::uint32_t cap = kMaxSplitBits;
  for (;; --cap) {
    std::uint64_t entries = 0;
    for (std::uint32_t c = 0; c < cells; ++c)
      if (dense(histogram[c])) entries += std::uint64_t{1} << (3 * split_bits(histogram[c], cap));
    if (cap == 1 || entries <= max_entries) break;
  }
  p.cell_chunk.assign(cells, 0);
  for (std::uint32_t c = 0; c < cells; ++c) {
    if (!dense(histogram[c])) continue;
    p.cell_chunk[c] = Partition::kSplitCell | static_cast<std::uint32_t>(p.splits.size());
    p.splits.push_back({split_bits(histogram[c], cap), 0, {}});
  }
  // Each scan counts a split cell's sub-cells two levels finer than its k where the budget
  // allows (cells in order, while the counts fit), and the counts at k are their sums (a code at
  // k is the top bits of its sub-cells' codes at k + 2: floor(t * 2^(k+2)) >> 2 is floor(t * 2^k)).
  // A cell whose k is raised then has its counts already: the rounds decide as if each counted
  // at k, and scan again only for a cell raised past what it counted. At 100M under 64M one of
  // 697 split cells was raised, and a whole scan of the positions counted it again.
  std::vector<std::uint32_t> split_offset, sub_histogram, counted_bits, counted_offset, fine;
  bool scan = true;
  for (int round = 0; !p.splits.empty(); ++round) {
    if (scan) {
      counted_bits.clear();
      std::uint64_t entries = 0;
      for (const Partition::SplitCell& split : p.splits) entries += std::uint64_t{1} << (3 * split.k);
      for (const Partition::SplitCell& split : p.splits) {
        const std::uint32_t finer = std::min(split.k + 2, kMaxSplitBits);
        const std::uint64_t more = (std::uint64_t{1} << (3 * finer)) - (std::uint64_t{1} << (3 * split.k));
        const bool fits = entries + more <= max_entries;
        entries += fits ? more : 0;
        counted_bits.push_back(fits ? finer : split.k);
      }
      counted_offset.assign(1, 0);
      for (std::uint32_t bits : counted_bits) counted_offset.push_back(counted_offset.back() + (1u << (3 * bits)));
      auto sub_counted = count_positions(counted_offset.back(), [&](std::uint32_t* sub, const Vec3f& v) {
        const std::uint32_t entry = p.cell_chunk[p.grid.cell(v)];
        if (!(entry & Partition::kSplitCell)) return;
        const std::uint32_t index = entry & ~Partition::kSplitCell;
        ++sub[counted_offset[index] + p.grid.sub_code(v, counted_bits[index])];
      });
      if (!sub_counted) return sub_counted.status();
      fine = std::move(*sub_counted);
    }
    split_offset.assign(1, 0);
    for (const Partition::SplitCell& split : p.splits) split_offset.push_back(split_offset.back() + (1u << (3 * split.k)));
    sub_histogram.assign(split_offset.back(), 0);
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      const std::uint32_t shift = 3 * (counted_bits[i] - p.splits[i].k);
      for (std::uint32_t code = 0; code < (1u << (3 * counted_bits[i])); ++code)
        sub_histogram[split_offset[i] + (code >> shift)] += fine[counted_offset[i] + code];
    }
    if (round == 2) break;
    std::vector<std::uint32_t> raised(p.splits.size());
    std::uint64_t entries = 0;
    bool any_raised = false;
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      const std::uint32_t* first = sub_histogram.data() + split_offset[i];
      const std::uint32_t* last = sub_histogram.data() + split_offset[i + 1];
      const std::uint32_t heaviest = *std::max_element(first, last);
      raised[i] = heaviest > target / 4 ? std::min(p.splits[i].k + 2, kMaxSplitBits) : p.splits[i].k;
      any_raised |= raised[i] != p.splits[i].k;
      entries += std::uint64_t{1} << (3 * raised[i]);
    }
    if (!any_raised || entries > max_entries) break;
    scan = false;
    for (std::size_t i = 0; i < p.splits.size(); ++i) {
      p.splits[i].k = raised[i];
      scan |= raised[i] > counted_bits[i];
    }
  }
  std::vector<std::uint32_t>().swap(fine);
  // Cells in Morton order (a split cell's sub-cells in theirs); cell of Morton code m is order[m].
  std::vector<std::uint32_t> order(cells);
  for (std::uint32_t c = 0; c < cells; ++c) order[p.grid.morton(c)] = c;
  // Cells fill chunks greedily in Morton order: a cell that would take the current chunk past
  // the target starts the next one, so no chunk owns more than the target unless one cell
  // alone does (the chunk passes' memory follows the largest chunk, not the mean).
  std::uint32_t chunk = 0;
  bool any = false;
  auto count = [&](std::uint32_t vertices) {
    if (vertices == 0) return;
    const bool full = any && p.owned_vertices[chunk] + vertices > target;
    if (full) ++chunk;
    if (!any || full) p.owned_vertices.push_back(0);
    any = true;
    p.owned_vertices[chunk] += vertices;
  };
  for (std::uint32_t c : order) {
    if (!(p.cell_chunk[c] & Partition::kSplitCell)) {
      count(histogram[c]);
      p.cell_chunk[c] = chunk;
      continue;
    }
    const std::uint32_t index = p.cell_chunk[c] & ~Partition::kSplitCell;
    Partition::SplitCell& split = p.splits[index];
    const std::uint32_t* sub = sub_histogram.data() + split_offset[index];
    for (std::uint32_t code = 0; code < (1u << (3 * split.k)); ++code) {
      const std::uint32_t was = chunk;
      count(sub[code]);
      if (code == 0) split.first = chunk;
      else if (chunk != was) split.starts.push_back(code);
    }
  }
  p.chunks = any ? chunk + 1 : 0;
  // Owner pass: the owning chunk per vertex, so that no later scan recomputes cells. The scans
  // read owners only (4 bytes a vertex through the cache); positions.bin stays for load_chunk.
  owners_path_ = out_.dir + "/owners.bin";
  vertex_files_->owners = owners_path_;
  // The writes go to a thread of their own (session 17): copying 200 MB into the page cache at
  // 100M took the scan's thread 0.4-0.5 s while the other core idled; now the next stripe's
  // owners are computed meanwhile.
  SpillWriter owners;
  GM_RETURN_IF_ERROR(owners.open(owners_path_, std::size_t{1} << 20));
  FaceSpill no_faces;
  SpillThread owner_writes(owners, no_faces, options_.threads > 1);
  std::vector<std::uint32_t> records;
  records.resize(kPositionStripeVertices);
  GM_RETURN_IF_ERROR(scan_positions(
      *vertex_files_, out_.vertices, [&](std::size_t n, auto&& fn) { for_pieces(n, fn); },
      [&](std::uint64_t, std::span<const Vec3f> batch, std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) records[i] = p.owner(batch[i]);
      },
      [&](std::uint64_t, std::span<const Vec3f> batch) {
        return owner_writes.bytes(std::as_bytes(std::span(records.data(), batch.size())));
      }));
  GM_RETURN_IF_ERROR(owner_writes.finish());
  GM_RETURN_IF_ERROR(owners.close());
  bytes_spilled_ += owners.bytes();
  // The cell table stays with the partition for owner_of.
  for (int a = 0; a < 3; ++a) {
    out_.owner_map.lo[a] = p.grid.lo[a];
    out_.owner_map.scale[a] = p.grid.scale[a];
    out_.owner_map.n[a] = p.grid.n[a];
  }
  out_.owner_map.cell_chunk = std::move(p.cell_chunk);
  out_.owner_map.splits = std::move(p.splits);
  return {};
}

// The scans' two windows (owners, a bitmap), taken from the cache's half of the budget: 1 MiB
// each at 64M.
std::size_t PartitionRun::window_bytes() const {
  return std::clamp<std::size_t>(options_.memory_bytes / 64, std::size_t{16} << 10, std::size_t{1} << 20);
}

template <class Tag, class Fn, class Stop>
Status PartitionRun::scan_faces(int bitmap, std::uint32_t unknown, Tag&& tag_of, Fn&& fn, Stop&& stop, FrameReadAhead::Skip skip,
                                const std::function<void(std::size_t)>& begin) {
  const std::uint64_t nv = out_.vertices;
  auto reader = format::RecordReader::open(faces_path_, kFaceSpillRecordKind, sizeof(Triangle));
  if (!reader) return reader.status();
  if ((*reader)->records() != out_.faces) {
    return Status::error(Code::kBadInput, faces_path_, "holds " + std::to_string((*reader)->records()) + " faces, ingest wrote " +
                                                          std::to_string(out_.faces) + " (temporary file damaged)");
  }
  // tag_of == nullptr: no tags, no windows; fn gets 0.
  constexpr bool kTags = !std::is_same_v<std::decay_t<Tag>, std::nullptr_t>;
  std::optional<FaceWindows> tag_windows;
  if constexpr (kTags) {
    tag_windows.emplace(FaceWindows{FileWindow(cache_->fd(owners_file_), window_bytes()), std::nullopt});
    if (bitmap >= 0) tag_windows->bitmap.emplace(cache_->fd(bitmap), window_bytes());
  }
  const std::string bitmap_path = bitmap >= 0 ? cache_->path(bitmap) : std::string();
  // Frames are read, decompressed and tagged one ahead on another thread: the scan's thread is
  // the partition's bottleneck, and the tags take its owner and bitmap lookups for most faces.
  // A window miss is a pread (a few µs); a face costs tens of ns. A frame may miss about once per
  // 256 faces; past that, the rest of the frame goes untagged (the scan's thread looks through the
  // cache, which may still hold the file) and so do the next 1, 2, 4 ... 64 frames, doubling while
  // frames keep missing. Disorder is often local (a stretch of the input that jumps about the
  // ids: at 100M one frame in 42 did), and a switch that stayed off for the rest of the scan
  // left the scan's thread every lookup of the round; on ids shuffled throughout, the windows
  // are read for one frame in 64.
  constexpr std::uint64_t kWindowMissFaces = 256, kTagSlice = 1024, kMaxBackOff = 64;
  std::uint64_t untagged = 0, back_off = 0, pass_over = 0;  // the tagger's; read once its thread is joined
  struct CountUntagged {  // destroyed after the read-ahead below
    const std::uint64_t& frames;
    std::uint64_t& count;
    ~CountUntagged() { count += frames; }
  } count_untagged{untagged, out_.untagged_frames};
  FrameReadAhead::Tagger tagger;
  if constexpr (kTags) tagger = [&](const std::vector<Triangle>& faces, std::vector<std::uint32_t>& tags) -> Status {
    FaceWindows& windows = *tag_windows;
    auto misses = [&] { return windows.owners.misses() + (windows.bitmap ? windows.bitmap->misses() : 0); };
    std::size_t tagged = 0;
    if (pass_over > 0) {
      --pass_over;
    } else {
      const std::uint64_t before = misses();
      bool missing = false;
      while (tagged < faces.size() && !missing) {
        const std::size_t end = std::min(faces.size(), tagged + kTagSlice);
        for (; tagged < end; ++tagged) tags[tagged] = tag_of(faces[tagged], windows);
        missing = (misses() - before) * kWindowMissFaces > tagged + kWindowMissFaces;
      }
      back_off = missing ? std::clamp<std::uint64_t>(2 * back_off, 1, kMaxBackOff) : 0;
      pass_over = back_off;
    }
    if (tagged < faces.size()) {
      ++untagged;
      std::fill(tags.begin() + static_cast<std::ptrdiff_t>(tagged), tags.end(), unknown);
    }
    if (!windows.owners.error().empty()) return Status::error(Code::kOutput, owners_path_, "read failed: " + windows.owners.error());
    if (windows.bitmap && !windows.bitmap->error().empty())
      return Status::error(Code::kOutput, bitmap_path, "read failed: " + windows.bitmap->error());
    return {};
  };
  FrameReadAhead ahead(**reader, std::move(tagger), std::move(skip), options_.threads > 1);
  std::vector<Triangle> batch;
  std::vector<std::uint32_t> tags;
  std::uint64_t first = 0;
  for (std::size_t frame = 0;; ++frame) {
    std::uint64_t skipped = 0;
    GM_RETURN_IF_ERROR(ahead.next(batch, tags, skipped));
    if (batch.empty() && skipped == 0) return {};
    if (skipped > 0) {
      first += skipped;
      continue;
    }
    begin(frame);
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const Triangle& t = batch[i];
      if (t.v[0] >= nv || t.v[1] >= nv || t.v[2] >= nv) {
        return Status::error(Code::kBadInput, faces_path_,
                             "face " + std::to_string(first + i) + " refers to a vertex out of range (temporary file damaged)");
      }
      fn(first + i, t, kTags ? tags[i] : 0u);
    }
    first += batch.size();
    if (options_.progress) options_.progress(scan_pass_, first, out_.faces);
    if (stop()) return Status::error(Code::kOutput, out_.dir, "stopped");
    GM_RETURN_IF_ERROR(cache_->status());
  }
}

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
    // Tag 1: a face the round must look at. Round 1: its corners' owners differ (at 100M, 4 %
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

std::string chunk_file_path(const std::string& dir, std::uint32_t chunk) {
  char name[32];
  std::snprintf(name, sizeof name, "/chunk-%06u.gmr", chunk);
  return dir + name;
}

// Creates the chunk files, empty, on a thread of its own while the ring rounds run: a create
// cost ~0.35 ms on this machine's ext4 (inode allocation), 0.5 s of the final scan's thread at
// 100M (1,474 chunks) when its writers made them. The writers open them with O_TRUNC later; a
// create that fails here is left to the writer to report.
class ChunkFileMaker {
 public:
  ChunkFileMaker(const std::string& dir, std::uint32_t chunks, bool background) {
    if (!background) return;
    thread_ = std::thread([this, dir, chunks] {
      for (std::uint32_t c = 0; c < chunks && !stop_.load(std::memory_order_relaxed); ++c) {
        const int fd = ::open(chunk_file_path(dir, c).c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
        if (fd >= 0) ::close(fd);
      }
    });
  }
  ~ChunkFileMaker() { finish(true); }
  ChunkFileMaker(const ChunkFileMaker&) = delete;
  ChunkFileMaker& operator=(const ChunkFileMaker&) = delete;
  // Waits for the thread (stopping it first when `stop`).
  void finish(bool stop = false) {
    if (!thread_.joinable()) return;
    if (stop) stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

Status PartitionRun::write_chunks() {
  const std::uint32_t chunks = planner_.chunks;
  out_.chunks.resize(chunks);
  for (std::uint32_t c = 0; c < chunks; ++c) {
    ChunkInfo& info = out_.chunks[c];
    info.id = c;
    info.owned_vertices = planner_.owned_vertices[c];
    info.path = chunk_file_path(out_.dir, c);
    info.vertex_files = vertex_files_;
  }
  if (chunks == 0) return {};
  // Staged frames share memory_bytes / 8, and what the block cache left of its half, up to
  // another eighth: the cache then grows no further than the rest, so the two stay within 5/8 of
  // the budget as before. Frames of at least 64 records; more chunks than fit are written in
  // several scans. With threads > 1, `threads` threads compress (ChunkOutput). Spatially ordered
  // input leaves the cache small (100M under 64M: 3.75 MiB of 32), and twice the staged bytes
  // (frames of ~19 KB instead of ~9.7 KB at 768 chunks) made the final scan 0.4-1.0 s faster
  // there and the chunk files 15 % smaller (session 16).
  const bool background = options_.threads > 1;
  const std::size_t workers = background ? options_.threads : 0;
  const std::uint64_t memory = options_.memory_bytes;
  const std::size_t writer_budget = static_cast<std::size_t>(
      std::min<std::uint64_t>(memory / 4, memory / 2 + memory / 8 - std::min<std::uint64_t>(cache_->bytes(), memory / 2)));
  cache_->limit(memory / 2 + memory / 8 - writer_budget);
  // Frames of at least 64 records when one scan holds every chunk. When it cannot, of at least
  // 256: later scans pass over the frames of faces they do not need (frame_chunks below), so
  // more, smaller groups cost little, and frames of 64 records (1.3 KB) made the 100M run under
  // 16M compress and write 1.8M frames.
  std::size_t min_frame = 0, spare = 0, per_scan = 0;
  auto fit = [&](std::size_t records) {
    min_frame = records * kChunkFaceRecordBytes;
    spare = background ? ChunkOutput::spare_frames(0) : 0;
    per_scan = std::max<std::size_t>(writer_budget / min_frame, spare + 1) - spare;
    if (options_.max_open_chunks > 0) per_scan = std::min<std::size_t>(per_scan, options_.max_open_chunks);
    per_scan = std::min<std::size_t>(per_scan, chunks);
    if (background) {
      spare = ChunkOutput::spare_frames(per_scan);
      while (per_scan > 1 && (per_scan + spare) * min_frame > writer_budget) spare = ChunkOutput::spare_frames(--per_scan);
    }
  };
  fit(64);
  if (per_scan < chunks) fit(256);
  std::size_t frame_bytes = std::clamp(writer_budget / (per_scan + spare), min_frame, std::size_t{1} << 20);
  frame_bytes -= frame_bytes % kChunkFaceRecordBytes;
  // One zstd context per compression thread, shared by the writers that thread serves.
  std::vector<std::unique_ptr<format::RecordCompressor>> compressors;
  for (std::size_t w = 0; w < std::max<std::size_t>(workers, 1); ++w) {
    auto compressor = format::RecordCompressor::create(options_.compression_level);
    if (!compressor) return compressor.status();
    compressors.push_back(std::move(*compressor));
  }
  format::RecordWriterOptions writer_options;
  writer_options.frame_bytes = frame_bytes;
  // Face id and vertex ids as differences from the previous record's, column by column.
  writer_options.columns = {{8, true}, {4, true}, {4, true}, {4, true}, {1, false}};
  // Writers keep their file open between frames when the descriptors fit well under the
  // process's limit; else each frame reopens its file (an open and a close per frame).
  rlimit files{};
  const std::uint64_t fd_limit = ::getrlimit(RLIMIT_NOFILE, &files) == 0 ? files.rlim_cur : 1024;
  writer_options.keep_open = per_scan <= 128 || per_scan + 256 <= fd_limit / 2;

  std::vector<std::unique_ptr<format::RecordWriter>> writers;
  std::vector<std::uint32_t> set;
  // With several scans (more chunks than the staged frames allow: 100M under 16M, 8,103 chunks,
  // six scans), the first records each face frame's lowest and highest chunk, and a later scan
  // skips the frames that send nothing to its group: faces are in input order, chunks in Morton
  // order, so on spatially ordered input a group's faces lie in a few runs of frames. 8 bytes a
  // frame of ~87k faces.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> frame_chunks;
  const bool several_scans = per_scan < chunks;
  if (options_.rings > 1) cache_->flush(has_extras_->file());  // the tags read it through a window
  for (std::uint32_t first = 0; first < chunks; first += static_cast<std::uint32_t>(per_scan)) {
    const std::uint32_t last = static_cast<std::uint32_t>(std::min<std::size_t>(first + per_scan, chunks));
    writers.clear();
    for (std::uint32_t c = first; c < last; ++c) {
      writer_options.shared = compressors[(c - first) % compressors.size()].get();
      auto writer = format::RecordWriter::create(out_.chunks[c].path, kChunkFaceRecordKind, kChunkFaceRecordBytes, writer_options);
      if (!writer) return writer.status();
      writers.push_back(std::move(*writer));
    }
    ChunkOutput output(writers, frame_bytes, workers);
    bool damaged = false;
    auto emit = [&](std::uint64_t f, const Triangle& t, std::uint32_t c, std::uint8_t flags) {
      std::byte* record = output.slot(c - first);
      std::memcpy(record, &f, 8);
      std::memcpy(record + 8, t.v, 12);
      record[20] = std::byte{flags};
      output.added(c - first, kChunkFaceRecordBytes);
      ChunkInfo& info = out_.chunks[c];
      ++info.faces;
      info.owned_faces += (flags & kOwnsFace) != 0;
    };
    // Tags: chunk + 1 for a face whose corners one chunk owns and no other chunk's rings hold
    // (most faces: all but the chunks' overlaps), which goes to that chunk alone and needs no
    // lookup here; 0 for the others and for untagged frames. The read-ahead thread reads the three owners and the three
    // has-extras bits through its windows.
    const bool rings = options_.rings > 1;
    auto tag_of = [&](const Triangle& t, FaceWindows& w) -> std::uint32_t {
      const std::uint32_t o = w.owners.u32(t.v[0]);
      if (w.owners.u32(t.v[1]) != o || w.owners.u32(t.v[2]) != o || o >= chunks) return 0;
      if (rings && (w.bitmap->bit(t.v[0]) || w.bitmap->bit(t.v[1]) || w.bitmap->bit(t.v[2]))) return 0;
      return o + 1;
    };
    const bool record_frames = several_scans && first == 0;
    std::size_t frame = 0;
    auto skip_frame = [&frame_chunks, record_frames, first, last](std::size_t k) {
      if (record_frames) return false;
      return k < frame_chunks.size() && (frame_chunks[k].second < first || frame_chunks[k].first >= last);
    };
    auto begin_frame = [&](std::size_t k) {
      frame = k;
      if (record_frames) frame_chunks.emplace_back(~std::uint32_t{0}, 0);
    };
    auto went_to = [&](std::uint32_t lowest, std::uint32_t highest) {
      if (!record_frames) return;
      auto& [lo, hi] = frame_chunks[frame];
      lo = std::min(lo, lowest);
      hi = std::max(hi, highest);
    };
    Status scanned = scan_faces(rings ? has_extras_->file() : -1, 0, tag_of, [&](std::uint64_t f, const Triangle& t, std::uint32_t tag) {
      if (tag != 0) {
        const std::uint32_t c = tag - 1;
        went_to(c, c);
        if (c >= first && c < last) emit(f, t, c, static_cast<std::uint8_t>(7 | kOwnsFace));
        return;
      }
      std::uint32_t owner[3];
      bool extras[3] = {false, false, false};
      for (int j = 0; j < 3; ++j) owner[j] = owners_->get(t.v[j]);
      if (rings)
        for (int j = 0; j < 3; ++j) extras[j] = has_extras_->test(t.v[j]);
      int lowest = 0;
      for (int j = 1; j < 3; ++j)
        if (t.v[j] < t.v[lowest]) lowest = j;
      const std::uint32_t face_owner = owner[lowest];
      if (owner[0] >= chunks || owner[1] >= chunks || owner[2] >= chunks) damaged = true;
      auto emit_to = [&](std::uint32_t c) {
        std::uint8_t flags = 0;
        for (int j = 0; j < 3; ++j) flags |= static_cast<std::uint8_t>(owner[j] == c) << j;
        if (face_owner == c) flags |= kOwnsFace;
        emit(f, t, c, flags);
      };
      // Most faces: one owner, no vertex in another chunk's rings.
      if (!extras[0] && !extras[1] && !extras[2] && owner[0] == owner[1] && owner[1] == owner[2]) {
        went_to(owner[0], owner[0]);
        if (owner[0] >= first && owner[0] < last) emit_to(owner[0]);
        return;
      }
      set.assign(owner, owner + 3);
      for (int j = 0; j < 3; ++j)
        if (extras[j]) sets_->for_each(t.v[j], [&](std::uint32_t e) { set.push_back(entry_chunk(e)); });
      std::sort(set.begin(), set.end());
      set.erase(std::unique(set.begin(), set.end()), set.end());
      if (set.back() >= chunks) damaged = true;
      went_to(set.front(), set.back());
      for (std::uint32_t c : set)
        if (c >= first && c < last) emit_to(c);
    }, [&] { return output.failed(); }, skip_frame, begin_frame);
    if (output.failed()) return output.finish();  // the writer's own error
    GM_RETURN_IF_ERROR(scanned);
    if (damaged) return Status::error(Code::kBadInput, out_.dir, "a temporary file names a chunk that does not exist (damaged)");
    GM_RETURN_IF_ERROR(output.finish());
    for (auto& writer : writers) bytes_spilled_ += writer->bytes_written();
  }
  // Every face and every vertex has exactly one owner.
  std::uint64_t owned_faces = 0, owned_vertices = 0;
  for (const ChunkInfo& info : out_.chunks) {
    owned_faces += info.owned_faces;
    owned_vertices += info.owned_vertices;
  }
  if (owned_faces != out_.faces || owned_vertices != out_.vertices) {
    return Status::error(Code::kProcessing, out_.dir,
                         "ownership does not add up: " + std::to_string(owned_faces) + " of " + std::to_string(out_.faces) +
                             " faces, " + std::to_string(owned_vertices) + " of " + std::to_string(out_.vertices) + " vertices");
  }
  return {};
}

Status PartitionRun::run(const std::string& input_path, const format::ReadOptions& read) {
  auto start = std::chrono::steady_clock::now();
  GM_RETURN_IF_ERROR(ingest(input_path, read));
  out_.seconds_ingest = seconds_since(start);
  start = std::chrono::steady_clock::now();
  GM_RETURN_IF_ERROR(plan());
  out_.steps.plan = seconds_since(start);
  auto step = std::chrono::steady_clock::now();
  // Half the budget caches vertex-indexed data; an eighth holds chunk writers' frames; the
  // rest is the scan buffer, the cell tables and the zstd context.
  // The scans' two windows come out of the cache's half.
  cache_ = std::make_unique<BlockCache>(options_.memory_bytes / 2 - 2 * window_bytes());
  auto owners = cache_->open_file(owners_path_);
  if (!owners) return owners.status();
  owners_ = std::make_unique<CachedArray<std::uint32_t>>(*cache_, *owners);
  owners_file_ = *owners;
  ChunkFileMaker maker(out_.dir, planner_.chunks, options_.threads > 1);
  if (options_.rings > 1) {
    auto index = cache_->add_file(out_.dir + "/set-index.bin");
    auto slots = cache_->add_file(out_.dir + "/sets.bin");
    auto nodes = cache_->add_file(out_.dir + "/set-nodes.bin");
    auto extras = cache_->add_file(out_.dir + "/has-extras.bin");
    auto f0 = cache_->add_file(out_.dir + "/frontier-0.bin");
    auto f1 = cache_->add_file(out_.dir + "/frontier-1.bin");
    for (const auto* r : {&index, &slots, &nodes, &extras, &f0, &f1})
      if (!*r) return r->status();
    sets_ = std::make_unique<ChunkSets>(*cache_, *index, *slots, *nodes);
    has_extras_ = std::make_unique<CachedBitmap>(*cache_, *extras);
    frontier_[0] = std::make_unique<CachedBitmap>(*cache_, *f0);
    frontier_[1] = std::make_unique<CachedBitmap>(*cache_, *f1);
    GM_RETURN_IF_ERROR(expand_rings());
  }
  out_.steps.rings = seconds_since(step);
  step = std::chrono::steady_clock::now();
  scan_pass_ = "chunks";
  maker.finish();
  GM_RETURN_IF_ERROR(write_chunks());
  GM_RETURN_IF_ERROR(cache_->status());
  out_.bytes_spilled = bytes_spilled_ + cache_->bytes_written();
  out_.cache_misses = cache_->misses();
  out_.cache_bytes = cache_->bytes();
  cache_.reset();
  // The face spill is no longer needed; the chunk files and the vertex files (load_chunk reads
  // positions and owners from them) stay until the Partition goes.
  ::unlink(faces_path_.c_str());
  for (const char* name : {"/set-index.bin", "/sets.bin", "/set-nodes.bin", "/has-extras.bin", "/frontier-0.bin", "/frontier-1.bin"}) {
    ::unlink((out_.dir + name).c_str());
  }
  out_.steps.chunks = seconds_since(step);
  out_.seconds_partition = seconds_since(start);
  return {};
}

}  // namespace

// ---- Partition ------------------------------------------------------------------------------------

Partition::~Partition() { remove_temp(); }

Partition::Partition(Partition&& other) noexcept { *this = std::move(other); }

Partition& Partition::operator=(Partition&& other) noexcept {
  if (this == &other) return *this;
  remove_temp();
  dir = std::move(other.dir);
  vertices = other.vertices;
  faces = other.faces;
  lo = other.lo;
  hi = other.hi;
  chunks = std::move(other.chunks);
  bytes_spilled = other.bytes_spilled;
  cache_misses = other.cache_misses;
  cache_bytes = other.cache_bytes;
  untagged_frames = other.untagged_frames;
  seconds_ingest = other.seconds_ingest;
  seconds_partition = other.seconds_partition;
  steps = other.steps;
  temp_slot = other.temp_slot;
  owner_map = std::move(other.owner_map);
  other.dir.clear();
  other.temp_slot = -1;
  return *this;
}

std::uint32_t Partition::owner_of(const Vec3f& p) const {
  if (owner_map.cell_chunk.empty()) return 0;
  Grid grid;
  for (int a = 0; a < 3; ++a) {
    grid.lo[a] = owner_map.lo[a];
    grid.scale[a] = owner_map.scale[a];
    grid.n[a] = owner_map.n[a];
  }
  return owner_in(grid, owner_map.cell_chunk, owner_map.splits, p);
}

void Partition::remove_temp() {
  if (!dir.empty()) remove_tree(dir);
  if (temp_slot >= 0) format::unregister_temp_path(temp_slot);
  dir.clear();
  temp_slot = -1;
}

format::Result<Partition> partition_mesh(const std::string& input_path, const format::ReadOptions& read,
                                         const PartitionOptions& options) {
  if (options.rings < 1 || options.rings > kMaxPartitionRings) {
    return Status::error(Code::kUsage, "", "overlap rings must be 1.." + std::to_string(kMaxPartitionRings) + ", not " +
                                               std::to_string(options.rings));
  }
  if (options.memory_bytes < kMinPartitionMemory) {
    return Status::error(Code::kUsage, "", "memory budget of " + std::to_string(options.memory_bytes) +
                                               " bytes is below the minimum of 16 MiB");
  }
  if (options.threads < 1) return Status::error(Code::kUsage, "", "threads must be at least 1");
  std::string parent = options.tmp_dir;
  if (parent.empty()) {
    const char* env = std::getenv("TMPDIR");
    parent = env != nullptr && *env != '\0' ? env : "/tmp";
  }
  std::string pattern = parent + "/gaussmesh-partition-XXXXXX";
  if (::mkdtemp(pattern.data()) == nullptr) {
    return Status::error(Code::kOutput, parent, "cannot create a temporary directory: " + errno_text());
  }
  Partition partition;
  partition.dir = pattern;
  partition.temp_slot = format::register_temp_path(partition.dir, true);
  PartitionRun run(options, partition);
  GM_RETURN_IF_ERROR(run.run(input_path, read));
  return partition;
}

// ---- Reading a chunk back --------------------------------------------------------------------------

namespace {

// (global id << 32 | corner) for every corner, sorted: an LSD radix sort on the id's offset from
// the chunk's lowest id, 11 bits a pass — stable, so corners of one id stay in order. A chunk's ids
// span a small range on spatially ordered input (one or two passes); std::sort took a seventh of
// pass 2's time.
std::vector<std::uint64_t> sorted_corner_keys(std::span<const std::uint32_t> ids) {
  const std::size_t n = ids.size();
  std::vector<std::uint64_t> keys(n), scratch(n);
  if (n == 0) return keys;
  const auto [lo_it, hi_it] = std::minmax_element(ids.begin(), ids.end());
  const std::uint32_t lo = *lo_it, span = *hi_it - *lo_it;
  constexpr int kBits = 11, kDigits = 3;  // 33 bits cover any 32-bit span
  constexpr std::uint32_t kBuckets = 1u << kBits;
  // Every digit's histogram in one sweep; a digit that puts every key in one bucket (the high
  // digits of a small span) needs no pass.
  std::vector<std::size_t> count(std::size_t{kDigits} * kBuckets);
  std::size_t* c0 = count.data();
  std::size_t* c1 = c0 + kBuckets;
  std::size_t* c2 = c1 + kBuckets;
  for (std::uint32_t id : ids) {
    const std::uint32_t offset = id - lo;
    ++c0[offset & (kBuckets - 1)];
    ++c1[(offset >> kBits) & (kBuckets - 1)];
    ++c2[offset >> (2 * kBits)];
  }
  bool first = true;
  for (int d = 0; d < kDigits; ++d) {
    const int shift = d * kBits;
    std::size_t* c = count.data() + d * kBuckets;
    if ((span >> shift) == 0 || c[((ids[0] - lo) >> shift) & (kBuckets - 1)] == n) continue;
    std::size_t sum = 0;
    for (std::uint32_t b = 0; b < kBuckets; ++b) {
      const std::size_t here = c[b];
      c[b] = sum;
      sum += here;
    }
    auto digit = [&](std::uint32_t id) { return ((id - lo) >> shift) & (kBuckets - 1); };
    if (first) {  // the first pass reads the ids themselves
      for (std::size_t k = 0; k < n; ++k) scratch[c[digit(ids[k])]++] = std::uint64_t{ids[k]} << 32 | k;
      first = false;
    } else {
      for (std::uint64_t key : keys) scratch[c[digit(static_cast<std::uint32_t>(key >> 32))]++] = key;
    }
    keys.swap(scratch);
  }
  if (first)  // one distinct id
    for (std::size_t k = 0; k < n; ++k) keys[k] = std::uint64_t{ids[k]} << 32 | k;
  return keys;
}

// Ids are numbered through a two-level bitmap: the span cut into blocks of 2^13 ids, a slot per
// block that holds an id (a 4-byte table entry per block of the span), and 2^13 bits (1 KiB)
// plus 128 word ranks (512 bytes) per slot.
constexpr unsigned kIdBlockBits = 13;
constexpr std::size_t kIdBlockWords = std::size_t{1} << (kIdBlockBits - 6);
constexpr std::size_t kIdBlockBytes = kIdBlockWords * (sizeof(std::uint64_t) + sizeof(std::uint32_t));
constexpr std::uint32_t kNoIdBlock = 0xFFFFFFFFu;

enum class Numbered { kDone, kTooSparse, kDisagree };

// number_chunk_vertices through the two-level bitmap for ids in [lo, lo + span), span < 2^32:
// kTooSparse (nothing written) when the table and the slots would take more than
// max_bytes; kDisagree with *disagree set to the global id of a vertex whose corners disagree
// on ownership. Cloned for CPUs with POPCNT (x86-64-v2 and later): the baseline build would
// call libgcc's bit-twiddling popcount for every corner.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
Numbered number_by_bitmap(std::span<const std::uint32_t> ids, const std::vector<std::uint8_t>& owned, std::uint32_t lo,
                          std::uint64_t span, std::size_t max_bytes, std::uint32_t* corners, ChunkMesh& mesh,
                          std::uint32_t* disagree) {
  const std::size_t n = ids.size();
  const std::size_t table_size = static_cast<std::size_t>((span - 1) >> kIdBlockBits) + 1;
  if (table_size * sizeof(std::uint32_t) > max_bytes) return Numbered::kTooSparse;
  // The blocks that hold an id get slots in ascending order.
  std::vector<std::uint32_t> slot_of(table_size, kNoIdBlock);
  for (std::uint32_t id : ids) slot_of[(id - lo) >> kIdBlockBits] = 0;
  std::uint32_t blocks = 0;
  for (std::uint32_t& slot : slot_of)
    if (slot == 0) slot = blocks++;
  if (table_size * sizeof(std::uint32_t) + std::size_t{blocks} * kIdBlockBytes > max_bytes) return Numbered::kTooSparse;
  auto word_of = [&](std::uint32_t offset) {  // the id's word among the slots' words
    return std::size_t{slot_of[offset >> kIdBlockBits]} * kIdBlockWords + ((offset >> 6) & (kIdBlockWords - 1));
  };
  const std::size_t words = std::size_t{blocks} * kIdBlockWords;
  std::vector<std::uint64_t> bits(words, 0);
  for (std::uint32_t id : ids) bits[word_of(id - lo)] |= std::uint64_t{1} << ((id - lo) & 63);
  std::vector<std::uint32_t> rank(words);
  std::uint32_t distinct = 0;
  for (std::size_t w = 0; w < words; ++w) {
    rank[w] = distinct;
    distinct += static_cast<std::uint32_t>(std::popcount(bits[w]));
  }
  mesh.global_vertex.resize(distinct);
  std::uint32_t* next = mesh.global_vertex.data();
  for (std::size_t block = 0; block < table_size; ++block) {
    if (slot_of[block] == kNoIdBlock) continue;
    const std::uint64_t first = std::uint64_t{lo} + (std::uint64_t{block} << kIdBlockBits);
    const std::uint64_t* block_bits = bits.data() + std::size_t{slot_of[block]} * kIdBlockWords;
    for (std::size_t w = 0; w < kIdBlockWords; ++w)
      for (std::uint64_t word = block_bits[w]; word != 0; word &= word - 1)
        *next++ = static_cast<std::uint32_t>(first + 64 * w + static_cast<unsigned>(std::countr_zero(word)));
  }
  // Ownership per vertex: bit 0 a corner said owned, bit 1 a corner said not owned.
  std::vector<std::uint8_t> said(distinct, 0);
  for (std::size_t c = 0; c < n; ++c) {
    const std::uint32_t offset = ids[c] - lo;
    const std::size_t w = word_of(offset);
    const std::uint64_t below = bits[w] & ((std::uint64_t{1} << (offset & 63)) - 1);
    const std::uint32_t local = rank[w] + static_cast<std::uint32_t>(std::popcount(below));
    corners[c] = local;
    said[local] |= owned[c] ? 1 : 2;
  }
  mesh.owned_vertex.resize(distinct);
  for (std::uint32_t v = 0; v < distinct; ++v) {
    if (said[v] == 3) {
      *disagree = mesh.global_vertex[v];
      return Numbered::kDisagree;
    }
    mesh.owned_vertex[v] = said[v] == 1;
  }
  return Numbered::kDone;
}

// Local vertex ids in ascending global id for a chunk's corners (mesh.triangles holding global
// ids; owned flags per corner): fills mesh.global_vertex and owned_vertex, and numbers the
// triangles' corners; a vertex whose corners disagree on ownership is bad(). Ids that fill
// their 2^13-id blocks well enough (any spatially ordered input, where a chunk's ids lie in a
// few ranges, one per stretch of the input's order): the two-level bitmap numbers them in
// sequential passes over the corners and no sort, in at most the sort's 48 bytes a face.
// Scattered ids: one sort of (global id, corner). At 100M refined
// triangles a chunk's ids span most of the 50M ids (one range per refinement level), and the
// sort, a one-level bitmap's fallback there, was 12 % of the whole run.
template <class Bad>
Status number_chunk_vertices(const std::vector<std::uint8_t>& owned, ChunkMesh& mesh, Bad&& bad) {
  // The corners hold global ids on entry and are numbered in place: each pass reads a corner's
  // id before it writes its local one.
  const std::span<const std::uint32_t> ids(reinterpret_cast<const std::uint32_t*>(mesh.triangles.data()), 3 * mesh.triangles.size());
  const std::size_t n = ids.size();
  if (n == 0) return {};
  // min and max without branches (minmax_element's compares on scattered ids mispredicted: a
  // seventh of load_chunk).
  std::uint32_t lo = ids[0], hi = ids[0];
  for (const std::uint32_t id : ids) {
    lo = std::min(lo, id);
    hi = std::max(hi, id);
  }
  const std::uint64_t span = std::uint64_t{hi} - lo + 1;
  auto* corners = reinterpret_cast<std::uint32_t*>(mesh.triangles.data());
  static_assert(sizeof(format::Triangle) == 3 * sizeof(std::uint32_t));
  std::uint32_t disagree = 0;
  switch (number_by_bitmap(ids, owned, lo, span, 48 * (n / 3 + 1), corners, mesh, &disagree)) {
    case Numbered::kDone: return {};
    case Numbered::kDisagree: return bad("vertex " + std::to_string(disagree) + " is both owned and not owned");
    case Numbered::kTooSparse: break;
  }
  const std::vector<std::uint64_t> keys = sorted_corner_keys(ids);
  std::size_t first_corner = 0;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    const auto id = static_cast<std::uint32_t>(keys[k] >> 32);
    const auto c = static_cast<std::size_t>(keys[k] & 0xFFFFFFFFu);
    if (k == 0 || id != mesh.global_vertex.back()) {
      mesh.global_vertex.push_back(id);
      mesh.owned_vertex.push_back(owned[c]);
      first_corner = c;
    } else if (owned[first_corner] != owned[c]) {
      return bad("vertex " + std::to_string(id) + " is both owned and not owned");
    }
    corners[c] = static_cast<std::uint32_t>(mesh.global_vertex.size() - 1);
  }
  return {};
}

// Copies the record_bytes-sized record of every id of `ids` (ascending) from `path` into `out`
// (ids.size() * record_bytes bytes). An id beyond the file is kBadInput naming `chunk_path`.
Status read_vertex_records(const std::string& path, std::size_t record_bytes, const std::vector<std::uint32_t>& ids,
                           const std::string& chunk_path, std::byte* out, const std::vector<std::uint32_t>* vertices = nullptr) {
  auto vertex = [&](std::size_t i) { return std::to_string(vertices ? (*vertices)[i] : ids[i]); };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::error(Code::kBadInput, path, "cannot open a vertex file: " + errno_text());
  FdCloser closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) return Status::error(Code::kBadInput, path, "cannot stat a vertex file: " + errno_text());
  const std::uint64_t count = static_cast<std::uint64_t>(st.st_size) / record_bytes;
  std::vector<std::byte> window;
  const std::size_t served = read_by_ascending_id(fd, count, record_bytes, ids, window, [&](std::size_t i, const std::byte* record) {
    std::memcpy(out + i * record_bytes, record, record_bytes);
  });
  if (served == ids.size()) return {};
  if (ids[served] >= count) {
    return Status::error(Code::kBadInput, chunk_path,
                         "vertex " + vertex(served) + " is beyond " + path + " (" + std::to_string(count) + " records)");
  }
  return Status::error(Code::kBadInput, path, "cannot read the record of vertex " + vertex(served));
}

// The chunk's positions from the input's own vertex records (VertexFiles::input).
Status read_input_positions(const VertexFiles::InputPositions& in, const ChunkInfo& info, ChunkMesh& mesh) {
  const std::vector<std::uint32_t>& ids = mesh.global_vertex;
  auto opened = open_input_positions(in);
  if (!opened) return opened.status();
  FdCloser closer{*opened};
  const std::uint64_t count = (in.size - in.first_byte) / in.stride;
  std::vector<std::byte> window;
  const std::size_t served = read_by_ascending_id(
      *opened, count, in.stride, ids, window,
      [&](std::size_t i, const std::byte* record) { mesh.positions[i] = input_position(in, record); }, in.first_byte);
  if (served == ids.size()) return {};
  return Status::error(Code::kBadInput, info.path,
                       "vertex " + std::to_string(ids[served]) + ": no record of it in " + in.path + " (" + std::to_string(count) + " vertices)");
}

// The chunk's positions from pass 0's two position files: each file's ids in order, translated
// to its records.
Status read_spilled_positions(const VertexFiles& files, const ChunkInfo& info, ChunkMesh& mesh) {
  const std::vector<std::uint32_t>& ids = mesh.global_vertex;
  std::vector<std::uint32_t> records, slots, vertices;
  std::vector<Vec3f> positions;
  for (std::uint32_t file = 0; file < kPositionFiles; ++file) {
    records.clear();
    slots.clear();
    vertices.clear();
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (position_file(ids[i]) != file) continue;
      records.push_back(static_cast<std::uint32_t>(position_record(ids[i])));
      slots.push_back(static_cast<std::uint32_t>(i));
      vertices.push_back(ids[i]);
    }
    if (records.empty()) continue;
    positions.resize(records.size());
    GM_RETURN_IF_ERROR(read_vertex_records(files.positions[file], kPositionRecordBytes, records, info.path,
                                           reinterpret_cast<std::byte*>(positions.data()), &vertices));
    for (std::size_t k = 0; k < slots.size(); ++k) mesh.positions[slots[k]] = positions[k];
  }
  return {};
}

// Positions and owners of the chunk's vertices from the partition's vertex files (or the input);
// the owner read back must agree with the chunk's owned flags.
Status read_chunk_positions(const ChunkInfo& info, ChunkMesh& mesh) {
  if (!info.vertex_files) return Status::error(Code::kProcessing, info.path, "no vertex files for the chunk");
  const VertexFiles& files = *info.vertex_files;
  const std::vector<std::uint32_t>& ids = mesh.global_vertex;
  mesh.positions.resize(ids.size());
  GM_RETURN_IF_ERROR(files.input ? read_input_positions(*files.input, info, mesh) : read_spilled_positions(files, info, mesh));
  std::vector<std::uint32_t>& owners = mesh.vertex_owner;
  owners.resize(ids.size());
  GM_RETURN_IF_ERROR(read_vertex_records(files.owners, kOwnerRecordBytes, ids, info.path, reinterpret_cast<std::byte*>(owners.data())));
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if ((owners[i] == info.id) != static_cast<bool>(mesh.owned_vertex[i])) {
      return Status::error(Code::kBadInput, info.path,
                           "vertex " + std::to_string(ids[i]) + ": owned flag disagrees with " + files.owners);
    }
  }
  return {};
}

}  // namespace

format::Result<ChunkMesh> load_chunk(const ChunkInfo& info) {
  const std::uint32_t record_bytes = info.loop ? kLoopChunkRecordBytes : kChunkFaceRecordBytes;
  const std::uint32_t kind = info.loop ? kLoopChunkRecordKind : kChunkFaceRecordKind;
  auto opened = info.segment.bytes > 0 ? format::RecordReader::open(info.path, kind, record_bytes, info.segment)
                                       : format::RecordReader::open(info.path, kind, record_bytes);
  if (!opened) return opened.status();
  format::RecordReader& reader = **opened;
  auto bad = [&](const std::string& message) { return Status::error(Code::kBadInput, info.path, message); };
  if (reader.records() != info.faces) {
    return bad("holds " + std::to_string(reader.records()) + " face records, the partition wrote " + std::to_string(info.faces));
  }
  ChunkMesh mesh;
  mesh.chunk = info.id;
  const std::size_t faces = static_cast<std::size_t>(info.faces);
  // Sized once by the partition's own count (which the file's seek table matched) and filled by
  // index: push_back's capacity checks were a third of this loop.
  mesh.global_face.resize(faces);
  mesh.owned_face.resize(faces);
  // The corners' global ids go straight into the triangles, numbered there in place (a separate
  // array of them was 12 more bytes a face while loading).
  mesh.triangles.resize(faces);
  std::uint32_t* corner_ids = reinterpret_cast<std::uint32_t*>(mesh.triangles.data());
  std::vector<std::uint8_t> corner_owned(3 * faces), corner_loop;  // corner_loop: loop chunks only
  std::uint64_t* global_face = mesh.global_face.data();
  std::uint8_t* owned_face = mesh.owned_face.data();
  std::size_t k = 0;  // records read
  for (;;) {
    auto block = reader.next();
    if (!block) return block.status();
    if (block->empty()) break;
    for (std::size_t at = 0; at < block->size(); at += record_bytes) {
      const std::byte* r = block->data() + at;
      std::uint64_t face;
      std::uint32_t v[3];
      std::memcpy(&face, r, 8);
      std::memcpy(v, r + 8, 12);
      const auto flags = std::to_integer<std::uint8_t>(r[20]);
      // Built only on failure: a string per record cost a fifth of pass 2's time.
      auto where = [&] { return "face record " + std::to_string(k) + ": "; };
      if (k >= faces) return bad(where() + "more records than the file claims");
      if (k > 0 && face <= global_face[k - 1]) return bad(where() + "face ids not ascending");
      if (!info.loop && (flags & 0xF0)) return bad(where() + "reserved flag bits set");
      const unsigned low01 = v[1] < v[0];  // the lowest corner, by selects: ids are coin tosses
      const unsigned lowest = v[2] < std::min(v[0], v[1]) ? 2u : low01;
      const bool owns_face = flags & kOwnsFace;
      if (owns_face != static_cast<bool>((flags >> lowest) & 1)) {
        return bad(where() + "face " + std::to_string(face) + " ownership disagrees with its lowest vertex's");
      }
      global_face[k] = face;
      owned_face[k] = owns_face;
      if (info.loop) {
        std::uint32_t piece;
        std::memcpy(&piece, r + kChunkFaceRecordBytes, 4);
        if (owns_face == (piece == 0xFFFFFFFFu)) return bad(where() + "a piece for a face the chunk does not own, or none for one it owns");
        mesh.loop_piece.push_back(piece);
        mesh.core_face.push_back((flags & kCoreFace) != 0);
        for (int j = 0; j < 3; ++j) corner_loop.push_back((flags >> (5 + j)) & 1);
      }
      for (int j = 0; j < 3; ++j) {
        corner_ids[3 * k + j] = v[j];
        corner_owned[3 * k + j] = (flags >> j) & 1;
      }
      ++k;
    }
  }
  if (k != faces) return bad("fewer face records than the file claims");
  GM_RETURN_IF_ERROR(number_chunk_vertices(corner_owned, mesh, bad));
  if (info.loop) {  // a vertex's corners agree on its loop bit: bit 0 said yes, bit 1 said no
    mesh.loop_vertex.assign(mesh.global_vertex.size(), 0);
    const auto* corners = reinterpret_cast<const std::uint32_t*>(mesh.triangles.data());
    for (std::size_t c = 0; c < corner_loop.size(); ++c) mesh.loop_vertex[corners[c]] |= corner_loop[c] ? 1 : 2;
    for (std::uint32_t v = 0; v < mesh.loop_vertex.size(); ++v) {
      if (mesh.loop_vertex[v] == 3) return bad("vertex " + std::to_string(mesh.global_vertex[v]) + " is both a loop vertex and not");
      mesh.loop_vertex[v] = mesh.loop_vertex[v] == 1;
    }
  }
  std::uint64_t owned_faces = 0, owned_vertices = 0;
  for (std::uint8_t o : mesh.owned_face) owned_faces += o;
  for (std::uint8_t o : mesh.owned_vertex) owned_vertices += o;
  if (owned_faces != info.owned_faces) {
    return bad("owns " + std::to_string(owned_faces) + " faces, the partition wrote " + std::to_string(info.owned_faces));
  }
  if (owned_vertices > info.owned_vertices) {
    return bad("owns " + std::to_string(owned_vertices) + " vertices, more than the partition's " +
               std::to_string(info.owned_vertices));
  }
  GM_RETURN_IF_ERROR(read_chunk_positions(info, mesh));
  return mesh;
}

}  // namespace gaussmesh::stream
