// The loop stitch (stream/stitch/loop_stitch.h): runs joined across chunks into loops from their
// lowest half-edge; runs that do not close, or disagree with their files, are kBadInput.
#include "stream/stitch/loop_stitch.h"

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

// A square patch 0 whose loop runs through two chunks: chunk 0 holds half-edges 30, 31 (from
// vertices 40, 41), chunk 1 holds 10, 11 (from 42, 43). Chunk 1 also owns vertex 41, a corner.
std::vector<ChunkLoops> two_chunk_square() {
  std::vector<ChunkLoops> chunks(2);
  auto run = [](std::uint64_t first, std::uint64_t next, std::uint64_t min_id, std::uint32_t min_index, std::uint32_t chunk) {
    LoopRunRecord r;
    r.first = first;
    r.next = next;
    r.min_id = min_id;
    r.min_index = min_index;
    r.length = 2;
    r.chunk = chunk;
    return r;
  };
  chunks[0].runs.push_back(run(30, 10, 30, 0, 0));
  chunks[0].run_vertices = {{40, {0, 0, 0}}, {41, {1, 0, 0}}};
  chunks[1].runs.push_back(run(10, 30, 10, 0, 1));
  chunks[1].run_vertices = {{42, {1, 1, 0}}, {43, {0, 1, 0}}};
  LoopVertexRecord corner;
  corner.vertex = 41;
  corner.position = {1, 0, 0};
  corner.degree = 3;
  corner.role = VertexRole::kCorner;
  chunks[1].vertices.push_back(corner);
  chunks[0].areas.push_back({0, {0, 0, 2}});
  return chunks;
}

// Every chunk's run vertices as segments of one new file (as the loops pass writes them).
std::vector<ChunkLoopSummary> spill(std::vector<ChunkLoops> chunks, const testing::ScratchDir& dir) {
  static int calls = 0;
  auto file = format::RecordSegmentFile::create(dir.file("loops-" + std::to_string(calls++)));
  EXPECT_TRUE(file.is_ok());
  std::vector<ChunkLoopSummary> out;
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    auto s = spill_chunk_loops(std::move(chunks[c]), **file);
    EXPECT_TRUE(s.is_ok());
    out.push_back(std::move(s).value());
  }
  return out;
}


TEST(LoopStitch, StitchLoopsJoinsRunsAcrossChunksFromTheirLowestHalfEdge) {
  testing::ScratchDir dir;
  const auto summaries = spill(two_chunk_square(), dir);
  LoopStitchStats stats;
  auto g = stitch_loops(summaries, 1, {{0, 0, 1}}, dir.path().string(), {{44, {0.5f, 0.5f, 0}}}, &stats);
  ASSERT_TRUE(g.is_ok()) << g.status().to_string();
  EXPECT_EQ(stats.runs, 2u);
  EXPECT_EQ(stats.half_edges, 4u);
  EXPECT_EQ(stats.vertices, 5u);
  EXPECT_EQ(g->global, (std::vector<std::uint32_t>{40, 41, 42, 43, 44}));
  // The loops are in a file: one loop of 4 half-edges.
  EXPECT_TRUE(g->loops.empty());
  ASSERT_TRUE(g->loop_source);
  EXPECT_EQ(g->loop_patch, (std::vector<std::uint32_t>{0}));
  EXPECT_EQ(g->loop_offset, (std::vector<std::uint64_t>{0, 4}));
  // Starts at half-edge 10 (chunk 1's run): vertices 42, 43, then 40, 41 — as dense ids.
  std::vector<std::uint32_t> loop(4);
  ASSERT_TRUE(g->loop_source->read(0, loop));
  EXPECT_EQ(loop, (std::vector<std::uint32_t>{2, 3, 0, 1}));
  std::vector<std::uint32_t> beyond(2);
  EXPECT_FALSE(g->loop_source->read(3, beyond));  // past the last entry
  EXPECT_FALSE(g->loop_source->status().is_ok());
  EXPECT_EQ(g->role[1], VertexRole::kCorner);
  EXPECT_EQ(g->role[0], VertexRole::kNone);
  EXPECT_EQ(g->graph.corners, 1u);
  EXPECT_EQ(g->graph.feature_edges, 2u);
  EXPECT_EQ(g->patch_area[0][2], 2.0);
  ASSERT_TRUE(g->position_source);
  const format::Vec3f p = g->position_source->position(2), q = g->position_source->position(4);
  EXPECT_EQ(p.x, 1.0f);
  EXPECT_EQ(p.y, 1.0f);
  EXPECT_EQ(q.x, 0.5f);
  EXPECT_TRUE(g->position_source->status().is_ok());
  g->position_source->position(5);  // out of range
  EXPECT_FALSE(g->position_source->status().is_ok());
}

TEST(LoopStitch, TheLoopFileGivesEveryLoopInAnyOrderAcrossItsReadWindows) {
  // Thousands of small loops and one longer than the loop file's read-ahead window (16,384
  // entries), each a run closing on itself in one chunk, one patch each: every loop reads back
  // as its dense ids in file order, backwards and in a scattered order (reads that fall in,
  // across and outside the window), and a read past the end still fails.
  testing::ScratchDir dir;
  std::vector<ChunkLoops> chunks(1);
  std::vector<std::vector<std::uint32_t>> expected;
  std::uint32_t vertex = 0;
  const std::uint32_t patches = 3001;
  for (std::uint32_t p = 0; p < patches; ++p) {
    const std::uint32_t n = p == 1500 ? 40000 : 3 + p % 5;
    LoopRunRecord r;
    r.first = r.next = r.min_id = 3 * std::uint64_t{vertex};
    r.offset = chunks[0].run_vertices.size();
    r.length = n;
    r.patch = p;
    chunks[0].runs.push_back(r);
    expected.emplace_back();
    for (std::uint32_t k = 0; k < n; ++k, ++vertex) {
      chunks[0].run_vertices.push_back({vertex, {float(k), float(p), 0}});
      expected.back().push_back(vertex);  // ids ascending from 0: each is its own dense id
    }
  }
  const auto summaries = spill(std::move(chunks), dir);
  auto g = stitch_loops(summaries, patches, std::vector<format::Vec3f>(patches, {0, 0, 1}), dir.path().string());
  ASSERT_TRUE(g.is_ok()) << g.status().to_string();
  ASSERT_TRUE(g->loop_source);
  ASSERT_EQ(g->loop_offset.size(), patches + 1u);
  auto check = [&](std::size_t l) {
    std::vector<std::uint32_t> loop(g->loop_offset[l + 1] - g->loop_offset[l]);
    ASSERT_TRUE(g->loop_source->read(g->loop_offset[l], loop)) << "loop " << l;
    ASSERT_EQ(loop, expected[l]) << "loop " << l;
  };
  for (std::size_t l = 0; l < patches; ++l) check(l);
  for (std::size_t l = patches; l-- > 0;) check(l);
  for (std::size_t k = 0; k < patches; ++k) check(k * 1237 % patches);
  EXPECT_TRUE(g->loop_source->status().is_ok());
  std::vector<std::uint32_t> beyond(2);
  EXPECT_FALSE(g->loop_source->read(g->loop_offset.back() - 1, beyond));
  EXPECT_FALSE(g->loop_source->status().is_ok());
}

TEST(LoopStitch, StitchLoopsRefusesRunsThatDoNotCloseOrDisagreeWithTheirFiles) {
  testing::ScratchDir dir;
  auto expect_bad = [&](std::vector<ChunkLoopSummary> s, const char* what) {
    SCOPED_TRACE(what);
    auto g = stitch_loops(s, 1, {{0, 0, 1}}, dir.path().string());
    ASSERT_FALSE(g.is_ok());
    EXPECT_EQ(g.status().code(), format::Code::kBadInput) << g.status().to_string();
  };
  {
    auto chunks = two_chunk_square();
    chunks[1].runs[0].next = 31;  // leads into the middle of a run
    expect_bad(spill(std::move(chunks), dir), "successor starts no run");
  }
  {
    auto chunks = two_chunk_square();
    chunks[1].runs[0].patch = 1;
    expect_bad(spill(std::move(chunks), dir), "patch out of range");
  }
  {
    auto s = spill(two_chunk_square(), dir);
    s[0].runs[0].length = 3;  // the file holds two
    expect_bad(s, "summary longer than the file");
  }
  {
    auto s = spill(two_chunk_square(), dir);
    std::filesystem::resize_file(s[1].path, std::filesystem::file_size(s[1].path) - 3);
    expect_bad(s, "truncated run file");
  }
  {
    auto chunks = two_chunk_square();
    chunks[0].vertices.push_back(chunks[1].vertices[0]);  // one vertex owned twice
    expect_bad(spill(std::move(chunks), dir), "vertex twice");
  }
}


}  // namespace
}  // namespace gaussmesh::stream
