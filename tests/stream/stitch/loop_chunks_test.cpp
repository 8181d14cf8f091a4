// The loops pass's records (stream/stitch/loop_chunks.h): a loop chunk finds the whole chunk's
// runs and vertex records under any merged patches; damaged loop chunks are kBadInput.
#include "stream/stitch/loop_chunks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/pipeline/in_core_simplify.h"
#include "tests/support/records.h"
#include "stream/stitch/paper_chains.h"
#include "tests/support/paper_pairs.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

TEST(LoopChunks, LoopChunksFindTheWholeChunksLoopsUnderAnyCoarserPatches) {
  // The loops pass reads, where it can, a loop chunk: the faces near the chunk's feature edges
  // (write_loop_chunk). Pieces here are cells of a fine grid (by face centroid) within each chunk,
  // feature edges the edges between cells (and breaks), and the merged patches any coarser
  // grouping of cells (every cell, pairs, or a hash into a few groups): an edge inside a cell
  // joins one patch, as a non-feature edge does under the stitch's merges. On every
  // chunk of the cow and a noisy sphere, the loop chunk must give the whole chunk's runs, run
  // vertices and vertex records, and its pieces' areas summed must give the patches' areas.
  const Mesh sphere = [] {
    testing::ShapeOptions o;
    o.vertices = 15000;
    o.seed = 5;
    o.noise = 0.01;
    return testing::make_sphere(o);
  }();
  testing::ScratchDir tmp;
  {
    auto out = format::OutputFile::create(tmp.file("sphere.ply"), true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_ply(**out, sphere.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  std::size_t loop_chunks = 0, chunks = 0;
  for (const std::string& path : {testing::fixture("real/cow.off"), tmp.file("sphere.ply")}) {
    SCOPED_TRACE(path);
    PartitionOptions partition;
    partition.rings = 1;
    partition.max_chunk_faces = 2500;
    partition.memory_bytes = std::uint64_t{64} << 20;
    partition.tmp_dir = tmp.path().string();
    auto parts = partition_mesh(path, {}, partition);
    ASSERT_TRUE(parts.is_ok()) << parts.status().to_string();
    auto cell_of = [&](const ChunkMesh& chunk, std::uint32_t f) {
      format::Vec3f c{0, 0, 0};
      for (std::uint32_t v : chunk.triangles[f].v) {
        c.x += chunk.positions[v].x / 3;
        c.y += chunk.positions[v].y / 3;
        c.z += chunk.positions[v].z / 3;
      }
      auto q = [&](float x, float lo, float hi) { return static_cast<std::uint32_t>(std::clamp((x - lo) / (hi - lo), 0.0f, 0.999f) * 4); };
      return q(c.x, parts->lo.x, parts->hi.x) * 16 + q(c.y, parts->lo.y, parts->hi.y) * 4 + q(c.z, parts->lo.z, parts->hi.z);
    };
    const std::function<std::uint32_t(std::uint32_t)> groupings[] = {
        [](std::uint32_t cell) { return cell; }, [](std::uint32_t cell) { return cell / 2; },
        [](std::uint32_t cell) { return (cell * 2654435761u) >> 30; }};
    for (const ChunkInfo& info : parts->chunks) {
      auto chunk = load_chunk(info);
      ASSERT_TRUE(chunk.is_ok()) << chunk.status().to_string();
      MeshAdjacency adjacency;
      ASSERT_TRUE(build_mesh_adjacency(chunk->view(), adjacency).is_ok());
      const std::size_t nf = chunk->triangles.size();
      // Pieces: the chunk's owned faces by cell, numbered in order of first face.
      std::vector<std::uint32_t> piece_index(nf, 0xFFFFFFFFu), cell(nf), piece_cell;
      std::map<std::uint32_t, std::uint32_t> piece_of_cell;
      for (std::uint32_t f = 0; f < nf; ++f) {
        cell[f] = cell_of(*chunk, f);
        if (!chunk->owned_face[f]) continue;
        auto [it, added] = piece_of_cell.emplace(cell[f], static_cast<std::uint32_t>(piece_cell.size()));
        if (added) piece_cell.push_back(cell[f]);
        piece_index[f] = it->second;
      }
      // Feature bits as the sampler's are to its labels: a break, or another cell across the edge
      // (so an edge without its bit joins one patch under every grouping below).
      std::vector<std::uint8_t> feature(nf, 0);
      for (std::uint32_t f = 0; f < nf; ++f)
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t g = adjacency.edge_neighbor[3 * f + i];
          if (g == MeshAdjacency::kNoFace || cell[g] != cell[f]) feature[f] |= static_cast<std::uint8_t>(1u << i);
        }
      std::vector<GlobalSample> samples;
      for (std::uint32_t v = 0; v < chunk->positions.size(); v += 37)
        if (chunk->owned_vertex[v]) samples.push_back({chunk->global_vertex[v], chunk->positions[v]});
      ChunkInfo loop_info;
      std::vector<std::array<double, 3>> piece_area;
      auto file = format::RecordSegmentFile::create(tmp.file("loop-" + std::to_string(info.id) + ".gmr"));
      ASSERT_TRUE(file.is_ok());
      auto written = write_loop_chunk(*chunk, info, adjacency, piece_index, feature, samples, **file, loop_info, piece_area);
      ASSERT_TRUE(written.is_ok()) << written.status().to_string();
      ++chunks;
      if (!*written) continue;
      ++loop_chunks;
      auto loop = load_chunk(loop_info);
      ASSERT_TRUE(loop.is_ok()) << loop.status().to_string();
      EXPECT_LT(loop->triangles.size(), nf);
      MeshAdjacency loop_adjacency;
      ASSERT_TRUE(build_mesh_adjacency(loop->view(), loop_adjacency).is_ok());
      for (std::uint32_t f = 0; f < loop->triangles.size(); ++f) {
        if (loop->owned_face[f]) {
          ASSERT_EQ(piece_cell[loop->loop_piece[f]], cell_of(*loop, f));
        }
      }
      auto is_corner = [](std::uint32_t v) { return v % 11 == 0; };
      for (const auto& group : groupings) {
        std::vector<std::uint32_t> patch(nf), loop_patch(loop->triangles.size());
        for (std::uint32_t f = 0; f < nf; ++f) patch[f] = group(cell[f]);
        for (std::uint32_t f = 0; f < loop_patch.size(); ++f) loop_patch[f] = group(cell_of(*loop, f));
        ChunkLoops whole, part;
        ASSERT_TRUE(find_chunk_loops(*chunk, adjacency, patch, is_corner, samples, whole).is_ok());
        ASSERT_TRUE(find_chunk_loops(*loop, loop_adjacency, loop_patch, is_corner, samples, part).is_ok());
        ASSERT_EQ(whole.runs.size(), part.runs.size());
        for (std::size_t k = 0; k < whole.runs.size(); ++k) {
          const LoopRunRecord &a = whole.runs[k], &b = part.runs[k];
          EXPECT_TRUE(a.first == b.first && a.next == b.next && a.min_id == b.min_id && a.offset == b.offset &&
                      a.min_index == b.min_index && a.length == b.length && a.patch == b.patch && a.breaks == b.breaks)
              << "run " << k << " of chunk " << info.id;
        }
        ASSERT_EQ(whole.run_vertices.size(), part.run_vertices.size());
        for (std::size_t k = 0; k < whole.run_vertices.size(); ++k)
          EXPECT_EQ(whole.run_vertices[k].vertex, part.run_vertices[k].vertex);
        ASSERT_EQ(whole.vertices.size(), part.vertices.size());
        for (std::size_t k = 0; k < whole.vertices.size(); ++k) {
          const LoopVertexRecord &a = whole.vertices[k], &b = part.vertices[k];
          EXPECT_TRUE(a.vertex == b.vertex && a.degree == b.degree && a.role == b.role && a.interior_patch == b.interior_patch)
              << "vertex " << a.vertex << " of chunk " << info.id;
        }
        EXPECT_TRUE(part.areas.empty());
        std::map<std::uint32_t, std::array<double, 3>> summed;
        for (std::uint32_t k = 0; k < piece_area.size(); ++k)
          for (int i = 0; i < 3; ++i) summed[group(piece_cell[k])][i] += piece_area[k][i];
        ASSERT_EQ(summed.size(), whole.areas.size());
        for (const auto& [p, sum] : whole.areas)
          for (int i = 0; i < 3; ++i) EXPECT_NEAR(summed[p][i], sum[i], 1e-9 * (1 + std::abs(sum[i])));
      }
    }
  }
  std::printf("%zu of %zu chunks as loop chunks\n", loop_chunks, chunks);
  EXPECT_GT(loop_chunks, chunks / 4);
}

TEST(LoopChunks, DamagedLoopChunksAreBadInput) {
  // A loop chunk file is read by load_chunk like a chunk file, with its own checks: a piece on a
  // face the chunk does not own or none on one it owns, corners of one vertex that disagree on
  // its loop bit, and the file taken for a plain chunk file (another kind) are kBadInput.
  testing::ScratchDir tmp;
  PartitionOptions partition;
  partition.max_chunk_faces = 2500;
  partition.tmp_dir = tmp.path().string();
  auto parts = partition_mesh(testing::fixture("real/cow.off"), {}, partition);
  ASSERT_TRUE(parts.is_ok()) << parts.status().to_string();
  const ChunkInfo& info = parts->chunks[0];
  auto chunk = load_chunk(info);
  ASSERT_TRUE(chunk.is_ok());
  MeshAdjacency adjacency;
  ASSERT_TRUE(build_mesh_adjacency(chunk->view(), adjacency).is_ok());
  std::vector<std::uint32_t> piece_index(chunk->triangles.size(), 0xFFFFFFFFu);
  std::vector<std::uint8_t> feature(chunk->triangles.size(), 0);
  for (std::uint32_t f = 0; f < piece_index.size(); ++f) {
    if (!chunk->owned_face[f]) continue;
    piece_index[f] = 0;  // one piece whose edges to other owners are features: R is the chunk's border
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adjacency.edge_neighbor[3 * f + i];
      if (g == MeshAdjacency::kNoFace || !chunk->owned_face[g]) feature[f] |= static_cast<std::uint8_t>(1u << i);
    }
  }
  ChunkInfo loop_info;
  std::vector<std::array<double, 3>> areas;
  auto file = format::RecordSegmentFile::create(tmp.file("loop.gmr"));
  ASSERT_TRUE(file.is_ok());
  auto written = write_loop_chunk(*chunk, info, adjacency, piece_index, feature, {}, **file, loop_info, areas);
  ASSERT_TRUE(written.is_ok() && *written);
  ASSERT_TRUE(load_chunk(loop_info).is_ok());
  // The file's one segment is the whole file: rewritten below as a record file of its own.
  ASSERT_EQ(loop_info.segment.offset, 0u);
  ASSERT_EQ(loop_info.segment.bytes, (*file)->size());
  loop_info.segment = {};
  auto read = testing::read_all_records(loop_info.path, kLoopChunkRecordKind, kLoopChunkRecordBytes);
  ASSERT_TRUE(read.is_ok()) << read.status().to_string();
  std::vector<std::byte> records = std::move(*read);
  auto expect_bad = [&](const ChunkInfo& damaged, const std::string& what) {
    auto loaded = load_chunk(damaged);
    ASSERT_FALSE(loaded.is_ok()) << what;
    EXPECT_EQ(loaded.status().code(), format::Code::kBadInput) << what;
    EXPECT_NE(loaded.status().to_string().find(damaged.path), std::string::npos) << loaded.status().to_string();
  };
  auto rewrite = [&](const std::function<void(std::vector<std::byte>&)>& damage, const std::string& what) {
    std::vector<std::byte> copy = records;
    damage(copy);
    ASSERT_TRUE(testing::write_all_records(loop_info.path, kLoopChunkRecordKind, kLoopChunkRecordBytes, copy).is_ok());
    expect_bad(loop_info, what);
  };
  const std::size_t n = records.size() / kLoopChunkRecordBytes;
  auto flags = [&](std::vector<std::byte>& r, std::size_t k) -> std::byte& { return r[k * kLoopChunkRecordBytes + 20]; };
  auto piece = [&](std::vector<std::byte>& r, std::size_t k) { return r.data() + k * kLoopChunkRecordBytes + 21; };
  std::size_t owned = n, foreign = n, looped = n;
  for (std::size_t k = 0; k < n; ++k) {
    const auto f = std::to_integer<std::uint8_t>(flags(records, k));
    if (f & kOwnsFace) owned = std::min(owned, k);
    else foreign = std::min(foreign, k);
    if (f & (kLoopCornerVertex * 7)) looped = std::min(looped, k);
  }
  ASSERT_TRUE(owned < n && foreign < n && looped < n);
  rewrite([&](auto& r) { std::memset(piece(r, owned), 0xFF, 4); }, "no piece on an owned face");
  rewrite([&](auto& r) { std::memset(piece(r, foreign), 0, 4); }, "a piece on a face not owned");
  rewrite([&](auto& r) {
    const auto f = std::to_integer<std::uint8_t>(flags(r, looped));
    for (int j = 0; j < 3; ++j)
      if (f & (kLoopCornerVertex << j)) {
        flags(r, looped) = std::byte{static_cast<std::uint8_t>(f & ~(kLoopCornerVertex << j))};
        break;
      }
  }, "a vertex's corners disagree on its loop bit");
  ChunkInfo plain = loop_info;
  plain.loop = false;
  expect_bad(plain, "a loop chunk read as a chunk file");
}

TEST(LoopChunks, SpilledLoopSummariesComeBackAsTheyWere) {
  // spill_loop_summaries frees the arrays and keeps their counts; read_loop_summaries gives every
  // field back, including a chunk with nothing; a file cut short anywhere, or missing, is
  // kBadInput naming it.
  testing::ScratchDir tmp;
  std::vector<ChunkLoopSummary> chunks(3);
  for (std::uint32_t c = 0; c < 3; c += 2) {  // chunk 1 stays empty
    for (std::uint32_t k = 0; k < 5 + c; ++k) {
      LoopRunRecord r;
      r.first = 3 * (100 * c + k), r.next = r.first + 7, r.min_id = r.first, r.offset = 4 * k;
      r.min_index = k % 2, r.length = 4, r.patch = 10 + k, r.breaks = k % 3, r.chunk = c;
      chunks[c].runs.push_back(r);
      chunks[c].vertices.push_back({1000 * c + k, {float(k), 0.5f, -float(c)}, 3, k % 2 ? VertexRole::kSample : VertexRole::kCorner,
                                    k == 2 ? 10u : 0xFFFFFFFFu});
      chunks[c].areas.push_back({10 + k, {0.25 * k, -1.0, 1e-3 * c}});
    }
    chunks[c].path = "run-vertices-" + std::to_string(c);
    chunks[c].segment = {64u * c, 32u};
    chunks[c].entries = 4u * (5 + c);
    chunks[c].bytes = 99;
  }
  const std::vector<ChunkLoopSummary> before = chunks;
  const std::string path = tmp.file("summaries.bin");
  ASSERT_TRUE(spill_loop_summaries(chunks, path).is_ok());
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    EXPECT_EQ(chunks[c].runs.capacity() + chunks[c].vertices.capacity() + chunks[c].areas.capacity(), 0u);
    EXPECT_EQ(chunks[c].path, before[c].path);
  }
  EXPECT_EQ(chunks[2].spilled_runs, 7u);
  EXPECT_EQ(chunks[2].spilled_vertices, 7u);
  EXPECT_EQ(chunks[2].spilled_areas, 7u);
  auto read = read_loop_summaries(chunks, path);
  ASSERT_TRUE(read.is_ok()) << read.status().to_string();
  ASSERT_EQ(read->size(), before.size());
  for (std::size_t c = 0; c < before.size(); ++c) {
    const ChunkLoopSummary &r = (*read)[c], &b = before[c];
    EXPECT_EQ(r.runs.size(), b.runs.size());
    for (std::size_t k = 0; k < std::min(r.runs.size(), b.runs.size()); ++k) {
      EXPECT_EQ(r.runs[k].first, b.runs[k].first);
      EXPECT_EQ(r.runs[k].next, b.runs[k].next);
      EXPECT_EQ(r.runs[k].offset, b.runs[k].offset);
      EXPECT_EQ(r.runs[k].patch, b.runs[k].patch);
      EXPECT_EQ(r.runs[k].chunk, b.runs[k].chunk);
      EXPECT_EQ(r.runs[k].breaks, b.runs[k].breaks);
    }
    EXPECT_EQ(r.vertices.size(), b.vertices.size());
    for (std::size_t k = 0; k < std::min(r.vertices.size(), b.vertices.size()); ++k) {
      EXPECT_EQ(r.vertices[k].vertex, b.vertices[k].vertex);
      EXPECT_EQ(r.vertices[k].position.x, b.vertices[k].position.x);
      EXPECT_EQ(r.vertices[k].role, b.vertices[k].role);
      EXPECT_EQ(r.vertices[k].interior_patch, b.vertices[k].interior_patch);
    }
    EXPECT_TRUE(r.areas == b.areas);
    EXPECT_EQ(r.path, b.path);
    EXPECT_EQ(r.segment.offset, b.segment.offset);
    EXPECT_EQ(r.entries, b.entries);
    EXPECT_EQ(r.bytes, b.bytes);
  }
  const auto size = std::filesystem::file_size(path);
  for (const auto cut : {std::uintmax_t{0}, size / 2, size - 1}) {
    std::filesystem::resize_file(path, cut);
    auto short_read = read_loop_summaries(chunks, path);
    ASSERT_FALSE(short_read.is_ok()) << "cut to " << cut;
    EXPECT_EQ(short_read.status().code(), format::Code::kBadInput);
    EXPECT_NE(short_read.status().to_string().find(path), std::string::npos) << short_read.status().to_string();
  }
  std::filesystem::remove(path);
  auto missing = read_loop_summaries(chunks, path);
  ASSERT_FALSE(missing.is_ok());
  EXPECT_EQ(missing.status().code(), format::Code::kBadInput);
}

}  // namespace
}  // namespace gaussmesh::stream
