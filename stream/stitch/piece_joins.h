// The on-disk joins of the stitch's pieces step (docs/stitch.md): the
// border-edge records of every chunk, bucketed by face pair into temporary record files and
// joined one bucket at a time, and every chunk's face answers (face -> piece) in a record file
// of its own (a segment, below), read on demand by whoever needs the piece of a face that chunk
// owns. Nothing here grows with the length of the chunk borders in memory: a bucket at a time,
// a frame at a time.
//
// Files live in a directory the caller owns and removes (the partition's temp dir). The
// per-chunk record files (answers, stars, pieces, piece adjacency, face pieces; and, through
// segments(), the sample pass's loop chunks and the loops pass's run vertices) are segments of a
// few shared files, `segments-N.rec` (format::RecordSegmentPool): one per thread writing at once, not one per chunk
// and kind. Everything read back is untrusted: a damaged file, an edge seen other than exactly
// twice, two sides that disagree, an answer out of order or from the wrong chunk is a kBadInput
// error, never a crash.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "format/record_file.h"
#include "format/status.h"
#include "stream/core/memory_budget.h"
#include "stream/stitch/chunk_pieces.h"

namespace gaussmesh::stream {

// Record kinds (format/record_file.h): "GMBE" and "GMFA" read as little-endian u32.
inline constexpr std::uint32_t kBorderEdgeRecordKind = 0x45424D47u;
inline constexpr std::uint32_t kFaceAnswerRecordKind = 0x41464D47u;
// Bytes of one border-edge record: u64 face, u64 other, u64 piece, u8 feature (0 or 1).
inline constexpr std::uint32_t kBorderEdgeRecordBytes = 25;
// Bytes of one face-answer record: u64 face, u64 piece.
inline constexpr std::uint32_t kFaceAnswerRecordBytes = 16;
// Candidates' star entries of one chunk ("GMST"): u64 face, u64 next face (all ones for a
// break), u32 owner of face, u32 owner of next (bits 0..30) | entering edge is a break (bit 31).
inline constexpr std::uint32_t kStarRecordKind = 0x54534D47u;
inline constexpr std::uint32_t kStarRecordBytes = 24;
// The candidates of one chunk ("GMCD"), ascending vertex: u32 global vertex id, u32 star entries
// (the chunk's star file holds them candidate after candidate).
inline constexpr std::uint32_t kCandidateRecordKind = 0x44434D47u;
inline constexpr std::uint32_t kCandidateRecordBytes = 8;
// A chunk's pieces ("GMPC": u64 piece id, u64 first face, u64 faces, u32 label, 3 × f64 vector
// area — zero unless the sample pass wrote a loop chunk, for which the loops pass reads the pieces
// again —, u64 the first face's key; PieceRecord) and its
// manifold feature edges between two of its pieces ("GMPA": u64 piece a, u64 piece b, u64 edges).
inline constexpr std::uint32_t kPieceRecordKind = 0x43504D47u;
inline constexpr std::uint32_t kPieceRecordBytes = 60;
inline constexpr std::uint32_t kPieceAdjacencyRecordKind = 0x41504D47u;
inline constexpr std::uint32_t kPieceAdjacencyRecordBytes = 24;
// The piece of each owned face of a chunk, in the chunk's face order ("GMFP": u32 index of the
// piece in its chunk): the chains, loops and fetch passes read it instead of labelling the chunk
// again.
inline constexpr std::uint32_t kFacePieceRecordKind = 0x50464D47u;
inline constexpr std::uint32_t kFacePieceRecordBytes = 4;
// More buckets than this are never made (each holds a descriptor and a pending frame).
inline constexpr std::size_t kMaxBorderBuckets = 256;

// How many buckets for about `expected_records` border-edge records so that one bucket holds
// about bucket_bytes(budget) in memory: at least 1, at most kMaxBorderBuckets. A bucket
// that comes out larger is joined in several reads (join_border_edges), so this is a guess that
// costs time, never memory, when wrong.
std::size_t border_bucket_count(std::uint64_t expected_records, const MemoryBudget& budget);
// The in-memory size aimed at for one bucket: 1/16 of the budget, at least 1 MiB.
std::uint64_t bucket_bytes(const MemoryBudget& budget);

class PieceJoinFiles {
 public:
  // The per-chunk record files, each a segment of a segments-N.rec file.
  enum class Part { kAnswers, kStars, kPieces, kAdjacency, kFacePieces, kCandidates };
  static constexpr std::size_t kParts = static_cast<std::size_t>(Part::kCandidates) + 1;  // kCandidates is last
  struct Placed {
    std::uint32_t file = 0xFFFFFFFFu;  // segments-N.rec file; all ones: not written
    format::RecordSegment segment;
  };

  // Creates `buckets` (1..kMaxBorderBuckets) empty bucket files under dir; answer files are
  // made by write_answers. Errors: kOutput when a file cannot be created; kUsage for a bucket
  // count out of range.
  // budget (unlimited: no bound) bounds the bucket writers' pending frames together to 1/16 of
  // it: each frame holds 4-32 KiB.
  static format::Result<std::unique_ptr<PieceJoinFiles>> create(const std::string& dir, std::size_t chunks,
                                                                std::size_t buckets, const MemoryBudget& budget = {});
  ~PieceJoinFiles();
  PieceJoinFiles(const PieceJoinFiles&) = delete;
  PieceJoinFiles& operator=(const PieceJoinFiles&) = delete;

  // Moves one chunk's border edges to the buckets, its face answers (border_faces, strictly
  // ascending face — as find_chunk_pieces emits them) to the chunk's answer file and its
  // candidates to its candidate file and their star entries to its star file (read back by
  // read_candidates and read_stars), its pieces and piece
  // adjacency to two more files (read_pieces), and clears those vectors. Thread-safe for distinct chunks; once per chunk. Errors: kOutput (disk full),
  // kProcessing when the answers are not ascending.
  format::Status spill(std::uint32_t chunk, ChunkPieces& pieces);
  // Closes the bucket files; required before join_border_edges. Chunks that never called spill
  // get an empty answer file.
  format::Status finish();

  // Joins the two sides of every border edge, a bucket at a time, holding about
  // bucket_bytes(budget) of records: on_edge(side of the lower face, side of the higher
  // face) once per edge, in no particular order. With threads > 1 the buckets are read and
  // sorted on that many threads (up to `threads` of them in memory at once) while on_edge runs
  // on one thread at a time, in the order one thread would call it. Errors: the files'
  // (kBadInput), an edge not seen exactly once from each side or whose sides disagree on the
  // feature bit (kBadInput), and on_edge's; the first in that order.
  format::Status join_border_edges(const MemoryBudget& budget,
                                   const std::function<format::Status(const BorderEdgeRecord&, const BorderEdgeRecord&)>&
                                       on_edge,
                                   std::uint32_t threads = 1) const;

  // The pieces of faces: faces[k] owned by chunk owners[k] gets pieces[k] from that chunk's
  // answers, or kNoPiece when it has none for it. Each owner's file is read once, a frame at a
  // time. Memory: an index over the requests and one frame. Errors: an owner out of range, a
  // damaged file, answers not strictly ascending or naming a piece of another chunk (kBadInput).
  format::Status look_up(std::span<const std::uint32_t> owners, std::span<const std::uint64_t> faces,
                         std::span<PieceId> pieces) const;

  // The star entries spill() took from chunk (none if it was not spilled). Errors: a damaged
  // file, or one holding another count of entries than was written (kBadInput).
  format::Status read_stars(std::uint32_t chunk, std::vector<StarEntry>& out) const;
  // The candidates spill() took from chunk, `first` counted from 0 in file order. Errors as
  // read_stars, and a star count that does not add up to the star file's (kBadInput).
  format::Status read_candidates(std::uint32_t chunk, std::vector<CandidateRecord>& out) const;
  std::uint64_t star_entries(std::uint32_t chunk) const { return chunk < chunks_ ? star_entries_[chunk] : 0; }
  std::uint64_t candidate_entries(std::uint32_t chunk) const { return chunk < chunks_ ? candidate_entries_[chunk] : 0; }
  // piece_index (find_chunk_pieces: per local face, its piece's index in the chunk, or all ones
  // for faces the chunk does not own) to the chunk's face-piece file: only the owned faces'.
  // Thread-safe for distinct chunks. Errors: kOutput.
  format::Status write_face_pieces(std::uint32_t chunk, const ChunkMesh& mesh, const std::vector<std::uint32_t>& piece_index);
  // Reads it back into piece_index for the same chunk mesh. Errors: a damaged file, one that
  // disagrees with the mesh's owned faces, an index beyond the chunk's pieces (kBadInput).
  format::Status read_face_pieces(std::uint32_t chunk, const ChunkMesh& mesh, std::vector<std::uint32_t>& piece_index) const;
  // The pieces and piece adjacency spill() took from chunk. Errors as read_stars.
  format::Status read_pieces(std::uint32_t chunk, std::vector<PieceRecord>& pieces,
                             std::vector<PieceAdjacencyRecord>& adjacency) const;
  // The pieces alone (the loops pass reads a loop chunk's pieces for their areas).
  format::Status read_pieces(std::uint32_t chunk, std::vector<PieceRecord>& pieces) const;
  std::uint64_t border_records() const { return border_records_; }
  std::uint64_t answer_records() const { return answer_records_; }
  std::uint64_t bytes_written() const { return bytes_written_; }  // compressed, every file
  std::size_t buckets() const { return bucket_paths_.size(); }
  // Where a chunk's part lies (file == all ones: not written) and the path of a segment file: for
  // tests that damage them.
  Placed placed(Part part, std::uint32_t chunk) const;
  std::string segment_path(std::uint32_t file) const { return segments_->path(file); }
  // The segment files (segments-N.rec), for other per-chunk record files of the same passes (loop chunks, loops).
  format::RecordSegmentPool& segments() { return *segments_; }
  // Points a chunk's part at another segment of the same file (tests append forged record files).
  void replace_segment_for_test(Part part, std::uint32_t chunk, format::RecordSegment segment);
  const std::string& bucket_path(std::size_t bucket) const { return bucket_paths_[bucket]; }

 private:
  PieceJoinFiles() = default;
  format::Status write_answer_file(std::uint32_t chunk, std::span<const FacePieceRecord> answers);
  format::Status write_answer_file(std::uint32_t chunk, std::span<const FacePieceRecord> answers,
                                   format::RecordSegmentPool::Lease& lease);
  // Records where a part went (under mutex_). kResources for a segment of 4 GiB or more.
  format::Status place(Part part, std::uint32_t chunk, const Placed& placed);

  std::string dir_;
  std::size_t chunks_ = 0;
  std::vector<std::string> bucket_paths_;
  std::vector<std::uint64_t> bucket_records_;
  std::unique_ptr<format::RecordCompressor> compressor_;  // shared by the bucket writers, under mutex_
  std::vector<std::unique_ptr<format::RecordWriter>> writers_;
  std::vector<std::uint8_t> answered_;  // per chunk: its answer file is written
  // Per chunk, per Part, where it is: 16 bytes (96 per chunk).
  struct Stored {
    std::uint64_t offset = 0;
    std::uint32_t bytes = 0;
    std::uint32_t file = 0xFFFFFFFFu;
  };
  std::vector<Stored> placed_;
  std::unique_ptr<format::RecordSegmentPool> segments_;  // the segment files (segments-N.rec)
  std::vector<std::uint64_t> star_entries_;  // per chunk: entries in its star file
  std::vector<std::uint64_t> candidate_entries_;  // per chunk: records in its candidate file
  std::vector<std::uint64_t> piece_entries_, adjacency_entries_;  // per chunk: spilled pieces, adjacency
  std::vector<std::uint64_t> pieces_of_chunk_;  // per chunk: its pieces (bound of its face pieces)
  std::mutex mutex_;
  std::uint64_t border_records_ = 0, answer_records_ = 0, bytes_written_ = 0;
  bool finished_ = false;
};

// The bucket of the edge between faces a and b (either order), of `buckets`; `part` of `parts`
// splits a bucket that is too large for one read. Exposed for tests.
std::size_t border_bucket(std::uint64_t a, std::uint64_t b, std::size_t buckets);
std::size_t border_bucket_part(std::uint64_t a, std::uint64_t b, std::size_t parts);

}  // namespace gaussmesh::stream
