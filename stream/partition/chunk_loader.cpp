// load_chunk: one chunk file read back and checked, its vertices numbered locally, their
// positions and owners read from the partition's vertex files.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "format/record_file.h"
#include "stream/partition/chunk_partition.h"
#include "stream/partition/id_indexed_file.h"
#include "stream/partition/input_positions.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream {
namespace {

using detail::errno_text;
using detail::FdCloser;
using detail::input_position;
using detail::open_input_positions;
using format::Code;
using format::Status;
using format::Vec3f;

// (global id << 32 | corner) for every corner, sorted: an LSD radix sort on the id's offset from
// the chunk's lowest id, 11 bits a pass — stable, so corners of one id stay in order. A chunk's ids
// span a small range on spatially ordered input (one or two passes), where this is much cheaper
// than a comparison sort.
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
// sequential passes over the corners and no sort, in at most the sort's 48 bytes a face. Two
// levels, not one: on a refined input a chunk's ids span most of the id range (one range per
// refinement level), which a one-level bitmap could not afford. Scattered ids: one sort of
// (global id, corner).
template <class Bad>
Status number_chunk_vertices(const std::vector<std::uint8_t>& owned, ChunkMesh& mesh, Bad&& bad) {
  // The corners hold global ids on entry and are numbered in place: each pass reads a corner's
  // id before it writes its local one.
  const std::span<const std::uint32_t> ids(reinterpret_cast<const std::uint32_t*>(mesh.triangles.data()), 3 * mesh.triangles.size());
  const std::size_t n = ids.size();
  if (n == 0) return {};
  // min and max without branches (minmax_element's compares mispredict on scattered ids).
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

// The chunk's positions from the ingest pass's two position files: each file's ids in order, translated
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
  // index: push_back's capacity checks would weigh on this loop.
  mesh.global_face.resize(faces);
  mesh.owned_face.resize(faces);
  // The corners' global ids go straight into the triangles, numbered there in place (a separate
  // array of them would be 12 more bytes a face while loading).
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
      // Built only on failure: a string per record would be a large part of loading's time.
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
