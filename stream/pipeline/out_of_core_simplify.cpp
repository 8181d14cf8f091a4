// The out-of-core simplify pipeline: one function per pass after the partition, and the driver
// that runs them in order. See out_of_core_simplify.h.
#include "stream/pipeline/out_of_core_simplify.h"

#include "stream/pipeline/in_core_simplify.h"
#include "stream/pipeline/out_of_core_finish.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>

#include <tbb/enumerable_thread_specific.h>

#include "format/file_io.h"
#include "format/record_file.h"
#include "stream/core/mesh_topology.h"
#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"
#include "stream/finish/quadric_finish.h"
#include "stream/partition/id_indexed_file.h"
#include "stream/pipeline/chunk_scheduler.h"
#include "stream/pipeline/out_of_core_setup.h"
#include "stream/pipeline/run_stats.h"
#include "stream/stitch/loop_chunks.h"
#include "stream/stitch/loop_stitch.h"
#include "stream/stitch/paper_chains.h"
#include "stream/stitch/piece_joins.h"

namespace gaussmesh::stream {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

format::Status damaged(const std::string& what) { return format::Status::error(format::Code::kBadInput, "stitch", what); }

// A graph's dense-to-input id table moves to a file in dir before the mesher runs (it holds
// every loop vertex): the mesher then gives dense ids as birth indices, and only those — the
// output's vertices — are read back.
format::Result<std::uint64_t> spill_global_ids(PolygonGraphInput& g, const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  const bool ok = format::write_all(fd, g.global.data(), g.global.size() * sizeof(std::uint32_t), 0);
  const int error = errno;
  ::close(fd);
  if (!ok) return format::Status::error(format::Code::kOutput, path, "cannot write vertex ids: " + std::string(std::strerror(error)));
  const std::uint64_t count = g.global.size();
  std::vector<std::uint32_t>().swap(g.global);
  return count;
}

// birth (dense ids) to input ids through spill_global_ids' file of count ids.
format::Status map_births(std::vector<std::uint32_t>& birth, const std::string& path, std::uint64_t count) {
  std::vector<std::uint32_t> ids(birth);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::vector<std::uint32_t> global(ids.size());
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return format::Status::error(format::Code::kOutput, path, std::strerror(errno));
  std::vector<std::byte> window;
  const std::size_t served = read_by_ascending_id(fd, count, sizeof(std::uint32_t), ids, window, [&](std::size_t i, const std::byte* record) {
    std::memcpy(&global[i], record, sizeof(std::uint32_t));
  });
  ::close(fd);
  if (served < ids.size()) return format::Status::error(format::Code::kOutput, path, "cannot read the id of vertex " + std::to_string(ids[served]));
  for (std::uint32_t& b : birth) b = global[std::lower_bound(ids.begin(), ids.end(), b) - ids.begin()];
  return format::Status();
}

// A loop chunk the sample pass wrote for a chunk (write_loop_chunk): the loops and chains passes
// read it instead of the chunk. It may hold no face (no feature edge and no sample in the chunk:
// inside one flat patch); the loops pass then reads nothing for it but its pieces' areas, which
// ride in the spilled piece records.
struct LoopChunk {
  std::uint64_t faces = 0, owned_faces = 0;
  std::uint32_t file = 0;  // its file among PieceJoinFiles::segments
  format::RecordSegment segment;
  bool present = false;  // false: the loops pass reads the chunk
};

// The fetch pass's record of one input face of a wanted patch.
struct FetchedFace {
  std::uint64_t face;
  std::uint32_t patch;
  std::array<std::uint32_t, 3> v;
  std::array<format::Vec3f, 3> p;
};

// The passes after the partition over one set of orientations, one method per pass, and what
// each pass leaves for the next. Each pass frees what no later pass reads before it returns.
class SimplifyRun {
 public:
  SimplifyRun(Partition& partition, std::span<const GaussSphere> spheres, const OutOfCoreSimplifyOptions& options,
              OutOfCoreSimplify& out)
      : partition_(partition), spheres_(spheres), options_(options), out_(out), nc_(partition.chunks.size()),
        paper_(options.sampler.sample_test == SampleTest::kPaper) {}

  bool is_paper() const { return paper_; }

  // sample: every chunk sampled for every orientation. With one orientation it also finds the
  // chunk's patch pieces and writes its loop chunk (and, for the paper test, its candidates' star
  // geometry); with several, the pieces come from a second pass over the chunks for the chosen
  // one. Each chunk's border edges and face answers go to disk (stream/stitch/piece_joins.h) as
  // it finishes.
  format::Status sample();
  // pieces: the patch pieces joined across chunks (stitch_pieces).
  format::Status pieces();
  // merge: the untriangulatable merge on the stitched patch graph; the surviving candidates are
  // the corners.
  format::Status merge();
  // The paper test: the surviving candidates' records under the merged labels, from their star
  // geometry and their stars' patches (what sample_mesh's merge leaves in its records).
  format::Status reevaluate_paper_candidates();
  // The loops and fetch passes need each piece's merged patch and each merged patch's label; the
  // rest of the stitch and the merge goes now.
  void release_merge_details();
  // chains (the paper test): candidate chains under the merged labels, chunk by chunk (loop
  // chunks hold every vertex on a feature edge with its whole star), joined across chunks, then
  // the non-sample and noisy filters (sample_mesh's last steps).
  format::Status chains();
  // samples_only: the samples in out.sample_points (ascending vertex), with the sphere's figures.
  void keep_samples();
  // loops: loops under the merged patches, chunk by chunk; each chunk's run vertices go to a
  // file. A loop chunk carries its owned faces' pieces, and its areas come from the sample
  // pass's per-piece sums.
  format::Status loops();
  // The loop stitch: runs joined into loops (stream/stitch/loop_stitch.h).
  format::Status stitch();
  // mesh: the polygon mesher on the stitched loops. Patches that need their input faces are
  // fetched (fetch pass) and the mesher runs again from the start, until none asks.
  format::Status mesh();
  // The quadric finish: every owned face's plane quadric into the approximation's vertices, on
  // the chunks' threads, then the collapses (stream/finish/quadric_finish.h).
  format::Status finish();

 private:
  // for_each_chunk over the partition's chunks, or over the `count` chunks info_of gives,
  // reporting `pass` and drawing on the run's budget.
  format::Status for_each_chunk(const char* pass, const ChunkBody& body) const;
  format::Status for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of,
                                const char* pass, const ChunkBody& body) const;
  // Where the loop stitch leaves the loop summaries (spill_loop_summaries) for a fetch.
  std::string summaries_path() const { return partition_.dir + "/loop-summaries.bin"; }
  // Chunk c as the loops and chains passes read it: its loop chunk where the sample pass wrote one.
  ChunkInfo loop_info_of(std::size_t c) const;
  // The sample pass's pieces and loop chunk for chunk c, from the sampler's arrays in ws.
  format::Status find_pieces(std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                             const std::vector<GlobalSample>& chunk_samples);
  // The paper test: chunk c's candidates' star geometry, for their records after the merge.
  format::Status write_geometry(std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws);
  std::uint32_t merged_patch_of_piece(PieceId piece) const;
  // A chunk's faces under the merged patches, and its adjacency in ws: owned faces through the
  // pieces the sample pass wrote for them, the others through the owners' answer files (each
  // read once per chunk); kNone where neither knows (faces far from every owned face). No
  // labelling again. A loop chunk carries its owned faces' pieces (checked against pieces, the
  // chunk's pieces).
  format::Status merged_patches_of_chunk(const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                                         std::vector<std::uint32_t>& patch,
                                         const std::vector<PieceRecord>& pieces = {}) const;
  // The fetch pass: the owned, non-collapsed faces of the patches `now` (ascending) from the
  // chunks that own faces of them, appended to fetched_.
  format::Status fetch(const std::vector<std::uint32_t>& now);

  Partition& partition_;
  std::span<const GaussSphere> spheres_;
  const OutOfCoreSimplifyOptions& options_;
  OutOfCoreSimplify& out_;
  const std::size_t nc_;
  const bool paper_;

  std::unique_ptr<PieceJoinFiles> joins_;
  std::vector<ChunkPieces> pieces_;
  std::vector<ChunkRecordSegment> star_geometry_;  // the paper test's, per chunk
  std::vector<LoopChunk> loop_chunks_;
  std::mutex geometry_mutex_;
  const GaussSphere* gauss_ = nullptr;           // the chosen orientation's
  std::vector<std::vector<GlobalSample>> chosen_;  // per chunk: its samples of the chosen orientation
  StitchedPatches stitched_;
  PatchMergeResult merged_;
  std::vector<std::uint32_t> corners_;  // candidates after the merge, ascending
  std::vector<PaperCandidate> paper_candidates_;
  std::vector<ChunkLoopSummary> loops_;
  std::vector<format::Vec3f> plane_;  // per merged patch: its label's normal
  PolygonGraphInput graph_;
  // The fetch pass's wanted patches (ascending) and their faces (ascending face).
  std::vector<std::uint32_t> wanted_;
  std::vector<FetchedFace> fetched_;
};

format::Status SimplifyRun::for_each_chunk(const char* pass, const ChunkBody& body) const {
  return stream::for_each_chunk(
      partition_, options_.threads, body,
      [&](std::size_t done, std::size_t total) {
        if (options_.progress) options_.progress(pass, done, total, partition_.faces);
      },
      options_.memory);
}

format::Status SimplifyRun::for_each_chunk(std::size_t count, const std::function<ChunkInfo(std::size_t)>& info_of,
                                           const char* pass, const ChunkBody& body) const {
  return stream::for_each_chunk(
      count, info_of, options_.threads, body,
      [&](std::size_t done, std::size_t total) {
        if (options_.progress) options_.progress(pass, done, total, partition_.faces);
      },
      options_.memory);
}

ChunkInfo SimplifyRun::loop_info_of(std::size_t c) const {
  ChunkInfo info = partition_.chunks[c];
  if (!loop_chunks_[c].present) return info;
  info.path = joins_->segment_path(loop_chunks_[c].file);
  info.segment = loop_chunks_[c].segment;
  info.loop = true;
  info.faces = loop_chunks_[c].faces;
  info.owned_faces = loop_chunks_[c].owned_faces;
  return info;
}

format::Status SimplifyRun::find_pieces(std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                                        const std::vector<GlobalSample>& chunk_samples) {
  std::vector<std::uint32_t> piece_index, candidates;
  for (const VertexRecord& r : ws.records)  // the sampler's, for these labels (sample_chunk)
    if (r.is_candidate) candidates.push_back(r.vertex);
  find_chunk_pieces(partition_, chunk, ws.adjacency, ws.labels, ws.feature, pieces_[c], &piece_index, &candidates);
  GM_RETURN_IF_ERROR(joins_->write_face_pieces(static_cast<std::uint32_t>(c), chunk, piece_index));
  ChunkInfo loop_info;
  std::vector<std::array<double, 3>> piece_area;
  format::RecordSegmentPool::Lease lease(joins_->segments());
  GM_RETURN_IF_ERROR(lease.status());
  auto written = write_loop_chunk(chunk, partition_.chunks[c], ws.adjacency, piece_index, ws.feature, chunk_samples,
                                  lease.file(), loop_info, piece_area);
  if (!written) return written.status();
  if (*written) {
    loop_chunks_[c] = {loop_info.faces, loop_info.owned_faces, lease.index(), loop_info.segment, true};
    if (piece_area.size() > pieces_[c].pieces.size())
      return format::Status::error(format::Code::kProcessing, "sample pass", "more piece areas than pieces");
    const std::size_t first = pieces_[c].pieces.size() - piece_area.size();  // this chunk's, appended last
    for (std::size_t k = 0; k < piece_area.size(); ++k) pieces_[c].pieces[first + k].area = piece_area[k];
  }
  return joins_->spill(static_cast<std::uint32_t>(c), pieces_[c]);
}

format::Status SimplifyRun::write_geometry(std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
  format::RecordSegmentPool::Lease lease(joins_->segments());
  GM_RETURN_IF_ERROR(lease.status());
  auto written = write_star_geometry(chunk, ws.adjacency, ws.normals, ws.records, lease.file());
  if (!written) return written.status();
  star_geometry_[c] = std::move(written).value();
  std::lock_guard<std::mutex> lock(geometry_mutex_);
  partition_.bytes_spilled += star_geometry_[c].segment.bytes;
  return format::Status();
}

format::Status SimplifyRun::sample() {
  const std::size_t no = spheres_.size();
  std::vector<std::vector<GlobalSample>> samples(nc_ * no);
  std::vector<ChunkSamplingStats> chunk_stats(nc_ * no);
  pieces_.resize(nc_);
  star_geometry_.resize(paper_ ? nc_ : 0);
  loop_chunks_.resize(nc_);
  // Border-edge records: about one per face of each chunk's first overlap ring, whose size is
  // about the overlap's over the rings (a guess: a wrong one costs reads, not memory).
  std::uint64_t expected_border = 0;
  for (const ChunkInfo& info : partition_.chunks)
    expected_border += (info.faces - std::min(info.faces, info.owned_faces)) / std::max<std::uint32_t>(options_.partition.rings, 1);
  auto joins = PieceJoinFiles::create(partition_.dir, nc_, border_bucket_count(expected_border, options_.memory),
                                      options_.memory);
  if (!joins) return joins.status();
  joins_ = std::move(joins).value();
  GM_RETURN_IF_ERROR(for_each_chunk("sample", [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
    for (std::size_t k = 0; k < no; ++k)
      GM_RETURN_IF_ERROR(sample_chunk(chunk, spheres_[k], options_.sampler, ws, samples[c * no + k], chunk_stats[c * no + k]));
    if (no > 1) return format::Status();
    if (paper_) GM_RETURN_IF_ERROR(write_geometry(c, chunk, ws));
    return find_pieces(c, chunk, ws, samples[c]);
  }));
  for (std::size_t k = 0; k < no; ++k) {
    std::size_t n = 0;
    for (std::size_t c = 0; c < nc_; ++c) n += samples[c * no + k].size();
    out_.samples_per_orientation.push_back(n);
  }
  out_.chosen = choose_sphere(out_.samples_per_orientation, options_.min_samples);
  gauss_ = &spheres_[out_.chosen];
  chosen_.resize(nc_);
  for (std::size_t c = 0; c < nc_; ++c) {
    chosen_[c] = std::move(samples[c * no + out_.chosen]);
    out_.samples += chosen_[c].size();
    out_.sampling_stats.add(chunk_stats[c * no + out_.chosen]);
  }
  std::vector<ChunkSamplingStats>().swap(chunk_stats);
  samples = {};
  if (no > 1) {
    GM_RETURN_IF_ERROR(for_each_chunk("pieces", [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
      std::vector<GlobalSample> unused;
      ChunkSamplingStats stats;
      GM_RETURN_IF_ERROR(sample_chunk(chunk, *gauss_, options_.sampler, ws, unused, stats));
      if (paper_) GM_RETURN_IF_ERROR(write_geometry(c, chunk, ws));
      return find_pieces(c, chunk, ws, chosen_[c]);
    }));
  }
  GM_RETURN_IF_ERROR(joins_->finish());
  partition_.bytes_spilled += joins_->bytes_written();
  return format::Status();
}

format::Status SimplifyRun::pieces() {
  auto stitched = stitch_pieces(pieces_, *joins_, options_.memory, options_.threads);
  if (!stitched) return stitched.status();
  stitched_ = std::move(stitched).value();
  return format::Status();
}

format::Status SimplifyRun::merge() {
  std::vector<ChunkPieces>().swap(pieces_);
  release_free_memory();
  CandidateEdges candidate_edges;
  PatchGraphInput merge_input = take_merge_input(stitched_, candidate_edges);
  // The merge reads the candidates' edges; after it only the paper test reads their stars (its
  // records under the merged labels), and the exact test only their vertices.
  std::vector<std::uint32_t> candidate_vertex;
  candidate_vertex.reserve(stitched_.candidates.size());
  for (const auto& c : stitched_.candidates) candidate_vertex.push_back(c.vertex);
  if (!paper_) {
    std::vector<StitchedPatches::Star>().swap(stitched_.star);
    std::vector<std::uint8_t>().swap(stitched_.entering_break);
    std::vector<StitchedPatches::Candidate>().swap(stitched_.candidates);
  }
  merged_ = merge_stitched_patches(candidate_edges, std::move(merge_input));
  candidate_edges = CandidateEdges();
  out_.patches = merged_.patch_label.size();
  out_.merged_patches = merged_.merged_patches;
  out_.merge_rounds = merged_.rounds;
  for (std::size_t k = 0; k < candidate_vertex.size(); ++k)
    if (merged_.is_candidate[k]) corners_.push_back(candidate_vertex[k]);
  std::vector<std::uint32_t>().swap(candidate_vertex);
  out_.candidates = corners_.size();
  return format::Status();
}

format::Status SimplifyRun::reevaluate_paper_candidates() {
  auto merged_label = [&](std::uint32_t p) { return merged_.patch_label[merged_.patch_of[p]]; };
  const MergedStar star = [&](std::uint32_t vertex, std::vector<StarSlotLabel>& slots) {
    const auto& cands = stitched_.candidates;
    const auto it = std::lower_bound(cands.begin(), cands.end(), vertex,
                                     [](const StitchedPatches::Candidate& a, std::uint32_t v) { return a.vertex < v; });
    if (it == cands.end() || it->vertex != vertex || !merged_.is_candidate[it - cands.begin()]) return false;
    for (std::uint32_t k = it->first; k < it->first + it->count; ++k) {
      const auto& e = stitched_.star[k];
      const std::uint32_t label = merged_label(e.patch);
      slots.push_back({label, e.next_patch == kNone || merged_label(e.next_patch) != label});
    }
    return true;
  };
  for (std::size_t c = 0; c < nc_; ++c)
    GM_RETURN_IF_ERROR(reevaluate_candidates(star_geometry_[c], static_cast<std::uint32_t>(c), *gauss_, star, paper_candidates_));
  if (paper_candidates_.size() != corners_.size())
    return damaged("the star geometry holds " + std::to_string(paper_candidates_.size()) + " of " +
                   std::to_string(corners_.size()) + " candidates");
  std::sort(paper_candidates_.begin(), paper_candidates_.end(),
            [](const PaperCandidate& a, const PaperCandidate& b) { return a.vertex < b.vertex; });
  std::vector<ChunkRecordSegment>().swap(star_geometry_);
  return format::Status();
}

void SimplifyRun::release_merge_details() {
  std::vector<StitchedPatches::Star>().swap(stitched_.star);
  std::vector<std::uint8_t>().swap(stitched_.entering_break);
  std::vector<StitchedPatches::Candidate>().swap(stitched_.candidates);
  std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(merged_.adjacency);
  std::vector<std::uint8_t>().swap(merged_.is_candidate);
  release_free_memory();
}

std::uint32_t SimplifyRun::merged_patch_of_piece(PieceId piece) const {
  const std::int64_t p = stitched_.patch_of_piece(piece);
  return p < 0 ? kNone : merged_.patch_of[p];
}

format::Status SimplifyRun::merged_patches_of_chunk(const ChunkMesh& chunk, ChunkSamplerWorkspace& ws,
                                                    std::vector<std::uint32_t>& patch,
                                                    const std::vector<PieceRecord>& pieces) const {
  GM_RETURN_IF_ERROR(build_mesh_adjacency(chunk.view(), ws.adjacency));
  std::vector<std::uint32_t> piece_index;
  if (chunk.core_face.empty()) {
    GM_RETURN_IF_ERROR(joins_->read_face_pieces(chunk.chunk, chunk, piece_index));
  } else {
    for (std::size_t f = 0; f < chunk.loop_piece.size(); ++f)
      if (chunk.owned_face[f] && chunk.loop_piece[f] >= pieces.size())
        return damaged("the loop chunk of chunk " + std::to_string(chunk.chunk) + ": a face names a piece the chunk does not have");
  }
  const std::vector<std::uint32_t>& index = chunk.core_face.empty() ? piece_index : chunk.loop_piece;
  std::vector<PieceId> face_piece;
  GM_RETURN_IF_ERROR(chunk_face_pieces(partition_, chunk, index, *joins_, face_piece));
  patch.resize(chunk.triangles.size());
  for (std::uint32_t f = 0; f < patch.size(); ++f) patch[f] = merged_patch_of_piece(face_piece[f]);
  return format::Status();
}

format::Status SimplifyRun::chains() {
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> chunk_pairs(nc_);
  std::vector<ChunkRecordSegment> fragment_files(nc_);
  GM_RETURN_IF_ERROR(for_each_chunk(
      nc_, [&](std::size_t c) { return loop_info_of(c); }, "chains",
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        if (chunk.triangles.empty()) return format::Status();  // no face (an empty loop chunk): no chain
        std::vector<std::uint32_t> patch;
        std::vector<PieceRecord> piece_records;
        if (!chunk.core_face.empty()) GM_RETURN_IF_ERROR(joins_->read_pieces(static_cast<std::uint32_t>(c), piece_records));
        GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch, piece_records));
        std::vector<std::uint32_t> label(patch.size(), 0);
        std::vector<std::uint8_t> known(patch.size(), 0);
        for (std::size_t f = 0; f < patch.size(); ++f) {
          if (patch[f] == kNone) continue;
          label[f] = merged_.patch_label[patch[f]];
          known[f] = 1;
        }
        auto is_candidate = [&](std::uint32_t v) { return std::binary_search(corners_.begin(), corners_.end(), v); };
        std::vector<ChainFragment> fragments;
        GM_RETURN_IF_ERROR(find_chunk_chains(chunk, ws.adjacency, label, known, is_candidate, chunk_pairs[c], fragments));
        std::sort(chunk_pairs[c].begin(), chunk_pairs[c].end());
        chunk_pairs[c].erase(std::unique(chunk_pairs[c].begin(), chunk_pairs[c].end()), chunk_pairs[c].end());
        chunk_pairs[c].shrink_to_fit();
        if (fragments.empty()) return format::Status();
        format::RecordSegmentPool::Lease lease(joins_->segments());
        GM_RETURN_IF_ERROR(lease.status());
        auto written = write_chain_fragments(fragments, lease.file());
        if (!written) return written.status();
        fragment_files[c] = std::move(written).value();
        return format::Status();
      }));
  std::vector<std::pair<std::uint32_t, std::uint32_t>> candidate_pairs;
  for (auto& p : chunk_pairs) {
    candidate_pairs.insert(candidate_pairs.end(), p.begin(), p.end());
    std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(p);
  }
  for (const ChunkRecordSegment& f : fragment_files) {
    out_.chain_fragments += f.records;
    partition_.bytes_spilled += f.segment.bytes;
  }
  GM_RETURN_IF_ERROR(join_chain_fragments(fragment_files, options_.memory, candidate_pairs));
  std::sort(candidate_pairs.begin(), candidate_pairs.end());
  candidate_pairs.erase(std::unique(candidate_pairs.begin(), candidate_pairs.end()), candidate_pairs.end());
  out_.candidate_pairs = candidate_pairs.size();
  out_.candidate_pairs_digest = candidate_pairs_digest(candidate_pairs);
  std::vector<NoisyFilterInput> survivors;
  std::vector<std::uint32_t> survivor_of;  // index into paper_candidates_
  for (std::uint32_t k = 0; k < paper_candidates_.size(); ++k) {
    const PaperCandidate& r = paper_candidates_[k];
    if (r.is_tree) {
      ++out_.tree_filtered;
      continue;
    }
    if (options_.sampler.drop_unwinding_candidates && r.gauss_vertex != kNoGaussVertex &&
        r.characteristic == Characteristic::kNone) {
      ++out_.unwinding_filtered;
      continue;
    }
    survivors.push_back({r.vertex, r.gauss_vertex, static_cast<std::uint8_t>(r.characteristic), r.cover_mask});
    survivor_of.push_back(k);
  }
  const std::vector<std::uint8_t> keep = noisy_sample_filter(survivors, candidate_pairs);
  std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(candidate_pairs);
  out_.samples = 0;
  for (std::size_t k = 0; k < survivors.size(); ++k) {
    if (!keep[k]) {
      ++out_.noisy_filtered;
      continue;
    }
    const PaperCandidate& r = paper_candidates_[survivor_of[k]];
    const GlobalSample sample{r.vertex, r.position, r.gauss_vertex, r.characteristic};
    if (options_.samples_only) {
      out_.sample_points.push_back(sample);
    } else {
      if (r.chunk >= nc_) return damaged("a candidate names chunk " + std::to_string(r.chunk));
      chosen_[r.chunk].push_back(sample);
    }
    ++out_.samples;
  }
  out_.samples_per_orientation.assign(1, out_.samples);
  std::vector<PaperCandidate>().swap(paper_candidates_);
  return format::Status();
}

void SimplifyRun::keep_samples() {
  out_.rotation = gauss_->options().rotation;
  out_.gauss_vertices = gauss_->vertex_count();
  out_.gauss_triangles = gauss_->triangle_count();
  if (paper_) return;  // chains() kept them
  for (auto& part : chosen_) out_.sample_points.insert(out_.sample_points.end(), part.begin(), part.end());
  std::sort(out_.sample_points.begin(), out_.sample_points.end(),
            [](const GlobalSample& a, const GlobalSample& b) { return a.vertex < b.vertex; });
}

format::Status SimplifyRun::loops() {
  loops_.resize(nc_);
  GM_RETURN_IF_ERROR(for_each_chunk(
      nc_, [&](std::size_t c) { return loop_info_of(c); }, "loops",
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        std::vector<std::uint32_t> patch;
        const bool loop_chunk = loop_chunks_[c].present;
        if (loop_chunk != !chunk.core_face.empty() && !chunk.triangles.empty())
          return format::Status::error(format::Code::kProcessing, "loops pass", "a loop chunk without its core flags");
        std::vector<PieceRecord> piece_records;
        if (loop_chunk) GM_RETURN_IF_ERROR(joins_->read_pieces(static_cast<std::uint32_t>(c), piece_records));
        auto is_corner = [&](std::uint32_t v) { return std::binary_search(corners_.begin(), corners_.end(), v); };
        ChunkLoops found;
        if (!chunk.triangles.empty()) {  // no face (an empty loop chunk): no loop, only its pieces' areas
          GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch, piece_records));
          GM_RETURN_IF_ERROR(find_chunk_loops(chunk, ws.adjacency, patch, is_corner, chosen_[c], found));
        }
        if (loop_chunk) {
          std::map<std::uint32_t, std::array<double, 3>> areas;
          for (const PieceRecord& r : piece_records) {
            auto& sum = areas[merged_patch_of_piece(r.piece)];
            for (int i = 0; i < 3; ++i) sum[i] += r.area[i];
          }
          for (const auto& [p, sum] : areas) found.areas.emplace_back(p, sum);
        }
        format::RecordSegmentPool::Lease lease(joins_->segments());
        GM_RETURN_IF_ERROR(lease.status());
        auto summary = spill_chunk_loops(std::move(found), lease.file());
        if (!summary) return summary.status();
        loops_[c] = std::move(summary).value();
        return format::Status();
      }));
  out_.peak_rss_after_loops = peak_rss();
  out_.bytes_spilled = partition_.bytes_spilled;
  for (std::size_t c = 0; c < nc_; ++c) {
    const bool loop = loop_chunks_[c].present;
    out_.loop_chunks += loop;
    out_.loop_faces += loop ? loop_chunks_[c].faces : partition_.chunks[c].faces;
    out_.bytes_spilled += loop ? loop_chunks_[c].segment.bytes : 0;
  }
  std::vector<LoopChunk>().swap(loop_chunks_);
  for (const ChunkLoopSummary& l : loops_) out_.bytes_spilled += l.bytes;
  plane_.resize(merged_.patch_label.size());
  for (std::size_t p = 0; p < plane_.size(); ++p) {
    if (merged_.patch_label[p] == kNoLabel) continue;
    const Vec3d& c = gauss_->triangle_center(merged_.patch_label[p]);
    plane_[p] = {float(c.x), float(c.y), float(c.z)};
  }
  return format::Status();
}

format::Status SimplifyRun::stitch() {
  // The summaries go to a file first and the stitch reads them back: after it they are needed
  // only if a fetch stitches the loops again, and are not held beside the mesher.
  for (const ChunkLoopSummary& l : loops_)
    out_.bytes_spilled += l.runs.size() * sizeof(LoopRunRecord) + l.vertices.size() * sizeof(LoopVertexRecord) +
                          l.areas.size() * sizeof(l.areas[0]);
  GM_RETURN_IF_ERROR(spill_loop_summaries(loops_, summaries_path()));
  auto loops = read_loop_summaries(loops_, summaries_path());
  if (!loops) return loops.status();
  LoopStitchStats stitch_stats;
  auto graph = stitch_loops(*loops, merged_.patch_label.size(), plane_, partition_.dir, {}, &stitch_stats);
  if (!graph) return graph.status();
  graph_ = std::move(graph).value();
  out_.stitch_runs = stitch_stats.runs;
  out_.stitch_half_edges = stitch_stats.half_edges;
  out_.stitch_vertices = stitch_stats.vertices;
  out_.bytes_spilled += 12 * stitch_stats.vertices;
  return format::Status();
}

format::Status SimplifyRun::fetch(const std::vector<std::uint32_t>& now) {
  // Only the chunks that own faces of those patches: a merged patch's owned faces are its
  // pieces' faces, and a piece is its chunk's. A pass over every chunk would cost far more than
  // the few faces asked for.
  if (stitched_.chunk_first.size() != nc_ + 1) return damaged("the stitched pieces do not cover the chunks");
  std::vector<std::uint32_t> holders;
  for (std::uint32_t c = 0; c < nc_; ++c)
    for (std::uint32_t k = stitched_.chunk_first[c]; k < stitched_.chunk_first[c + 1]; ++k)
      if (std::binary_search(now.begin(), now.end(), merged_.patch_of[stitched_.piece_patch[k]])) {
        holders.push_back(c);
        break;
      }
  out_.fetched_chunks += holders.size();
  std::vector<std::vector<FetchedFace>> per_chunk(holders.size());
  GM_RETURN_IF_ERROR(for_each_chunk(
      holders.size(), [&](std::size_t i) { return partition_.chunks[holders[i]]; }, "fetch",
      [&](std::size_t c, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
        std::vector<std::uint32_t> patch_of;
        GM_RETURN_IF_ERROR(merged_patches_of_chunk(chunk, ws, patch_of));
        const std::vector<std::uint8_t> skip = faces_the_mesher_skips(chunk.triangles, ws.adjacency);
        for (std::uint32_t f = 0; f < chunk.triangles.size(); ++f) {
          const auto& t = chunk.triangles[f];
          if (!chunk.owned_face[f] || skip[f]) continue;
          const std::uint32_t patch = patch_of[f];
          if (!std::binary_search(now.begin(), now.end(), patch)) continue;
          FetchedFace r{chunk.global_face[f], patch, {}, {}};
          for (int i = 0; i < 3; ++i) {
            r.v[i] = chunk.global_vertex[t.v[i]];
            r.p[i] = chunk.positions[t.v[i]];
          }
          per_chunk[c].push_back(r);
        }
        return format::Status();
      }));
  for (auto& part : per_chunk) fetched_.insert(fetched_.end(), part.begin(), part.end());
  wanted_.insert(wanted_.end(), now.begin(), now.end());
  std::sort(wanted_.begin(), wanted_.end());
  std::sort(fetched_.begin(), fetched_.end(), [](const FetchedFace& a, const FetchedFace& b) { return a.face < b.face; });
  return format::Status();
}

format::Status SimplifyRun::mesh() {
  const std::string ids_path = partition_.dir + "/loop-ids.bin";
  auto id_count = spill_global_ids(graph_, ids_path);
  if (!id_count) return id_count.status();
  // What the passes before freed goes back before the mesher, whose tables are output-sized and
  // can be the run's largest (docs/meshing.md#memory).
  release_free_memory();
  auto meshed = mesh_patch_loops(std::move(graph_));
  if (!meshed) return meshed.status();
  for (int attempt = 0; !meshed->needs_faces.empty(); ++attempt) {
    if (attempt >= 8) return format::Status::error(format::Code::kProcessing, "stitch", "patches keep asking for faces");
    std::vector<std::uint32_t> asked = meshed->needs_faces;
    std::sort(asked.begin(), asked.end());
    std::vector<std::uint32_t> now;
    std::set_difference(asked.begin(), asked.end(), wanted_.begin(), wanted_.end(), std::back_inserter(now));
    if (now.empty()) return format::Status::error(format::Code::kProcessing, "stitch", "fetched faces did not help");
    GM_RETURN_IF_ERROR(fetch(now));
    // The graph again, with the fetched faces' vertices among its (dense, global-order) ids.
    std::vector<std::pair<std::uint32_t, format::Vec3f>> extra;
    for (const FetchedFace& r : fetched_)
      for (int i = 0; i < 3; ++i) extra.emplace_back(r.v[i], r.p[i]);
    std::sort(extra.begin(), extra.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    extra.erase(std::unique(extra.begin(), extra.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                extra.end());
    auto loops = read_loop_summaries(loops_, summaries_path());
    if (!loops) return loops.status();
    auto regraph = stitch_loops(*loops, merged_.patch_label.size(), plane_, partition_.dir, extra, nullptr);
    loops = std::vector<ChunkLoopSummary>();
    if (!regraph) return regraph.status();
    {
      const DenseIds dense(regraph->global);
      std::map<std::uint32_t, PatchFaces> by_patch;
      for (const FetchedFace& r : fetched_) {
        PatchFaces& pf = by_patch[r.patch];
        pf.patch = r.patch;
        pf.triangles.push_back({dense(r.v[0]), dense(r.v[1]), dense(r.v[2])});
      }
      for (auto& [patch, pf] : by_patch) regraph->patch_faces.push_back(std::move(pf));
    }
    id_count = spill_global_ids(*regraph, ids_path);
    if (!id_count) return id_count.status();
    out_.fetched_patches = wanted_.size();
    out_.fetched_faces = fetched_.size();
    meshed = mesh_patch_loops(std::move(*regraph));
    if (!meshed) return meshed.status();
  }
  GM_RETURN_IF_ERROR(map_births(meshed->mesh.birth, ids_path, *id_count));
  out_.mesh = std::move(meshed->mesh.mesh);
  out_.birth = std::move(meshed->mesh.birth);
  out_.polygon = meshed->stats;
  out_.rotation = gauss_->options().rotation;
  out_.gauss_vertices = gauss_->vertex_count();
  out_.gauss_triangles = gauss_->triangle_count();
  return format::Status();
}

format::Status SimplifyRun::finish() {
  const auto start = Clock::now();
  const FaceQuadrics quadrics(out_.mesh.view());
  // Fixed-point sums: which thread adds which chunk does not change the result.
  tbb::enumerable_thread_specific<FaceQuadrics::Accumulator> partial([&] { return quadrics.new_accumulator(); });
  GM_RETURN_IF_ERROR(for_each_chunk("quadrics", [&](std::size_t, const ChunkMesh& chunk, ChunkSamplerWorkspace&) {
    auto& acc = partial.local();
    for (std::size_t f = 0; f < chunk.triangles.size(); ++f) {
      if (!chunk.owned_face[f]) continue;
      const auto& t = chunk.triangles[f];
      quadrics.add_face(chunk.positions[t.v[0]], chunk.positions[t.v[1]], chunk.positions[t.v[2]], acc);
    }
    return format::Status();
  }));
  std::vector<FixedQuadric> sums = quadrics.new_sums();
  for (const auto& part : partial) add_sums(sums, part.sums);
  partial.clear();
  const double seconds_quadrics = seconds_since(start);
  auto finished = finish_from_sums(out_.mesh.view(), quadrics.frame(), sums, out_.finish_options);
  if (!finished) return finished.status();
  finished->seconds_quadrics = seconds_quadrics;
  out_.mesh = std::move(finished->mesh);
  out_.birth.clear();  // the finish moves vertices: they are no longer input vertices
  out_.finish = std::move(finished).value();
  return format::Status();
}

// surface_values' pass over the input's triangles: every chunk's owned faces with their corners'
// positions, numbered by the partition's face ids; it reads `partition`'s files.
TrianglePassFn owned_triangles(const Partition& partition, std::uint32_t threads, const MemoryBudget& memory) {
  return [kept = &partition, threads, memory](const TriangleBatchFn& batch) {
    return for_each_chunk(
        *kept, threads,
        [&batch](std::size_t, const ChunkMesh& chunk, ChunkSamplerWorkspace&) {
          std::vector<IndexedTriangle> owned;
          owned.reserve(chunk.triangles.size());
          for (std::size_t f = 0; f < chunk.triangles.size(); ++f) {
            if (!chunk.owned_face[f]) continue;
            const format::Triangle& t = chunk.triangles[f];
            owned.push_back({{chunk.positions[t.v[0]], chunk.positions[t.v[1]], chunk.positions[t.v[2]]}, chunk.global_face[f]});
          }
          return batch(owned);
        },
        {}, memory);
  };
}

// The passes after the partition, for `spheres` (the exact test: every orientation in the sample
// pass; the paper test: one), in order: sample, pieces, merge, chains (the paper test), loops,
// the loop stitch, mesh (with its fetch rounds). `out` comes with the partition's figures. The
// temporary directory is removed at the end when remove_temp (the paper test's runs per
// orientation keep it for the next run; each run's files replace the last one's).
format::Result<OutOfCoreSimplify> simplify_partition(Partition& partition, std::span<const GaussSphere> spheres,
                                                     const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify out,
                                                     bool remove_temp) {
  SimplifyRun run(partition, spheres, options, out);
  RunStats stats;
  GM_RETURN_IF_ERROR(run.sample());
  out.seconds_sample = stats.end_pass(&out.peak_rss_after_pieces);

  stats.begin_pass();  // the stitch: pieces, merge, chains, loops, loop stitch
  GM_RETURN_IF_ERROR(run.pieces());
  out.stitch_steps.pieces = stats.end_step();
  GM_RETURN_IF_ERROR(run.merge());
  out.stitch_steps.merge = stats.end_step(&out.peak_rss_after_merge);
  if (run.is_paper()) GM_RETURN_IF_ERROR(run.reevaluate_paper_candidates());
  run.release_merge_details();
  if (run.is_paper()) {
    GM_RETURN_IF_ERROR(run.chains());
    out.stitch_steps.chains = stats.end_step();
  }
  auto cleanup = [&] {
    if (!remove_temp) return;
    const auto start = Clock::now();
    partition.remove_temp();
    out.seconds_cleanup = seconds_since(start);
  };
  if (options.samples_only) {
    out.seconds_stitch = stats.end_pass();
    cleanup();
    run.keep_samples();
    return out;
  }
  GM_RETURN_IF_ERROR(run.loops());
  out.stitch_steps.loops = stats.end_step();
  GM_RETURN_IF_ERROR(run.stitch());
  out.stitch_steps.loop_stitch = stats.end_step();
  out.seconds_stitch = stats.end_pass();

  stats.begin_pass();
  GM_RETURN_IF_ERROR(run.mesh());
  if (out.finish_options.enabled()) GM_RETURN_IF_ERROR(run.finish());
  out.seconds_mesh = stats.end_pass();
  if (remove_temp && out.finish && out.attribute_spill) {
    // The finish moved the approximation's vertices: their attributes come from the input's
    // triangles, and the caller lets the files go after them.
    out.bytes_spilled = partition.bytes_spilled;
    out.input_partition = std::make_shared<Partition>(std::move(partition));
    out.input_triangles = owned_triangles(*out.input_partition, options.threads, options.memory);
    return out;
  }
  cleanup();
  return out;
}

// The passes after the partition (its options resolved against the input's faces and bounds):
// sample to mesh for the chosen sphere, the finish.
format::Result<OutOfCoreSimplify> simplify_sampled(Partition& partition_ref, const std::vector<GaussSphere>& spheres,
                                                   const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify base);
format::Result<OutOfCoreSimplify> simplify_ladder(Partition& partition, const OutOfCoreSimplifyOptions& options,
                                                  OutOfCoreSimplify base);
// The finish on the input itself (stream::finish_collapses_input): the input gathered from the
// chunks' owned faces, as compact_input has it in core. Sets `done` unless the input is not a
// manifold OpenMesh can hold (then the Gauss approximation is the caller's to make).
format::Status simplify_input(Partition& partition, const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify& out,
                              bool& done);

format::Result<OutOfCoreSimplify> run_simplify(const std::string& input_path, const format::ReadOptions& read,
                                               const OutOfCoreSimplifyOptions& options);

}  // namespace

format::Result<OutOfCoreSimplify> simplify_out_of_core(const std::string& input_path, const format::ReadOptions& read,
                                                       const OutOfCoreSimplifyOptions& options) {
  auto run = run_simplify(input_path, read, options);
  // The records' polygon mesher refuses a patch layout whose output would not be a manifold, and
  // a vertex with two fans can pass through it into the output. On a manifold input neither
  // happens (docs/meshing.md); on a non-manifold one out of core there is no whole input to split
  // (docs/cli.md, "Non-manifold input"): the error names the input and says so. The output held
  // whole is checked; a chunked finish's collapses keep the input's topology.
  std::string problem;
  if (!run && run.status().code() == format::Code::kProcessing && run.status().where() == "polygon mesher") {
    problem = run.status().message();
  } else if (run && !run->parts && !run->mesh.triangles.empty() && !options.samples_only) {
    auto topology = compute_topology(run->mesh.view());
    if (!topology) return topology.status();
    if (topology->non_manifold_edges > 0) problem = "the output would have an edge with more than two faces";
    else if (topology->non_manifold_vertices > 0) problem = "the output would have a vertex joining separate fans";
  }
  if (!problem.empty()) {
    return format::Status::error(format::Code::kProcessing, input_path == "-" ? "<stdin>" : input_path,
                                 "not a manifold where the out-of-core mesher needs one (" + problem +
                                     "): an edge with more than two faces or a vertex joining separate fans, which "
                                     "`gaussmesh info` counts; the in-core engine (--engine in-core) splits them");
  }
  return run;
}

namespace {

format::Result<OutOfCoreSimplify> run_simplify(const std::string& input_path, const format::ReadOptions& read,
                                               const OutOfCoreSimplifyOptions& options) {
  GM_RETURN_IF_ERROR(check_out_of_core_options("simplify", options.spheres, options.threads));
  // The frequency ladder (auto, exact test) creates its spheres pass by pass.
  const bool ladder = options.auto_frequency && options.finish.any() && options.spheres.size() > 1 &&
                      options.sampler.sample_test != SampleTest::kPaper;
  std::vector<GaussSphere> spheres;
  if (!ladder) {
    auto created = create_spheres(options.spheres);
    if (!created) return created.status();
    spheres = std::move(created).value();
  } else {
    // The first rung (frequency 1) is cheap: creating it checks the rotation all rungs share.
    auto first = GaussSphere::create(options.spheres.front());
    if (!first) return first.status();
  }
  PartitionOptions partition_options = options.partition;
  // The output names no input ids: a scattered input is renumbered in spatial order first.
  partition_options.reorder_scattered = true;
  // A target may take the chunked finish, whose pieces are a chunk's owned faces: chunks small
  // enough for a thread's share of the budget (the output does not depend on the chunks).
  if (options.auto_frequency && options.finish.any() && partition_options.max_chunk_faces == 0) {
    const std::uint32_t rings = required_overlap_rings(options.sampler.smooth_iterations);
    partition_options.max_chunk_faces =
        std::min(sample_pass_chunk_faces(options.memory, options.threads, rings),
                 chunked_finish_chunk_faces(options.memory));
  }
  auto partition = partition_for_chunks(input_path, read, partition_options, options.memory, options.sampler, options.threads);
  if (!partition) return partition.status();
  OutOfCoreSimplify base;
  record_partition(*partition, base);
  base.finish_options = resolve_finish(options.finish, partition->faces, diagonal_of(partition->lo, partition->hi));
  GM_RETURN_IF_ERROR(check_finish_target(base.finish_options, partition->faces, input_path));
  if (options.auto_frequency && options.finish.any() && finish_collapses_input(base.finish_options, partition->faces)) {
    bool done = false;
    GM_RETURN_IF_ERROR(simplify_input(*partition, options, base, done));
    if (done) return base;
  }
  if (options.auto_frequency && options.finish.any()) {
    OutOfCoreSimplifyOptions resolved = options;
    resolved.min_samples = finish_min_samples(base.finish_options, partition->faces);
    // A Gauss approximation the target needs that would not fit the budget: the chunked finish
    // on the input itself instead, which fits any budget.
    const std::uint64_t limit = options.memory_explicit ? options.memory.bytes() : options.memory_ceiling;
    if (limit > 0 && finish_memory_estimate(resolved.min_samples, 1, partition->faces) > limit) {
      OutOfCoreSimplifyOptions chunked = options;
      chunked.always_chunked_finish = true;
      bool done = false;
      GM_RETURN_IF_ERROR(simplify_input(*partition, chunked, base, done));
      if (done) return base;
    }
    resolved.auto_frequency = false;
    if (ladder) return simplify_ladder(*partition, resolved, std::move(base));
    return simplify_sampled(*partition, spheres, resolved, std::move(base));
  }
  return simplify_sampled(*partition, spheres, options, std::move(base));
}

// --frequency auto, exact test: the ladder's sample counts from counting passes over the chunks
// (the cheap frequencies, up to kLadderGroupFrequency, in one pass; each finer one in a pass of
// its own, only while none has reached min_samples), so that no finer sphere than the chosen
// one is ever sampled; then the whole run with the chosen sphere. The counts are the in-core
// run's, so the choice is too.
constexpr std::uint32_t kLadderGroupFrequency = 16;

// The refusal of a finish that would hold `need` bytes, more than `limit`; `what` says what it
// holds ("an approximation of about N faces").
format::Status too_large_for_budget(const std::string& what, std::uint64_t need, std::uint64_t limit,
                                    bool explicit_budget) {
  const std::string held = "the target needs " + what + ", about " + std::to_string(need >> 20) + " MiB, ";
  if (explicit_budget) {
    return format::Status::error(format::Code::kResources, "--memory",
                                 held + "above the budget of " + std::to_string(limit >> 20) +
                                     " MiB: raise --memory or lower the target");
  }
  return format::Status::error(format::Code::kResources, "--memory",
                               held + "more than a quarter of this machine's memory (" + std::to_string(limit >> 20) +
                                   " MiB): lower the target");
}

std::string approximation_of(std::uint64_t samples) {
  return "an approximation of about " + std::to_string(2 * samples) + " faces";
}

format::Status simplify_input(Partition& partition, const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify& out,
                              bool& done) {
  const std::uint64_t need = input_finish_memory_estimate(partition.faces);
  out.finish_memory_estimate = need;
  const std::uint64_t limit = options.memory_explicit ? options.memory.bytes() : options.memory_ceiling;
  const auto start = Clock::now();
  if ((limit > 0 && need > limit) || options.always_chunked_finish) {
    // Too large to hold whole: the chunked finish, piece by piece within the budget.
    const std::uint64_t whole_output =
        out.finish_options.target_faces * options.whole_output_bytes_per_face + (std::uint64_t{20} << 20);  // and the process
    if (options.memory_explicit && options.whole_output_bytes_per_face > 0 && whole_output > limit) {
      return format::Status::error(
          format::Code::kResources, "--memory",
          "the output's " + std::to_string(out.finish_options.target_faces) + " faces need about " +
              std::to_string(whole_output >> 20) + " MiB to write in this format, above the budget of " +
              std::to_string(limit >> 20) + " MiB: write PLY or OBJ (streamed), raise --memory or lower the target");
    }
    ChunkedFinishOptions chunked;
    chunked.finish = out.finish_options;
    chunked.threads = options.threads;
    chunked.last_round_locked_share_before_one_piece = options.last_round_locked_share_before_one_piece;
    chunked.memory = options.memory_explicit ? options.memory : MemoryBudget::of(limit);
    if (options.progress)
      chunked.progress = [&](const char* pass, std::size_t done_pieces, std::size_t total) {
        options.progress(pass, done_pieces, total, partition.faces);
      };
    auto finished = chunked_finish(partition, chunked);
    if (!finished) return finished.status();
    FinishResult r;
    r.approximation_faces = finished->input_faces;
    r.collapses = finished->collapses;
    r.refused = finished->refused;
    r.estimated_error = finished->estimated_error;
    const std::uint64_t target = out.finish_options.target_faces;
    r.reached_target = target == 0 || finished->output->face_count() <= target;
    r.stopped_by = r.reached_target ? (target == 0 && finished->over_error > 0 ? "max_error" : "target")
                                    : finished->over_error > 0 ? "max_error" : "topology";
    r.seconds_quadrics = finished->seconds_rounds.front();
    for (std::size_t i = 1; i < finished->seconds_rounds.size(); ++i) r.seconds_decimate += finished->seconds_rounds[i];
    out.chunked = ChunkedFinishFigures{finished->round_pieces, finished->round_faces, finished->round_locked_faces,
                                       finished->seconds_rounds, finished->largest_piece, finished->unheld_pieces};
    out.finish = std::move(r);
    out.seconds_mesh = seconds_since(start);
    out.bytes_spilled = partition.bytes_spilled;
    // The output is read from the temporary directory when it is written: it goes with it.
    finished->output->own(std::move(partition));
    if (out.attribute_spill) out.input_triangles = owned_triangles(finished->output->partition(), options.threads, chunked.memory);
    out.parts = std::move(finished->output);
    out.collapsed_input = true;
    done = true;
    return format::Status();
  }
  struct OwnedFace {
    std::uint64_t id;
    format::Triangle t;  // global vertex ids
  };
  std::vector<OwnedFace> faces;
  std::vector<format::Vec3f> positions(partition.vertices);
  std::mutex mutex;
  GM_RETURN_IF_ERROR(for_each_chunk(
      partition, options.threads,
      [&](std::size_t, const ChunkMesh& chunk, ChunkSamplerWorkspace&) {
        std::vector<OwnedFace> mine;
        for (std::size_t f = 0; f < chunk.triangles.size(); ++f) {
          if (!chunk.owned_face[f]) continue;
          const auto& t = chunk.triangles[f];
          mine.push_back({chunk.global_face[f], {{chunk.global_vertex[t.v[0]], chunk.global_vertex[t.v[1]],
                                                  chunk.global_vertex[t.v[2]]}}});
        }
        std::lock_guard<std::mutex> lock(mutex);
        for (std::size_t v = 0; v < chunk.positions.size(); ++v)
          if (chunk.owned_vertex[v] && chunk.global_vertex[v] < positions.size())
            positions[chunk.global_vertex[v]] = chunk.positions[v];
        faces.insert(faces.end(), mine.begin(), mine.end());
        return format::Status();
      },
      [&](std::size_t done_chunks, std::size_t total) {
        if (options.progress) options.progress("gather", done_chunks, total, partition.faces);
      },
      options.memory));
  std::sort(faces.begin(), faces.end(), [](const OwnedFace& a, const OwnedFace& b) { return a.id < b.id; });
  std::vector<format::Triangle> triangles;
  triangles.reserve(faces.size());
  for (const auto& f : faces) triangles.push_back(f.t);
  std::vector<OwnedFace>().swap(faces);
  Mesh compact = compact_input(positions, triangles);
  std::vector<format::Vec3f>().swap(positions);
  std::vector<format::Triangle>().swap(triangles);
  auto finished = finish_input(compact.view(), out.finish_options);
  if (!finished) {
    if (finished.status().code() != format::Code::kProcessing) return finished.status();
    return format::Status();  // not a manifold: the Gauss approximation
  }
  out.mesh = std::move(finished->mesh);
  out.finish = std::move(finished).value();
  out.seconds_mesh = seconds_since(start);
  out.bytes_spilled = partition.bytes_spilled;
  if (out.attribute_spill) {
    // The input's triangles for its attributes: the caller lets the files go after them.
    out.input_partition = std::make_shared<Partition>(std::move(partition));
    out.input_triangles = owned_triangles(*out.input_partition, options.threads, options.memory);
  } else {
    const auto cleanup = Clock::now();
    partition.remove_temp();
    out.seconds_cleanup = seconds_since(cleanup);
  }
  out.collapsed_input = true;
  done = true;
  return format::Status();
}

format::Result<OutOfCoreSimplify> simplify_ladder(Partition& partition, const OutOfCoreSimplifyOptions& options,
                                                  OutOfCoreSimplify base) {
  const auto start = Clock::now();
  const std::vector<GaussSphereOptions>& ladder = options.spheres;
  // The chosen approximation has at least min_samples samples (unless no rung reaches them): when
  // even that passes an explicit budget, say so before any counting pass.
  const std::uint64_t limit = options.memory_explicit ? options.memory.bytes() : options.memory_ceiling;
  const std::uint64_t least = finish_memory_estimate(options.min_samples, ladder.front().frequency, partition.faces);
  if (limit > 0 && options.min_samples <= partition.faces && least > limit)
    return too_large_for_budget(approximation_of(options.min_samples), least, limit, options.memory_explicit);
  std::vector<std::size_t> counts;
  std::size_t chosen = ladder.size() - 1;
  bool found = false;
  for (std::size_t next = 0; next < ladder.size() && !found;) {
    std::size_t end = next + 1;
    while (end < ladder.size() && ladder[end].frequency <= kLadderGroupFrequency) ++end;
    // Only this pass's spheres are held: a finer G costs memory (~3 KB per f²).
    auto created = create_spheres(std::vector<GaussSphereOptions>(ladder.begin() + next, ladder.begin() + end));
    if (!created) return created.status();
    const std::vector<GaussSphere>& spheres = *created;
    std::vector<std::size_t> part(end - next, 0);
    std::mutex mutex;
    GM_RETURN_IF_ERROR(for_each_chunk(
        partition, options.threads,
        [&](std::size_t, const ChunkMesh& chunk, ChunkSamplerWorkspace& ws) {
          std::vector<std::size_t> mine(end - next, 0);
          for (std::size_t k = next; k < end; ++k) {
            std::vector<GlobalSample> samples;
            ChunkSamplingStats stats;
            GM_RETURN_IF_ERROR(sample_chunk(chunk, spheres[k - next], options.sampler, ws, samples, stats));
            mine[k - next] = samples.size();
          }
          std::lock_guard<std::mutex> lock(mutex);
          for (std::size_t i = 0; i < mine.size(); ++i) part[i] += mine[i];
          return format::Status();
        },
        [&](std::size_t done, std::size_t total) {
          if (options.progress) options.progress("frequency", done, total, partition.faces);
        },
        options.memory));
    for (std::size_t k = next; k < end && !found; ++k) {
      counts.push_back(part[k - next]);
      if (counts.back() >= options.min_samples) chosen = k, found = true;
    }
    next = end;
  }
  const double seconds_ladder = seconds_since(start);
  // The stitch, the mesher and the finish hold the approximation: about two faces per sample,
  // kFinishBytesPerFace each at their peak. An explicit budget is a contract (refuse what would
  // pass it); the automatic one grows to what the target needs, up to memory_ceiling.
  const std::uint64_t need = finish_memory_estimate(counts[chosen], ladder[chosen].frequency, partition.faces);
  base.finish_memory_estimate = need;
  if (limit > 0 && need > limit)
    return too_large_for_budget(approximation_of(counts[chosen]), need, limit, options.memory_explicit);
  OutOfCoreSimplifyOptions one = options;
  one.min_samples = 0;
  one.spheres = {ladder[chosen]};
  auto sphere = create_spheres(one.spheres);
  if (!sphere) return sphere.status();
  auto run = simplify_partition(partition, std::span(sphere->data(), 1), one, std::move(base), true);
  if (!run) return run.status();
  run->chosen = chosen;
  run->samples_per_orientation = counts;
  run->seconds_sample += seconds_ladder;
  return run;
}

format::Result<OutOfCoreSimplify> simplify_sampled(Partition& partition_ref, const std::vector<GaussSphere>& spheres,
                                                   const OutOfCoreSimplifyOptions& options, OutOfCoreSimplify base) {
  Partition* partition = &partition_ref;
  const std::size_t no = spheres.size();
  if (options.sampler.sample_test != SampleTest::kPaper || no == 1)
    return simplify_partition(*partition, spheres, options, std::move(base), true);

  // The paper test's samples come after the merge and the chains, so each orientation runs the
  // passes up to its samples (as sample_mesh_best_orientation samples the mesh once per
  // orientation); the one with the fewest (ties: the first) is kept — with `samples_only` as it
  // is, else run again to the end.
  OutOfCoreSimplifyOptions counting = options;
  counting.samples_only = true;
  std::vector<std::size_t> counts;
  std::size_t chosen = 0;
  double seconds_sample = 0, seconds_stitch = 0, seconds_cleanup = 0;
  std::optional<OutOfCoreSimplify> best;
  for (std::size_t k = 0; k < no; ++k) {
    const bool last = options.samples_only && k + 1 == no;
    auto run = simplify_partition(*partition, std::span(&spheres[k], 1), counting, base, last);
    if (!run) return run.status();
    counts.push_back(run->samples);
    seconds_sample += run->seconds_sample;
    seconds_stitch += run->seconds_stitch;
    seconds_cleanup += run->seconds_cleanup;
    if (choose_sphere(counts, options.min_samples) == k) {
      chosen = k;
      if (options.samples_only) best = std::move(run).value();
    }
    release_free_memory();
  }
  if (!options.samples_only) {
    auto run = simplify_partition(*partition, std::span(&spheres[chosen], 1), options, base, true);
    if (!run) return run.status();
    best = std::move(run).value();
    best->seconds_sample += seconds_sample;
    best->seconds_stitch += seconds_stitch;
  } else {
    best->seconds_sample = seconds_sample;
    best->seconds_stitch = seconds_stitch;
    best->seconds_cleanup = seconds_cleanup;
    best->bytes_spilled = partition->bytes_spilled;
  }
  best->chosen = chosen;
  best->samples_per_orientation = counts;
  return std::move(best).value();
}

}  // namespace

}  // namespace gaussmesh::stream