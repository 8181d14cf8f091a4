// The ingest and partition passes of the out-of-core pipeline (docs/partition.md): ingest a mesh
// stream into spill files, cut its bounds into Morton-ordered cells grouped into chunks that
// each own about a target number of vertices, and write every chunk's faces — those within
// `rings` vertex rings of the vertices it owns — to one record file per chunk, in memory
// bounded by PartitionOptions::memory_bytes whatever the input size.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "format/mesh_reader.h"
#include "format/mesh_types.h"
#include "format/record_file.h"
#include "format/temp_ownership.h"
#include "format/status.h"
#include "stream/attributes/vertex_attribute_spill.h"
#include "stream/partition/spatial_order.h"

namespace gaussmesh::stream {

// How a run's temporary directory in --tmp is named (then six random characters); a later run
// removes those whose run has died (format::remove_dead_runs_temps). Every name a run locks starts
// "gaussmesh-run-": the names of versions that held no lock are never matched, so a run of such a
// version sharing the --tmp is not taken for a dead one.
inline constexpr char kPartitionDirPrefix[] = "gaussmesh-run-";

// Record kind of chunk face files (format/record_file.h): "GMCG" read as a little-endian u32.
inline constexpr std::uint32_t kChunkFaceRecordKind = 0x47434D47u;
// Bytes of one chunk face record (layout in docs/partition.md):
//   0  u64  global face id (the face's position in the reader's triangle stream)
//   8  u32  global vertex id of corner 0, 1, 2
//   20 u8   flags: bit j (0..2) = the chunk owns corner j; bit 3 = the chunk owns the face;
//           bits 4..7 zero
// Positions are not repeated per face: load_chunk reads them from the partition's positions file.
inline constexpr std::uint32_t kChunkFaceRecordBytes = 21;
// The partition's vertex files, kept with the chunk files, indexed by global vertex id,
// little-endian: positions.bin (x, y, z as f32, bit-exact input floats; 12 bytes) and
// owners.bin (the owning chunk as u32; 4 bytes).
inline constexpr std::uint32_t kPositionRecordBytes = 12;
inline constexpr std::uint32_t kOwnerRecordBytes = 4;
inline constexpr std::uint8_t kOwnsFace = 8;
// Loop chunk files ("GMLC"), written by simplify's sample pass for the loops pass: the faces of a chunk near
// its piece borders (stream/stitch/loop_chunks.h, write_loop_chunk). A chunk face record, then
//   21 u32  the index of the face's piece in the chunk (owned faces), all ones otherwise
// and flag bit 4 (kCoreFace): every edge of the face has all its faces in the file; bit 5 + j
// (kLoopCornerVertex << j): corner j's vertex is one whose every face is a core face.
inline constexpr std::uint32_t kLoopChunkRecordKind = 0x434C4D47u;
inline constexpr std::uint32_t kLoopChunkRecordBytes = 25;
inline constexpr std::uint8_t kCoreFace = 16;
inline constexpr std::uint8_t kLoopCornerVertex = 32;

// Working memory of a chunk in the sample pass, per face (adjacency, normals, labels, records):
// the chunk size follows from it when max_chunk_faces is 0.
inline constexpr std::uint64_t kChunkBytesPerFace = 200;
// Rings above this are refused (per-vertex chunk sets tag entries with their ring in 8 bits).
inline constexpr std::uint32_t kMaxPartitionRings = 64;
// Smallest memory budget accepted (the reader's window and the spill buffers need ~8 MiB).
inline constexpr std::uint64_t kMinPartitionMemory = std::uint64_t{16} << 20;

struct PartitionOptions {
  // The working-set budget of this pass (peak RSS stays under it) and the source of the chunk
  // size: chunk faces = memory_bytes / threads / kChunkBytesPerFace.
  std::uint64_t memory_bytes = std::uint64_t{256} << 20;
  // Overlap rings k >= 1 (required_overlap_rings(smooth) in stream/sampling/sampler.h).
  std::uint32_t rings = 3;
  // Chunks in flight in the sample pass; only divides the chunk size here.
  std::uint32_t threads = 1;
  // Faces per chunk to aim for (0 = derive from memory_bytes). A chunk owns at most 3/4 of this
  // in faces; the overlap rings bring the rest. Tests set it small to force hundreds of chunks.
  std::uint64_t max_chunk_faces = 0;
  // Chunk files written at once in the final scan (0 = as many as the memory allows). Tests set
  // it small to force the multi-round path.
  std::uint32_t max_open_chunks = 0;
  // zstd level of the chunk files. -4, not 1: on their column frames it is several times faster
  // both ways for files no larger (docs/records.md, "Levels").
  int compression_level = -4;
  // Called now and then with (pass, done, total): "ingest" counts triangles read against the
  // count the header declares (0 when it declares none; untrusted, for display only); "rings"
  // and "chunks" count the faces of each scan of the face spill against all faces.
  std::function<void(const char*, std::uint64_t, std::uint64_t)> progress;
  // Where the run's temporary directory is made (empty = $TMPDIR, else /tmp).
  std::string tmp_dir;
  // Spill the input's vertices with their attributes, when it has any, for a transfer after the
  // run (Partition::attribute_spill); off for jobs whose output has no attributes (sample).
  bool spill_attributes = false;
  // Renumber an input whose ids are scattered (OrderProbe) in spatial order first
  // (spatial_order.h): vertex and face ids in the chunk files are then the new ones. For
  // commands whose output does not name input ids (simplify).
  bool reorder_scattered = false;
  // With reorder_scattered: weld equal positions (spatial_order.h; kAuto: when the input looks
  // like a triangle soup).
  Weld weld = Weld::kAuto;
  // The renumbering's table (0 = from memory_bytes). Tests set it small to force the passes
  // over several ranges.
  std::uint64_t reorder_table_bytes = 0;
};

// The ingest pass's position spill is two files, written at once by two threads: one file's buffered
// writes take its inode's lock, and the kernel's copy into new page-cache pages of a single file
// would bound the ingest. Vertex v is in stripe v / kPositionStripeVertices, the stripes
// alternating between the files.
inline constexpr std::uint32_t kPositionStripeVertices = 1u << 16;
inline constexpr std::uint32_t kPositionFiles = 2;
inline constexpr std::uint32_t position_file(std::uint32_t v) { return (v / kPositionStripeVertices) % kPositionFiles; }
// v's record index in its file.
inline constexpr std::uint64_t position_record(std::uint32_t v) {
  return std::uint64_t{v / kPositionStripeVertices / kPositionFiles} * kPositionStripeVertices + v % kPositionStripeVertices;
}

// The partition's vertex files, one copy shared by every ChunkInfo of a run.
struct VertexFiles {
  std::array<std::string, kPositionFiles> positions;  // positions-0.bin, positions-1.bin
  std::string owners;                                 // owners.bin
  // Positions read back from the input itself instead: a regular file whose vertices are
  // fixed-size records of little-endian float32 (format::MeshHeader::raw_vertices), so that
  // the ingest pass writes no copy (12 bytes a vertex). Vertex v's coordinate `axis` is
  // the 4 bytes at first_byte + v * stride + xyz[axis]. The file's size and modification time
  // at ingest are checked at every open: an input changed during the run is kBadInput.
  struct InputPositions {
    std::string path;
    std::uint64_t first_byte = 0;
    std::uint32_t stride = 0;
    std::uint32_t xyz[3] = {0, 0, 0};
    std::uint64_t size = 0;
    std::int64_t modified_ns = 0;
  };
  std::optional<InputPositions> input;
};

struct ChunkInfo {
  std::uint32_t id = 0;
  std::uint64_t owned_vertices = 0;  // every vertex of its cells, referenced by faces or not
  std::uint64_t owned_faces = 0;     // faces whose lowest-id vertex it owns
  std::uint64_t faces = 0;           // records in its file: F_k(C), owned faces included
  std::string path;                  // its chunk face record file
  bool loop = false;                 // path is a loop chunk file (kLoopChunkRecordKind)
  format::RecordSegment segment;     // bytes > 0: the record file is this segment of path
  std::shared_ptr<const VertexFiles> vertex_files;  // the partition's
};

// seconds_partition split by step: the plan (cell histograms and the owner pass over
// positions.bin), the ring rounds, the final scan writing the chunk files.
struct PartitionSteps {
  double plan = 0, rings = 0, chunks = 0;
};

// seconds_reorder split by step (docs/partition.md, "The passes"): the vertices (cells, sort,
// weld, the old-to-new map), the faces renamed and grouped by lowest corner, the ordered face
// spill.
struct ReorderSteps {
  double vertices = 0, faces = 0, spill = 0;
};

// The result of the ingest and partition passes. Owns its temporary directory: the destructor (or
// remove_temp()) deletes it with everything in it. Move-only.
struct Partition {
  std::string dir;                  // the run's temp dir, registered for signal cleanup
  std::uint64_t vertices = 0;       // input vertex count
  std::uint64_t faces = 0;          // triangles after the reader's fan triangulation
  format::Vec3f lo, hi;             // bounds of the finite positions (zero when there are none)
  std::vector<ChunkInfo> chunks;    // ids 0..n-1, in Morton order of their cells
  std::uint64_t bytes_spilled = 0;  // every byte written to temporary files
  std::uint64_t cache_misses = 0;   // blocks read into the bounded cache (a measure of disorder)
  std::uint64_t cache_bytes = 0;    // the cache's size at the end: 1/8 of its budget, grown by reloads
  std::uint64_t untagged_frames = 0;
  bool reordered = false;           // the input was renumbered (reorder_scattered)
  // The input's vertex attributes, which the passes do not carry: the ingest spills them with
  // the positions (null when there are none) for the transfer after the run. And the other
  // per-vertex values its reader named as not understood.
  format::AttributeKinds input_attributes;
  std::shared_ptr<VertexAttributeSpill> attribute_spill;
  std::vector<std::string> ignored_vertex_values;
  std::vector<std::string> input_warnings;  // what the reader skipped (MeshSink::on_warning)
  std::uint64_t welded_vertices = 0;  // vertices welded away by the renumbering (vertices counts the rest)  // face frames the ring rounds scanned (partly) untagged: windows missing, disorder
  double seconds_ingest = 0, seconds_partition = 0;
  double seconds_reorder = 0;       // the renumbering, when reordered (not in seconds_partition)
  PartitionSteps steps;             // seconds_partition by step
  ReorderSteps reorder_steps;       // seconds_reorder by step

  Partition() = default;
  ~Partition();
  Partition(Partition&& other) noexcept;
  Partition& operator=(Partition&& other) noexcept;
  Partition(const Partition&) = delete;
  Partition& operator=(const Partition&) = delete;
  // Deletes dir now (idempotent).
  void remove_temp();

  // The chunk owning a vertex at p: the chunk of its grid cell, computed with the partition pass's own
  // arithmetic (the same function on the same grid), so it agrees bit for bit with the ownership
  // flags of the chunk files. Any p is accepted (NaN and out-of-bounds coordinates clamp as in
  // the partition pass); 0 when there are no chunks.
  std::uint32_t owner_of(const format::Vec3f& p) const;
  // The map behind owner_of: the cell grid (origin, cells per unit, cells per axis) and the
  // chunk of every cell (at most 2^18 cells: 1 MiB, whatever the input size). A cell holding
  // more than a quarter of a chunk's vertices is split into 8^k sub-cells (docs/partition.md, "Split
  // cells"): its entry is kSplitCell | index into `splits`, and its sub-cells, in Z-order, run
  // from chunk `first`, the chunk going up by one at each of `starts` (ascending sub-cell codes).
  static constexpr std::uint32_t kSplitCell = 0x80000000u;
  struct SplitCell {
    std::uint32_t k = 0, first = 0;
    std::vector<std::uint32_t> starts;
  };
  struct OwnerMap {
    double lo[3] = {0, 0, 0}, scale[3] = {0, 0, 0};
    std::uint32_t n[3] = {1, 1, 1};
    std::vector<std::uint32_t> cell_chunk;
    std::vector<SplitCell> splits;
  } owner_map;

  int temp_slot = -1;  // format::register_temp_path slot of dir
  format::TempOwnership dir_lock;  // held while dir exists: a later run leaves it alone
};

// The ingest and partition passes from input_path (a file, or "-" for stdin) through format::read_mesh_file.
// Ownership: a vertex is owned by the chunk of its grid cell (at most 2^18 cells, Morton order,
// runs of cells per chunk); a face by the chunk owning its lowest-id vertex. Chunk C holds
// F_k(C): V_0 = owned vertices, F_{i+1} = faces with a corner in V_i (degenerate faces too),
// V_{i+1} = corners of F_{i+1}.
// Errors: the reader's (kBadInput, naming the input and the place); kUsage for options out of
// range (rings 0 or > kMaxPartitionRings, memory below kMinPartitionMemory, threads 0);
// kResources for more than 2^32 - 1 vertices; kOutput when a temporary file cannot be written
// (disk full). On every error the temporary directory is gone when this returns.
format::Result<Partition> partition_mesh(const std::string& input_path, const format::ReadOptions& read,
                                         const PartitionOptions& options);

// One chunk as a local mesh: local vertices in ascending global id, triangles in ascending
// global face id, with local vertex indices.
struct ChunkMesh {
  std::uint32_t chunk = 0;
  std::vector<format::Vec3f> positions;
  std::vector<format::Triangle> triangles;
  std::vector<std::uint32_t> global_vertex;  // per local vertex, strictly ascending
  std::vector<std::uint64_t> global_face;    // per local face, strictly ascending
  std::vector<std::uint8_t> owned_vertex;    // per local vertex: 1 if the chunk owns it
  std::vector<std::uint8_t> owned_face;      // per local face: 1 if the chunk owns it
  // Per local vertex: its owning chunk, from owners.bin (load_chunk checks it against
  // owned_vertex); empty for a mesh made another way (owner_of answers then).
  std::vector<std::uint32_t> vertex_owner;
  // From a loop chunk file only (else empty), per local face: its piece's index in the chunk
  // (owned faces; all ones for the others), and whether it is a core face; per local vertex:
  // whether it is a loop vertex (all its faces are core faces).
  std::vector<std::uint32_t> loop_piece;
  std::vector<std::uint8_t> core_face;
  std::vector<std::uint8_t> loop_vertex;
  format::MeshView view() const { return {positions, triangles}; }
};

// Reads and checks one chunk file, and the positions and owners of its vertices from
// info.vertex_files (ascending ids, one pread per run of nearby ids). Everything is untrusted: a damaged or
// inconsistent file (checksums, record count against info.faces, owned faces against
// info.owned_faces, face ids not ascending, flag bits, one vertex id with two ownerships, a face
// owned though its lowest-id vertex is not, a vertex id beyond a vertex file, an owned flag
// that disagrees with owners.bin) is a kBadInput error naming the file.
// Memory: about 65 B per face of the chunk.
format::Result<ChunkMesh> load_chunk(const ChunkInfo& info);

}  // namespace gaussmesh::stream
