// Streaming STL reader, binary (80-byte header, uint32 count, 50-byte records) and ascii
// (solid / facet normal / outer loop / vertex / endloop / endfacet / endsolid). STL repeats
// each corner position in every facet, so vertices are welded by exact position in a hash
// table: the one reader whose memory grows with the mesh (unique vertices). docs/formats.md.
// Without ReadOptions::weld_stl every corner is a vertex of its own (a soup) and the memory is
// fixed: simplify welds the soup itself, in bounded memory (stream/partition/spatial_order.h).
#include "format/stl_reader.h"

#include <sys/mman.h>

#include <bit>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "format/mesh_batcher.h"
#include "format/mesh_reader.h"
#include "format/text_scan.h"

namespace gaussmesh::format {
namespace {

using text::LineScanner;
using text::NumberError;

constexpr size_t kHeaderBytes = 84;  // 80-byte header + uint32 triangle count
constexpr size_t kRecordBytes = 50;  // normal, 3 corners (12 floats), uint16 attribute
constexpr size_t kSniffBytes = 4096;
constexpr size_t kRecordsPerRefill = 4096;

uint32_t load_u32_le(const char* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  if constexpr (std::endian::native == std::endian::big) {
    v = (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24);
  }
  return v;
}

float load_f32_le(const char* p) { return std::bit_cast<float>(load_u32_le(p)); }

bool starts_with_nocase(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && text::equals_nocase(s.substr(0, prefix.size()), prefix);
}

bool contains_nocase(std::string_view s, std::string_view needle) {
  for (size_t i = 0; i + needle.size() <= s.size(); ++i) {
    if (text::equals_nocase(s.substr(i, needle.size()), needle)) return true;
  }
  return false;
}

// Welds positions by exact value: bitwise-equal coordinates (with -0.0 taken as 0.0) are one
// vertex. Open addressing with linear probing, load <= 0.7: about 23-46 bytes per unique
// vertex. STL files list a mesh's facets in some spatial order, so a corner usually repeats
// soon after it first appears: a small direct-mapped cache of recent corners (fixed 512 KiB)
// answers most lookups without touching the large table, which lives in DRAM.
class VertexWelder {
 public:
  static constexpr uint32_t kEmpty = 0xFFFFFFFFu;  // never a vertex index (< kMaxVertices)

  VertexWelder() : slots_(kInitialSlots), recent_(kRecentSlots) {}

  // False when even the initial tables could not be allocated.
  bool ok() const { return slots_.ok() && recent_.ok(); }
  size_t size() const { return size_; }
  // True when the next insertion must wait for grow().
  bool full() const { return size_ * 10 >= slots_.size() * 7; }
  // What the tables hold while grow() copies the table into one twice its size.
  uint64_t bytes_while_growing() const { return (3 * uint64_t{slots_.size()} + kRecentSlots) * sizeof(Slot); }

  // The index of p: an existing one, or next_index after inserting p. Precondition: !full().
  uint32_t find_or_insert(const Vec3f& p, uint32_t next_index) {
    Key key{bits(p.x), bits(p.y), bits(p.z)};
    size_t h = hash(key);
    Slot& cached = recent_[h >> (64 - kRecentBits)];
    if (cached.index != kEmpty && same(cached.key, key)) return cached.index;
    size_t mask = slots_.size() - 1;
    for (size_t i = h & mask;; i = (i + 1) & mask) {
      Slot& s = slots_[i];
      if (s.index == kEmpty) {
        s.key = key;
        s.index = next_index;
        ++size_;
        cached = s;
        return next_index;
      }
      if (same(s.key, key)) {
        cached = s;
        return s.index;
      }
    }
  }

  // Doubles the table. Fails (kResources, no where) only when memory runs out.
  Status grow() {
    SlotArray bigger(slots_.size() * 2);
    if (!bigger.ok()) {
      return Status::error(Code::kResources, "",
                           "out of memory welding STL vertices (" + std::to_string(size_) +
                               " unique so far)");
    }
    size_t mask = bigger.size() - 1;
    for (size_t k = 0; k < slots_.size(); ++k) {
      const Slot& s = slots_[k];
      if (s.index == kEmpty) continue;
      size_t i = hash(s.key) & mask;
      while (bigger[i].index != kEmpty) i = (i + 1) & mask;
      bigger[i] = s;
    }
    std::swap(slots_, bigger);
    return {};
  }

 private:
  static constexpr size_t kInitialSlots = size_t{1} << 16;
  static constexpr int kRecentBits = 15;
  static_assert(sizeof(size_t) == 8, "hash bits assume a 64-bit size_t");
  static constexpr size_t kRecentSlots = size_t{1} << kRecentBits;
  struct Key {
    uint32_t x = 0, y = 0, z = 0;
  };
  struct Slot {
    Key key;
    uint32_t index = kEmpty;
  };
  // Slots, all empty, in memory the kernel may back with huge pages: the table is touched at
  // random, and with 4 KiB pages its first touch costs a page fault per 256 slots.
  class SlotArray {
   public:
    explicit SlotArray(size_t n) : size_(n) {
      size_t bytes = n * sizeof(Slot);
      bool huge = bytes >= kHugePage;
      if (huge) bytes = (bytes + kHugePage - 1) / kHugePage * kHugePage;
      void* p = std::aligned_alloc(huge ? kHugePage : alignof(Slot), bytes);
      if (p == nullptr) {
        size_ = 0;
        return;
      }
#ifdef MADV_HUGEPAGE
      if (huge) ::madvise(p, bytes, MADV_HUGEPAGE);  // a hint: failure changes nothing
#endif
      std::memset(p, 0xFF, n * sizeof(Slot));  // index 0xFFFFFFFF == kEmpty
      data_.reset(static_cast<Slot*>(p));
    }
    bool ok() const { return data_ != nullptr; }
    size_t size() const { return size_; }
    Slot& operator[](size_t i) { return data_.get()[i]; }
    const Slot& operator[](size_t i) const { return data_.get()[i]; }

   private:
    static constexpr size_t kHugePage = size_t{2} << 20;
    struct Free {
      void operator()(Slot* p) const { std::free(p); }
    };
    std::unique_ptr<Slot, Free> data_;
    size_t size_ = 0;
  };
  static bool same(const Key& a, const Key& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

  static uint32_t bits(float f) {
    uint32_t b = std::bit_cast<uint32_t>(f);
    return b == 0x80000000u ? 0u : b;  // -0.0 == 0.0
  }
  static size_t hash(const Key& k) {
    uint64_t h = (uint64_t{k.x} * 0x9E3779B97F4A7C15ull) ^ (uint64_t{k.y} * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t{k.z} * 0x165667B19E3779F9ull);
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return static_cast<size_t>(h);
  }

  SlotArray slots_;
  SlotArray recent_;
  size_t size_ = 0;
};

// Shared by both encodings: welds a corner and hands out its index.
class StlCorners {
 public:
  // The welder holds at most half of `memory_limit` (0: no limit), the rest being the caller's:
  // an STL with more unique vertices than that is refused rather than read past the budget.
  StlCorners(MeshBatcher& batcher, bool weld, uint64_t memory_limit) : batcher_(batcher), limit_(memory_limit / 2) {
    if (weld) welder_.emplace();  // its tables only when it welds
  }

  Result<VertexIndex> corner(const Vec3f& p) {
    uint64_t next = batcher_.vertex_count();
    if (next >= kMaxVertices) {
      return Status::error(Code::kResources, "",
                           "more than " + std::to_string(kMaxVertices) + " unique vertices are not supported");
    }
    if (!welder_) {  // every corner its own vertex: a soup, welded later (ReadOptions::weld_stl)
      GM_RETURN_IF_ERROR(batcher_.add_vertex(p));
      return static_cast<VertexIndex>(next);
    }
    if (!welder_->ok()) return Status::error(Code::kResources, "", "out of memory for the STL vertex table");
    if (welder_->full()) {
      if (limit_ > 0 && welder_->bytes_while_growing() > limit_) {
        return Status::error(Code::kResources, "",
                             "welding this STL's vertices needs more than " + std::to_string(welder_->bytes_while_growing() >> 20) +
                                 " MiB (" + std::to_string(welder_->size()) + " unique so far), over half the --memory budget of " +
                                 std::to_string((2 * limit_) >> 20) + " MiB: raise --memory, or simplify it (which welds in bounded memory)");
      }
      GM_RETURN_IF_ERROR(welder_->grow());
    }
    uint32_t index = welder_->find_or_insert(p, static_cast<uint32_t>(next));
    if (index == next) GM_RETURN_IF_ERROR(batcher_.add_vertex(p));
    return index;
  }

 private:
  MeshBatcher& batcher_;
  uint64_t limit_;
  std::optional<VertexWelder> welder_;
};

// Puts a "where" on a located-elsewhere error (the welder does not know the position).
Status locate(Status s, const std::string& where) {
  if (s.is_ok() || !s.where().empty()) return s;
  return Status::error(s.code(), where, s.message());
}

Status read_binary_stl(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  Result<size_t> got = source.ensure(kHeaderBytes);
  GM_RETURN_IF_ERROR(got.status());
  if (*got < kHeaderBytes) {
    return Status::error(Code::kBadInput, source.at_byte(source.offset() + *got),
                         "file ends inside the 84-byte binary STL header");
  }
  uint64_t count = load_u32_le(source.cursor() + 80);
  source.advance(kHeaderBytes);
  if (std::optional<uint64_t> size = source.total_size(); size && *size >= kHeaderBytes) {
    uint64_t body = *size - kHeaderBytes;
    uint64_t need = count * kRecordBytes;
    // Writers that cannot seek back leave the count 0; the size then tells it.
    if (count == 0 && body > 0 && body % kRecordBytes == 0) {
      count = body / kRecordBytes;
    } else if (need > body) {
      return Status::error(Code::kBadInput, source.at_byte(80),
                           "declares " + std::to_string(count) + " triangles (" +
                               std::to_string(kHeaderBytes + need) + " bytes) but the file has " +
                               std::to_string(*size) + " bytes (truncated file or wrong count)");
    }
  }
  MeshHeader header;
  header.format = MeshFormat::kStl;
  header.declared_faces = count;
  GM_RETURN_IF_ERROR(sink.on_header(header));

  MeshBatcher batcher(sink, options.batch_size);
  StlCorners corners(batcher, options.weld_stl, options.memory_limit);
  uint64_t done = 0;
  while (done < count) {
    uint64_t want = std::min<uint64_t>(count - done, kRecordsPerRefill);
    got = source.ensure(static_cast<size_t>(want) * kRecordBytes);
    GM_RETURN_IF_ERROR(got.status());
    uint64_t records = std::min<uint64_t>(want, *got / kRecordBytes);
    if (records == 0) {
      return Status::error(Code::kBadInput, source.at_byte(source.offset() + *got),
                           "file ends after " + std::to_string(done) + " of " +
                               std::to_string(count) + " triangles");
    }
    const char* p = source.cursor();
    for (uint64_t r = 0; r < records; ++r, p += kRecordBytes) {
      VertexIndex v[3];
      for (int k = 0; k < 3; ++k) {
        const char* c = p + 12 + 12 * k;
        Vec3f position{load_f32_le(c), load_f32_le(c + 4), load_f32_le(c + 8)};
        if (!std::isfinite(position.x) || !std::isfinite(position.y) || !std::isfinite(position.z)) {
          return Status::error(Code::kBadInput, source.at_byte(source.offset() + (c - source.cursor())),
                               "triangle " + std::to_string(done + r) + " has a coordinate that is not a finite number");
        }
        Result<VertexIndex> index = corners.corner(position);
        if (!index.is_ok()) {
          return locate(index.status(), source.at_byte(source.offset() + (c - source.cursor())));
        }
        v[k] = *index;
      }
      GM_RETURN_IF_ERROR(batcher.add_triangle(v[0], v[1], v[2]));
    }
    source.advance(static_cast<size_t>(records * kRecordBytes));
    done += records;
  }
  // Bytes after the last declared record (padding some writers add) are ignored.
  GM_RETURN_IF_ERROR(batcher.finish());
  return sink.on_end();
}

class AsciiStlReader {
 public:
  AsciiStlReader(ByteSource& source, const ReadOptions& options, MeshSink& sink)
      : source_(source), sink_(sink), batcher_(sink, options.batch_size), corners_(batcher_, options.weld_stl, options.memory_limit) {}

  Status run() {
    MeshHeader header;
    header.format = MeshFormat::kStl;
    GM_RETURN_IF_ERROR(sink_.on_header(header));
    for (;;) {
      Result<std::optional<std::string_view>> line = source_.next_line();
      GM_RETURN_IF_ERROR(line.status());
      if (!line->has_value()) break;
      LineScanner scan(**line);
      std::string_view keyword = scan.token();
      if (keyword.empty()) continue;
      GM_RETURN_IF_ERROR(statement(keyword, scan));
    }
    if (state_ != State::kOutside) {
      return source_.bad_at_line(std::string("file ends inside a solid (") + expected() + ")");
    }
    if (solids_ == 0) {
      return Status::error(Code::kBadInput, source_.name(), "input is empty: no 'solid'");
    }
    GM_RETURN_IF_ERROR(batcher_.finish());
    return sink_.on_end();
  }

 private:
  enum class State { kOutside, kInSolid, kInFacet, kInLoop, kAfterLoop };

  const char* expected() const {
    switch (state_) {
      case State::kOutside: return "expected 'solid'";
      case State::kInSolid: return "expected 'facet' or 'endsolid'";
      case State::kInFacet: return "expected 'outer loop'";
      case State::kInLoop: return "expected 'vertex' or 'endloop'";
      case State::kAfterLoop: return "expected 'endfacet'";
    }
    return "";
  }

  Status unexpected(std::string_view keyword) const {
    return source_.bad_at_line("unexpected " + text::quote(keyword) + ": " + expected());
  }

  Status statement(std::string_view keyword, LineScanner& scan) {
    using text::equals_nocase;
    switch (state_) {
      case State::kOutside:
        if (!equals_nocase(keyword, "solid")) return unexpected(keyword);
        ++solids_;
        state_ = State::kInSolid;  // the rest of the line is the solid's name
        return {};
      case State::kInSolid:
        if (equals_nocase(keyword, "endsolid")) {
          state_ = State::kOutside;
          return {};
        }
        if (!equals_nocase(keyword, "facet")) return unexpected(keyword);
        state_ = State::kInFacet;  // "normal nx ny nz" follows: recomputed downstream, ignored
        return {};
      case State::kInFacet:
        if (!equals_nocase(keyword, "outer") || !equals_nocase(scan.token(), "loop")) {
          return unexpected(keyword);
        }
        state_ = State::kInLoop;
        loop_corners_ = 0;
        return {};
      case State::kInLoop:
        if (equals_nocase(keyword, "vertex")) return vertex(scan);
        if (!equals_nocase(keyword, "endloop")) return unexpected(keyword);
        if (loop_corners_ < 3) {
          return source_.bad_at_line("facet loop has " + std::to_string(loop_corners_) +
                                     " vertices; a facet needs at least 3");
        }
        state_ = State::kAfterLoop;
        return {};
      case State::kAfterLoop:
        if (!equals_nocase(keyword, "endfacet")) return unexpected(keyword);
        state_ = State::kInSolid;
        return {};
    }
    return {};
  }

  // Loops with more than three corners (some writers emit polygons) are fan-triangulated.
  Status vertex(LineScanner& scan) {
    float c[3];
    for (int k = 0; k < 3; ++k) {
      NumberError e = scan.read_float(c[k]);
      if (e != NumberError::kOk) {
        static constexpr const char* kAxis[3] = {"x", "y", "z"};
        return source_.bad_at_line(
            text::number_problem(e, std::string("vertex ") + kAxis[k], scan.last_token()));
      }
    }
    Result<VertexIndex> index = corners_.corner(Vec3f{c[0], c[1], c[2]});
    if (!index.is_ok()) return locate(index.status(), source_.at_line());
    if (loop_corners_ == 0) {
      first_ = *index;
    } else if (loop_corners_ >= 2) {
      GM_RETURN_IF_ERROR(batcher_.add_triangle(first_, previous_, *index));
    }
    previous_ = *index;
    ++loop_corners_;
    return {};
  }

  ByteSource& source_;
  MeshSink& sink_;
  MeshBatcher batcher_;
  StlCorners corners_;
  State state_ = State::kOutside;
  uint64_t solids_ = 0;
  uint64_t loop_corners_ = 0;
  VertexIndex first_ = 0, previous_ = 0;
};

}  // namespace

bool looks_binary(std::string_view head) {
  for (char ch : head) {
    unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x09 || (c > 0x0D && c < 0x20) || c == 0x7F) return true;
  }
  return false;
}

Result<StlEncoding> sniff_stl(ByteSource& source) {
  Result<size_t> got = source.ensure(kSniffBytes);
  GM_RETURN_IF_ERROR(got.status());
  std::string_view head(source.cursor(), *got);
  bool size_matches = false;
  if (std::optional<uint64_t> size = source.total_size(); size && head.size() >= kHeaderBytes) {
    uint64_t count = load_u32_le(head.data() + 80);
    size_matches = kHeaderBytes + count * kRecordBytes == *size;
  }
  size_t lead = 0;
  while (lead < head.size() && (text::is_space(head[lead]) || head[lead] == '\n')) ++lead;
  std::string_view rest = head.substr(lead);
  bool solid = starts_with_nocase(rest, "solid") &&
               (rest.size() == 5 || text::is_space(rest[5]) || rest[5] == '\n');
  bool text_like = !looks_binary(head);
  if (solid) {
    // Many binary writers start the 80-byte header with "solid" too: text with STL keywords
    // is ascii, anything with binary bytes (the count and floats nearly always have some) or
    // an exactly matching size is binary.
    bool keywords = text_like && (contains_nocase(rest, "facet") || contains_nocase(rest, "endsolid"));
    if (keywords) return StlEncoding::kAscii;
    if (size_matches || !text_like) return StlEncoding::kBinary;
    return StlEncoding::kAscii;  // a (truncated) text file that starts with "solid"
  }
  return size_matches ? StlEncoding::kBinary : StlEncoding::kNotStl;
}

Status read_stl(ByteSource& source, const ReadOptions& options, MeshSink& sink) {
  Result<size_t> got = source.ensure(1);
  GM_RETURN_IF_ERROR(got.status());
  if (*got == 0) return Status::error(Code::kBadInput, source.name(), "input is empty: no STL data");
  Result<StlEncoding> encoding = sniff_stl(source);
  GM_RETURN_IF_ERROR(encoding.status());
  if (*encoding == StlEncoding::kAscii) {
    AsciiStlReader reader(source, options, sink);
    return reader.run();
  }
  return read_binary_stl(source, options, sink);
}

}  // namespace gaussmesh::format
