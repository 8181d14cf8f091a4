// Border-edge buckets and face-answer files of the out-of-core stitch. See piece_joins.h.
#include "stream/stitch/piece_joins.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <memory>
#include <numeric>

#include <tbb/parallel_pipeline.h>

#include "stream/core/hash_mix.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using format::Status;

// Pending bytes per bucket writer: at most this, at least the smaller (all buckets' pending frames
// share 1/16 of the budget).
constexpr std::size_t kBucketFrameBytes = std::size_t{32} << 10, kMinBucketFrameBytes = std::size_t{4} << 10;
constexpr std::size_t kAnswerFrameBytes = std::size_t{256} << 10;

Status damaged(const std::string& what) { return Status::error(Code::kBadInput, "stitch", what); }


std::uint64_t pair_hash(std::uint64_t a, std::uint64_t b) {
  return mix64(mix64(std::min(a, b)) ^ std::max(a, b));
}

void put_u64(std::byte* at, std::uint64_t v) { std::memcpy(at, &v, 8); }
std::uint64_t get_u64(const std::byte* at) {
  std::uint64_t v;
  std::memcpy(&v, at, 8);
  return v;
}

void encode(const BorderEdgeRecord& r, std::byte* at) {
  put_u64(at, r.face);
  put_u64(at + 8, r.other);
  put_u64(at + 16, r.piece);
  at[24] = std::byte{r.feature ? std::uint8_t{1} : std::uint8_t{0}};
}

std::pair<std::uint64_t, std::uint64_t> edge_key(const BorderEdgeRecord& r) {
  return {std::min(r.face, r.other), std::max(r.face, r.other)};
}

}  // namespace

std::size_t border_bucket(std::uint64_t a, std::uint64_t b, std::size_t buckets) {
  return static_cast<std::size_t>(pair_hash(a, b) % buckets);
}

std::size_t border_bucket_part(std::uint64_t a, std::uint64_t b, std::size_t parts) {
  return static_cast<std::size_t>(mix64(pair_hash(a, b) + 0x9E3779B97F4A7C15ull) % parts);
}

std::uint64_t bucket_bytes(const MemoryBudget& budget) {
  return std::max<std::uint64_t>(budget.fraction(1, 16), std::uint64_t{1} << 20);
}

std::size_t border_bucket_count(std::uint64_t expected_records, const MemoryBudget& budget) {
  const std::uint64_t bytes = expected_records * sizeof(BorderEdgeRecord);
  const std::uint64_t per = bucket_bytes(budget);
  return static_cast<std::size_t>(std::clamp<std::uint64_t>((bytes + per - 1) / per, 1, kMaxBorderBuckets));
}

format::Result<std::unique_ptr<PieceJoinFiles>> PieceJoinFiles::create(const std::string& dir, std::size_t chunks,
                                                                       std::size_t buckets, const MemoryBudget& budget) {
  if (buckets == 0 || buckets > kMaxBorderBuckets) {
    return Status::error(Code::kUsage, "stitch", "border-edge bucket count " + std::to_string(buckets) + " out of range");
  }
  std::unique_ptr<PieceJoinFiles> files(new PieceJoinFiles());
  files->dir_ = dir;
  files->chunks_ = chunks;
  files->answered_.assign(chunks, 0);
  files->placed_.assign(kParts * chunks, Stored{});
  files->segments_ = std::make_unique<format::RecordSegmentPool>(dir + "/segments-");
  files->star_entries_.assign(chunks, 0);
  files->candidate_entries_.assign(chunks, 0);
  files->piece_entries_.assign(chunks, 0);
  files->adjacency_entries_.assign(chunks, 0);
  files->pieces_of_chunk_.assign(chunks, 0);
  auto compressor = format::RecordCompressor::create(1);
  if (!compressor) return compressor.status();
  files->compressor_ = std::move(*compressor);
  format::RecordWriterOptions options;
  options.frame_bytes = kBucketFrameBytes;
  if (budget.is_limited())
    options.frame_bytes = static_cast<std::size_t>(std::clamp<std::uint64_t>(
        MemoryBudget::of(budget.fraction(1, 16)).per_part(buckets), kMinBucketFrameBytes, kBucketFrameBytes));
  options.shared = files->compressor_.get();
  for (std::size_t b = 0; b < buckets; ++b) {
    files->bucket_paths_.push_back(dir + "/border-" + std::to_string(b) + ".rec");
    auto writer = format::RecordWriter::create(files->bucket_paths_.back(), kBorderEdgeRecordKind,
                                               kBorderEdgeRecordBytes, options);
    if (!writer) return writer.status();
    files->writers_.push_back(std::move(*writer));
  }
  files->bucket_records_.assign(buckets, 0);
  return files;
}

PieceJoinFiles::~PieceJoinFiles() = default;

PieceJoinFiles::Placed PieceJoinFiles::placed(Part part, std::uint32_t chunk) const {
  if (chunk >= chunks_) return {};
  const Stored& s = placed_[kParts * std::size_t{chunk} + static_cast<std::size_t>(part)];
  return {s.file, {s.offset, s.bytes}};
}

Status PieceJoinFiles::place(Part part, std::uint32_t chunk, const Placed& placed) {
  if (placed.segment.bytes > 0xFFFFFFFFu)
    return Status::error(Code::kResources, "stitch", "a record file of chunk " + std::to_string(chunk) + " of 4 GiB or more");
  placed_[kParts * std::size_t{chunk} + static_cast<std::size_t>(part)] = {placed.segment.offset,
                                                                      static_cast<std::uint32_t>(placed.segment.bytes), placed.file};
  return {};
}

void PieceJoinFiles::replace_segment_for_test(Part part, std::uint32_t chunk, format::RecordSegment segment) {
  const std::uint32_t file = placed(part, chunk).file;
  (void)place(part, chunk, {file, segment});
}

namespace {

// Writes n records of `bytes` each, made by encode(k, at), as the next segment of `file`.
template <class Encode>
format::Result<format::RecordSegment> write_records(format::RecordSegmentFile& file, std::uint32_t kind, std::uint32_t bytes,
                                                    std::size_t n, Encode&& encode) {
  auto writer = format::RecordWriter::create_in(file, kind, bytes);
  if (!writer) return writer.status();
  std::vector<std::byte> buffer(n * bytes);
  for (std::size_t k = 0; k < n; ++k) encode(k, buffer.data() + k * bytes);
  GM_RETURN_IF_ERROR((*writer)->append(buffer));
  GM_RETURN_IF_ERROR((*writer)->finish());
  return (*writer)->segment();
}

// Reads a record file that must hold exactly `expect` records, calling decode(at) for each.
template <class Decode>
Status read_records(const std::string& path, format::RecordSegment segment, std::uint32_t kind, std::uint32_t bytes,
                    std::uint64_t expect, Decode&& decode) {
  if (expect == 0) return {};
  auto reader = format::RecordReader::open(path, kind, bytes, segment);
  if (!reader) return reader.status();
  if ((*reader)->records() != expect) return damaged(path + ": holds another number of records than were written");
  std::uint64_t seen = 0;
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    for (std::size_t k = 0; k + bytes <= frame->size(); k += bytes, ++seen) decode(frame->data() + k);
  }
  if (seen != expect) return damaged(path + ": holds another number of records than were written");
  return {};
}
}  // namespace

using Lease = format::RecordSegmentPool::Lease;

Status PieceJoinFiles::write_face_pieces(std::uint32_t chunk, const ChunkMesh& mesh, const std::vector<std::uint32_t>& piece_index) {
  if (chunk >= chunks_ || piece_index.size() != mesh.triangles.size())
    return Status::error(Code::kProcessing, "stitch", "face pieces of chunk " + std::to_string(chunk) + " do not fit");
  std::vector<std::uint32_t> owned;
  std::uint32_t pieces = 0;
  for (std::size_t f = 0; f < piece_index.size(); ++f) {
    if (!mesh.owned_face[f]) continue;
    owned.push_back(piece_index[f]);
    pieces = std::max(pieces, piece_index[f] + 1);
  }
  Lease lease(*segments_);
  GM_RETURN_IF_ERROR(lease.status());
  auto segment = write_records(lease.file(), kFacePieceRecordKind, kFacePieceRecordBytes, owned.size(),
                               [&](std::size_t k, std::byte* at) { std::memcpy(at, &owned[k], 4); });
  if (!segment) return segment.status();
  std::lock_guard lock(mutex_);
  pieces_of_chunk_[chunk] = pieces;
  GM_RETURN_IF_ERROR(place(Part::kFacePieces, chunk, {lease.index(), *segment}));
  bytes_written_ += segment->bytes;
  return {};
}

Status PieceJoinFiles::read_face_pieces(std::uint32_t chunk, const ChunkMesh& mesh, std::vector<std::uint32_t>& piece_index) const {
  if (chunk >= chunks_) return damaged("face pieces of chunk " + std::to_string(chunk) + ", which does not exist");
  std::uint64_t owned = 0;
  for (std::uint8_t o : mesh.owned_face) owned += o;
  piece_index.assign(mesh.triangles.size(), 0xFFFFFFFFu);
  std::size_t f = 0;
  bool bad_index = false;
  const Placed at_file = placed(Part::kFacePieces, chunk);
  if (at_file.file == Placed{}.file) return damaged("face pieces of chunk " + std::to_string(chunk) + " were never written");
  const std::string path = segment_path(at_file.file);
  GM_RETURN_IF_ERROR(read_records(path, at_file.segment, kFacePieceRecordKind, kFacePieceRecordBytes, owned,
                                  [&](const std::byte* at) {
                                    while (f < mesh.owned_face.size() && !mesh.owned_face[f]) ++f;
                                    std::uint32_t index;
                                    std::memcpy(&index, at, 4);
                                    if (index >= pieces_of_chunk_[chunk]) bad_index = true;
                                    if (f < piece_index.size()) piece_index[f++] = index;
                                  }));
  if (bad_index) return damaged(path + ": a face names a piece the chunk does not have");
  return {};
}

Status PieceJoinFiles::read_candidates(std::uint32_t chunk, std::vector<CandidateRecord>& out) const {
  out.clear();
  if (chunk >= chunks_) return damaged("candidates of chunk " + std::to_string(chunk) + ", which does not exist");
  if (candidate_entries_[chunk] == 0) return {};
  const Placed at_file = placed(Part::kCandidates, chunk);
  out.reserve(candidate_entries_[chunk]);
  std::uint64_t entries = 0;
  GM_RETURN_IF_ERROR(read_records(segment_path(at_file.file), at_file.segment, kCandidateRecordKind, kCandidateRecordBytes,
                                  candidate_entries_[chunk], [&](const std::byte* at) {
                                    std::uint32_t v[2];
                                    std::memcpy(v, at, 8);
                                    out.push_back({v[0], static_cast<std::uint32_t>(std::min<std::uint64_t>(entries, 0xFFFFFFFFu)), v[1]});
                                    entries += v[1];
                                  }));
  if (entries != star_entries_[chunk])
    return damaged(segment_path(at_file.file) + ": the candidates of chunk " + std::to_string(chunk) + " name " +
                   std::to_string(entries) + " star entries, its star file holds " + std::to_string(star_entries_[chunk]));
  return {};
}

Status PieceJoinFiles::read_pieces(std::uint32_t chunk, std::vector<PieceRecord>& pieces,
                                   std::vector<PieceAdjacencyRecord>& adjacency) const {
  adjacency.clear();
  GM_RETURN_IF_ERROR(read_pieces(chunk, pieces));
  adjacency.reserve(adjacency_entries_[chunk]);
  const Placed at_file = placed(Part::kAdjacency, chunk);
  return read_records(segment_path(at_file.file), at_file.segment, kPieceAdjacencyRecordKind, kPieceAdjacencyRecordBytes,
                      adjacency_entries_[chunk], [&](const std::byte* at) {
                        adjacency.push_back({get_u64(at), get_u64(at + 8), get_u64(at + 16)});
                      });
}

Status PieceJoinFiles::read_pieces(std::uint32_t chunk, std::vector<PieceRecord>& pieces) const {
  pieces.clear();
  if (chunk >= chunks_) return damaged("pieces of chunk " + std::to_string(chunk) + ", which does not exist");
  pieces.reserve(piece_entries_[chunk]);
  const Placed at_file = placed(Part::kPieces, chunk);
  GM_RETURN_IF_ERROR(read_records(segment_path(at_file.file), at_file.segment, kPieceRecordKind, kPieceRecordBytes, piece_entries_[chunk],
                                  [&](const std::byte* at) {
                                    PieceRecord r;
                                    r.piece = get_u64(at);
                                    r.min_face = get_u64(at + 8);
                                    r.faces = get_u64(at + 16);
                                    std::memcpy(&r.label, at + 24, 4);
                                    std::memcpy(r.area.data(), at + 28, 24);
                                    r.min_key = get_u64(at + 52);
                                    pieces.push_back(r);
                                  }));
  return {};
}

Status PieceJoinFiles::read_stars(std::uint32_t chunk, std::vector<StarEntry>& out) const {
  out.clear();
  if (chunk >= chunks_) return damaged("stars of chunk " + std::to_string(chunk) + ", which does not exist");
  const std::uint64_t expect = star_entries_[chunk];
  if (expect == 0) return {};
  const Placed at_file = placed(Part::kStars, chunk);
  const std::string path = segment_path(at_file.file);
  auto reader = format::RecordReader::open(path, kStarRecordKind, kStarRecordBytes, at_file.segment);
  if (!reader) return reader.status();
  if ((*reader)->records() != expect) return damaged(path + ": holds another number of star entries than were written");
  out.reserve(expect);
  for (;;) {
    auto frame = (*reader)->next();
    if (!frame) return frame.status();
    if (frame->empty()) break;
    for (std::size_t k = 0; k + kStarRecordBytes <= frame->size(); k += kStarRecordBytes) {
      StarEntry e;
      std::uint32_t owners[2];
      e.face = get_u64(frame->data() + k);
      e.next = get_u64(frame->data() + k + 8);
      std::memcpy(owners, frame->data() + k + 16, 8);
      e.owner = owners[0];
      e.next_owner = owners[1] & 0x7FFFFFFFu;
      e.entering_break = owners[1] >> 31;
      out.push_back(e);
    }
  }
  if (out.size() != expect) return damaged(path + ": holds another number of star entries than were written");
  return {};
}

Status PieceJoinFiles::write_answer_file(std::uint32_t chunk, std::span<const FacePieceRecord> answers) {
  Lease lease(*segments_);
  GM_RETURN_IF_ERROR(lease.status());
  return write_answer_file(chunk, answers, lease);
}

Status PieceJoinFiles::write_answer_file(std::uint32_t chunk, std::span<const FacePieceRecord> answers, Lease& lease) {
  // Ascending faces and their pieces (mostly a few per chunk) as differences, column by column.
  format::RecordWriterOptions options;
  options.frame_bytes = kAnswerFrameBytes;
  options.columns = {{8, true}, {8, true}};
  auto writer = format::RecordWriter::create_in(lease.file(), kFaceAnswerRecordKind, kFaceAnswerRecordBytes, options);
  if (!writer) return writer.status();
  const std::size_t per_frame = (*writer)->frame_limit() / kFaceAnswerRecordBytes;
  std::vector<std::byte> bytes(std::min(answers.size(), per_frame) * kFaceAnswerRecordBytes);
  for (std::size_t at = 0; at < answers.size(); at += per_frame) {
    const std::size_t n = std::min(per_frame, answers.size() - at);
    for (std::size_t i = 0; i < n; ++i) {
      put_u64(bytes.data() + i * kFaceAnswerRecordBytes, answers[at + i].face);
      put_u64(bytes.data() + i * kFaceAnswerRecordBytes + 8, answers[at + i].piece);
    }
    GM_RETURN_IF_ERROR((*writer)->append(std::span(bytes.data(), n * kFaceAnswerRecordBytes)));
  }
  GM_RETURN_IF_ERROR((*writer)->finish());
  std::lock_guard lock(mutex_);
  answered_[chunk] = 1;
  GM_RETURN_IF_ERROR(place(Part::kAnswers, chunk, {lease.index(), (*writer)->segment()}));
  answer_records_ += answers.size();
  bytes_written_ += (*writer)->bytes_written();
  return {};
}

Status PieceJoinFiles::spill(std::uint32_t chunk, ChunkPieces& pieces) {
  if (chunk >= chunks_) return Status::error(Code::kProcessing, "stitch", "chunk " + std::to_string(chunk) + " out of range");
  for (std::size_t k = 1; k < pieces.border_faces.size(); ++k) {
    if (pieces.border_faces[k].face <= pieces.border_faces[k - 1].face)
      return Status::error(Code::kProcessing, "stitch", "face answers of chunk " + std::to_string(chunk) + " not ascending");
  }
  Lease lease(*segments_);
  GM_RETURN_IF_ERROR(lease.status());
  GM_RETURN_IF_ERROR(write_answer_file(chunk, pieces.border_faces, lease));
  std::vector<FacePieceRecord>().swap(pieces.border_faces);  // "= {}" would keep the capacity
  // A part written: its place and record count, under the lock.
  auto stored = [&](Part part, std::vector<std::uint64_t>& entries, std::size_t n,
                    format::Result<format::RecordSegment>& segment) -> Status {
    if (!segment) return segment.status();
    std::lock_guard lock(mutex_);
    entries[chunk] = n;
    bytes_written_ += segment->bytes;
    return place(part, chunk, {lease.index(), *segment});
  };
  if (!pieces.star.empty()) {
    auto segment = write_records(lease.file(), kStarRecordKind, kStarRecordBytes, pieces.star.size(),
                                 [&](std::size_t k, std::byte* at) {
                                   const StarEntry& e = pieces.star[k];
                                   const std::uint32_t owners[2] = {e.owner, e.next_owner | std::uint32_t{e.entering_break} << 31};
                                   put_u64(at, e.face);
                                   put_u64(at + 8, e.next);
                                   std::memcpy(at + 16, owners, 8);
                                 });
    GM_RETURN_IF_ERROR(stored(Part::kStars, star_entries_, pieces.star.size(), segment));
  }
  std::vector<StarEntry>().swap(pieces.star);
  if (!pieces.candidates.empty()) {
    std::uint64_t entries = 0;
    for (std::size_t k = 0; k < pieces.candidates.size(); ++k) {
      if (pieces.candidates[k].first != entries) return Status::error(Code::kProcessing, "stitch", "candidates' stars not in order");
      entries += pieces.candidates[k].count;
    }
    if (entries != star_entries_[chunk]) return Status::error(Code::kProcessing, "stitch", "candidates' stars not all spilled");
    auto segment = write_records(lease.file(), kCandidateRecordKind, kCandidateRecordBytes, pieces.candidates.size(),
                                 [&](std::size_t k, std::byte* at) {
                                   const std::uint32_t v[2] = {pieces.candidates[k].vertex, pieces.candidates[k].count};
                                   std::memcpy(at, v, 8);
                                 });
    GM_RETURN_IF_ERROR(stored(Part::kCandidates, candidate_entries_, pieces.candidates.size(), segment));
  }
  std::vector<CandidateRecord>().swap(pieces.candidates);
  if (!pieces.pieces.empty()) {
    auto segment = write_records(lease.file(), kPieceRecordKind, kPieceRecordBytes, pieces.pieces.size(),
                               [&](std::size_t k, std::byte* at) {
                                 const PieceRecord& r = pieces.pieces[k];
                                 put_u64(at, r.piece);
                                 put_u64(at + 8, r.min_face);
                                 put_u64(at + 16, r.faces);
                                 std::memcpy(at + 24, &r.label, 4);
                                 std::memcpy(at + 28, r.area.data(), 24);
                                 put_u64(at + 52, r.min_key);
                               });
    GM_RETURN_IF_ERROR(stored(Part::kPieces, piece_entries_, pieces.pieces.size(), segment));
  }
  if (!pieces.adjacency.empty()) {
    auto segment = write_records(lease.file(), kPieceAdjacencyRecordKind, kPieceAdjacencyRecordBytes,
                               pieces.adjacency.size(), [&](std::size_t k, std::byte* at) {
                                 const PieceAdjacencyRecord& r = pieces.adjacency[k];
                                 put_u64(at, r.a);
                                 put_u64(at + 8, r.b);
                                 put_u64(at + 16, r.edges);
                               });
    GM_RETURN_IF_ERROR(stored(Part::kAdjacency, adjacency_entries_, pieces.adjacency.size(), segment));
  }
  std::vector<PieceRecord>().swap(pieces.pieces);
  std::vector<PieceAdjacencyRecord>().swap(pieces.adjacency);
  // Border edges grouped by bucket (a counting sort), then appended under the lock.
  const std::size_t nb = bucket_paths_.size();
  std::vector<std::size_t> start(nb + 1, 0);
  std::vector<std::uint32_t> bucket_of(pieces.border.size());
  for (std::size_t k = 0; k < pieces.border.size(); ++k) {
    bucket_of[k] = static_cast<std::uint32_t>(border_bucket(pieces.border[k].face, pieces.border[k].other, nb));
    ++start[bucket_of[k] + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::byte> bytes(pieces.border.size() * kBorderEdgeRecordBytes);
  std::vector<std::size_t> at(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < pieces.border.size(); ++k)
    encode(pieces.border[k], bytes.data() + at[bucket_of[k]]++ * kBorderEdgeRecordBytes);
  std::lock_guard lock(mutex_);
  if (finished_) return Status::error(Code::kProcessing, "stitch", "border edges after finish");
  for (std::size_t b = 0; b < nb; ++b) {
    if (start[b + 1] == start[b]) continue;
    GM_RETURN_IF_ERROR(writers_[b]->append(std::span(bytes.data() + start[b] * kBorderEdgeRecordBytes,
                                                     (start[b + 1] - start[b]) * kBorderEdgeRecordBytes)));
    bucket_records_[b] += start[b + 1] - start[b];
  }
  border_records_ += pieces.border.size();
  std::vector<BorderEdgeRecord>().swap(pieces.border);
  return {};
}

Status PieceJoinFiles::finish() {
  {
    std::lock_guard lock(mutex_);
    if (finished_) return {};
    finished_ = true;
    for (auto& writer : writers_) {
      GM_RETURN_IF_ERROR(writer->finish());
      bytes_written_ += writer->bytes_written();
    }
    writers_.clear();
    compressor_.reset();
  }
  for (std::uint32_t c = 0; c < chunks_; ++c)
    if (!answered_[c]) GM_RETURN_IF_ERROR(write_answer_file(c, {}));
  return {};
}

Status PieceJoinFiles::join_border_edges(
    const MemoryBudget& budget,
    const std::function<Status(const BorderEdgeRecord&, const BorderEdgeRecord&)>& on_edge,
    std::uint32_t threads) const {
  if (!finished_) return Status::error(Code::kProcessing, "stitch", "border edges joined before finish");
  const std::size_t nb = bucket_paths_.size();
  const std::uint64_t per = bucket_bytes(budget);
  // A bucket larger than the aim is read once per part, each read keeping one part.
  struct Task {
    std::size_t bucket, part, parts;
  };
  std::vector<Task> tasks;
  for (std::size_t b = 0; b < nb; ++b) {
    const std::uint64_t bytes = bucket_records_[b] * sizeof(BorderEdgeRecord);
    const std::size_t parts = static_cast<std::size_t>(std::max<std::uint64_t>((bytes + per - 1) / per, 1));
    for (std::size_t part = 0; part < parts; ++part) tasks.push_back({b, part, parts});
  }
  // One task's edges, checked and sorted by (face pair, face): the two sides of an edge side by side.
  auto load = [&](const Task& t, std::vector<BorderEdgeRecord>& edges) -> Status {
    auto reader = format::RecordReader::open(bucket_paths_[t.bucket], kBorderEdgeRecordKind, kBorderEdgeRecordBytes);
    if (!reader) return reader.status();
    edges.clear();
    // Sized from the count written (a part's share, hashed, with an eighth to spare), not by
    // doubling: a doubling held the old and the new array at once, 1.5-3 times the bucket.
    const std::uint64_t expected = bucket_records_[t.bucket] / t.parts;
    edges.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(
        t.parts > 1 ? expected + expected / 8 + 64 : bucket_records_[t.bucket], per / sizeof(BorderEdgeRecord) * 2)));
    for (;;) {
      auto frame = (*reader)->next();
      if (!frame) return frame.status();
      if (frame->empty()) break;
      for (std::size_t at = 0; at + kBorderEdgeRecordBytes <= frame->size(); at += kBorderEdgeRecordBytes) {
        const std::byte* r = frame->data() + at;
        BorderEdgeRecord e;
        e.face = get_u64(r);
        e.other = get_u64(r + 8);
        e.piece = get_u64(r + 16);
        const auto feature = std::to_integer<std::uint8_t>(r[24]);
        if (feature > 1) return damaged(bucket_paths_[t.bucket] + ": a border edge with feature byte " + std::to_string(feature));
        e.feature = feature == 1;
        if (border_bucket(e.face, e.other, nb) != t.bucket)
          return damaged(bucket_paths_[t.bucket] + ": the edge between faces " + std::to_string(e.face) + " and " +
                         std::to_string(e.other) + " is in the wrong bucket");
        if (t.parts > 1 && border_bucket_part(e.face, e.other, t.parts) != t.part) continue;
        edges.push_back(e);
      }
    }
    std::sort(edges.begin(), edges.end(), [](const BorderEdgeRecord& x, const BorderEdgeRecord& y) {
      return edge_key(x) != edge_key(y) ? edge_key(x) < edge_key(y) : x.face < y.face;
    });
    return {};
  };
  auto join = [&](const std::vector<BorderEdgeRecord>& edges) -> Status {
    for (std::size_t k = 0; k < edges.size(); k += 2) {
      if (k + 1 >= edges.size() || edge_key(edges[k]) != edge_key(edges[k + 1]) ||
          (k + 2 < edges.size() && edge_key(edges[k + 2]) == edge_key(edges[k])) || edges[k].face == edges[k + 1].face) {
        return damaged("border edge between faces " + std::to_string(edges[k].face) + " and " +
                       std::to_string(edges[k].other) + " is not seen once from each side");
      }
      if (edges[k].feature != edges[k + 1].feature) {
        return damaged("the two sides of the edge between faces " + std::to_string(edges[k].face) + " and " +
                       std::to_string(edges[k].other) + " disagree on whether it is a feature edge");
      }
      GM_RETURN_IF_ERROR(on_edge(edges[k], edges[k + 1]));
    }
    return {};
  };
  if (threads <= 1 || tasks.size() <= 1) {
    std::vector<BorderEdgeRecord> edges;
    for (const Task& t : tasks) {
      GM_RETURN_IF_ERROR(load(t, edges));
      GM_RETURN_IF_ERROR(join(edges));
    }
    return {};
  }
  // Tasks read and sorted on the threads, at most `threads` in flight, joined one at a time in
  // task order (so on_edge sees the serial loop's order, and the first error in that order is
  // the one returned).
  struct Loaded {
    std::vector<BorderEdgeRecord> edges;
    Status status;
  };
  std::size_t next = 0;
  Status result;
  std::atomic<bool> failed{false};
  tbb::parallel_pipeline(
      threads,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next == tasks.size() || failed) {
                                              fc.stop();
                                              return 0;
                                            }
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, std::shared_ptr<Loaded>>(tbb::filter_mode::parallel,
                                                                 [&](std::size_t k) {
                                                                   auto loaded = std::make_shared<Loaded>();
                                                                   if (!failed) loaded->status = load(tasks[k], loaded->edges);
                                                                   return loaded;
                                                                 }) &
          tbb::make_filter<std::shared_ptr<Loaded>, void>(tbb::filter_mode::serial_in_order,
                                                          [&](const std::shared_ptr<Loaded>& loaded) {
                                                            if (!result.is_ok()) return;
                                                            result = loaded->status.is_ok() ? join(loaded->edges) : loaded->status;
                                                            if (!result.is_ok()) failed = true;
                                                          }));
  return result;
}

Status PieceJoinFiles::look_up(std::span<const std::uint32_t> owners, std::span<const std::uint64_t> faces,
                               std::span<PieceId> pieces) const {
  if (owners.size() != faces.size() || pieces.size() != faces.size())
    return Status::error(Code::kProcessing, "stitch", "look_up: spans of different sizes");
  std::vector<std::uint32_t> order(faces.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return owners[a] != owners[b] ? owners[a] < owners[b] : faces[a] < faces[b];
  });
  for (std::size_t first = 0; first < order.size();) {
    const std::uint32_t owner = owners[order[first]];
    std::size_t last = first;
    while (last < order.size() && owners[order[last]] == owner) ++last;
    if (owner >= chunks_) return damaged("a face owned by chunk " + std::to_string(owner) + ", which does not exist");
    const Placed at_file = placed(Part::kAnswers, owner);
    if (at_file.file == Placed{}.file) return damaged("the face answers of chunk " + std::to_string(owner) + " were never written");
    const std::string path = segment_path(at_file.file);
    auto reader = format::RecordReader::open(path, kFaceAnswerRecordKind, kFaceAnswerRecordBytes, at_file.segment);
    if (!reader) return reader.status();
    std::size_t at = first;
    std::uint64_t previous = 0;
    bool any = false;
    while (at < last) {
      auto frame = (*reader)->next();
      if (!frame) return frame.status();
      if (frame->empty()) break;
      for (std::size_t k = 0; k + kFaceAnswerRecordBytes <= frame->size() && at < last; k += kFaceAnswerRecordBytes) {
        const std::uint64_t face = get_u64(frame->data() + k);
        const PieceId piece = get_u64(frame->data() + k + 8);
        if (any && face <= previous) return damaged(path + ": face answers not ascending at face " + std::to_string(face));
        if (piece >> 32 != owner || piece == kNoPiece)
          return damaged(path + ": face " + std::to_string(face) + " answered with a piece of another chunk");
        any = true;
        previous = face;
        for (; at < last && faces[order[at]] < face; ++at) pieces[order[at]] = kNoPiece;
        for (; at < last && faces[order[at]] == face; ++at) pieces[order[at]] = piece;
      }
    }
    for (; at < last; ++at) pieces[order[at]] = kNoPiece;
    first = last;
  }
  return {};
}

}  // namespace gaussmesh::stream
