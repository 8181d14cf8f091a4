// The chunked finish (docs/finish.md, "Out of core: the chunked finish"): the quadric finish on
// the input itself when the input is too large to collapse whole within --memory. Rounds of
// collapses over pieces that each fit the budget, in the manner of Wu & Kobbelt's stream
// decimation and of clustered LOD with locked borders:
//   round 1     each partition chunk's owned faces, cut into pieces (finish_pieces.h), collapsed
//               to kRoundOneShare × the target's share with every vertex shared between pieces
//               locked;
//   round 2, …  what is left, grouped again into pieces of cells of a grid shifted against the
//               last round's, so that its locked borders lie inside them; each collapsed to its
//               share of the target, with only the vertices the new pieces share locked.
// A vertex of a round belongs to the piece of its cell, a face to the piece of its lowest-id
// corner (the partition's rule), so that a piece that owns a vertex reads every piece of the
// last round holding it, and knows its faces, its whole quadric and whether it is shared.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/record_file.h"
#include "format/status.h"
#include "stream/core/memory_budget.h"
#include "stream/core/mesh.h"
#include "stream/finish/quadric_finish.h"
#include "stream/partition/chunk_partition.h"

namespace gaussmesh::stream {

// Round 1 collapses each piece to this many times its share of the face target, so that round
// 2 has room to place the rest where the error is least.
inline constexpr double kRoundOneShare = 4;
// A piece's working set per face at its peak (the collapse mesh, the quadrics, the queue, the records);
// a chunk file's, per face, while its pieces are cut.
inline constexpr std::uint64_t kPieceBytesPerFace = 400;
inline constexpr std::uint64_t kChunkFileBytesPerFace = 80;

// The partition chunk size for a run that may take the chunked finish: one chunk's owned faces
// in one piece within a thread's share of the budget.
std::uint64_t chunked_finish_chunk_faces(const MemoryBudget& budget);

// Round 2 aims at the face target only when the faces at its locked vertices are at most a share
// of the target: those faces keep round 1's density (several times the target's), which the
// output then spends on the pieces' borders instead of where the error is. Otherwise round 2
// takes the free faces to twice the target's density and leaves the target to round 3, whose
// borders lie elsewhere. The share is a half, or a tenth when what round 2 would leave (its
// locked faces and twice the target) fits one piece: round 3 is then one piece with no locked
// vertex at all, and costs little (docs/finish.md).
inline constexpr double kLastRoundLockedShare = 0.5;
inline constexpr double kLastRoundLockedShareBeforeOnePiece = 0.1;

struct ChunkedFinishOptions {
  FinishOptions finish;
  std::uint32_t threads = 1;
  double last_round_locked_share_before_one_piece = kLastRoundLockedShareBeforeOnePiece;
  MemoryBudget memory;
  std::function<void(const char*, std::size_t, std::size_t)> progress;  // (round, pieces done, pieces)
};

// Rounds after the first stop once the target is met, when one removes under 1 % of the faces
// it had, or after this many.
inline constexpr int kMaxRounds = 6;

// The output of the chunked finish, read back from the last round's files (each vertex from the
// piece that owns it, in piece order; then each piece's faces) without holding the mesh: a
// writer streams it (format::write_ply_parts), or gathers it into memory. vertices() comes
// before faces(); either may be read again (the attribute transfer reads them before the writer
// does): the first vertices() writes the units' owned ids that faces() looks corners up in. The
// files live in the partition's directory: own() keeps it until the output is destroyed.
class ChunkedOutput : public format::MeshParts {
 public:
  struct Rounds;
  ChunkedOutput(std::unique_ptr<Rounds> rounds, std::uint64_t vertices, std::string ids_prefix);
  ~ChunkedOutput() override;
  std::uint64_t vertex_count() const override { return vertices_; }
  std::uint64_t face_count() const override;
  format::Status vertices(const std::function<format::Status(std::span<const format::Vec3f>)>& batch) override;
  format::Status faces(const std::function<format::Status(std::span<const format::Triangle>)>& batch) override;
  void own(Partition partition) { partition_ = std::move(partition); }
  const Partition& partition() const { return partition_; }  // the one own() gave

 private:
  Partition partition_;  // declared first, so that its directory goes last
  std::unique_ptr<Rounds> rounds_;
  std::uint64_t vertices_ = 0;
  std::unique_ptr<format::RecordSegmentPool> ids_;  // each unit's owned ids, written by vertices()
  std::vector<format::RecordSegment> id_segments_;
  std::uint32_t ids_file_ = 0;
  std::vector<std::uint64_t> offsets_;  // output index of each unit's first owned vertex
};

struct ChunkedFinish {
  std::unique_ptr<ChunkedOutput> output;
  std::uint64_t collapses = 0, refused = 0, over_error = 0;
  double estimated_error = 0;  // input units
  std::uint64_t input_faces = 0;  // the owned faces without a repeated corner
  // Per round: its pieces, the faces left after it, its seconds; from round 2 on, the faces at
  // its locked vertices when it shared the target by them (0 when it did not need to).
  std::vector<std::uint64_t> round_pieces, round_faces, round_locked_faces;
  std::vector<double> seconds_rounds;
  std::uint64_t largest_piece = 0;  // faces of the largest piece after round 1
  std::uint64_t unheld_pieces = 0;  // pieces that are not oriented manifolds, left as they were
};

// The rounds over the chunks of `partition` (at least two overlap rings); the output stays in
// files in partition.dir, read through ChunkedFinish::output.
format::Result<ChunkedFinish> chunked_finish(const Partition& partition, const ChunkedFinishOptions& options);

}  // namespace gaussmesh::stream
