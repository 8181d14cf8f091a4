// The paper test's chain fragments (stream/stitch/paper_chains.h): joined across chunks by the feature
// edges they leave by, a chain through several chunks gives one pair, a closed chain or one that
// comes back to its candidate none; damaged joins are kBadInput. (The whole pass against the
// in-core find_candidate_adjacency: tests/stream/pipeline/out_of_core_simplify_test.cpp,
// out_of_core_sample_test.cpp.)
#include "stream/stitch/paper_chains.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using Pairs = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

ChainFragment candidate_and_link(std::uint32_t candidate, std::uint32_t from, std::uint32_t to) {
  return {{candidate, std::uint64_t{from} << 32 | to}, 2};
}
ChainFragment two_links(std::uint32_t from0, std::uint32_t to0, std::uint32_t from1, std::uint32_t to1) {
  return {{std::uint64_t{from0} << 32 | to0, std::uint64_t{from1} << 32 | to1}, 3};
}

// Each chunk's fragments as a segment of one file, as the chain pass writes them.
std::vector<ChunkRecordSegment> write(const std::vector<std::vector<ChainFragment>>& chunks, const testing::ScratchDir& dir) {
  static int calls = 0;
  auto file = format::RecordSegmentFile::create(dir.file("fragments-" + std::to_string(calls++)));
  EXPECT_TRUE(file.is_ok());
  std::vector<ChunkRecordSegment> out;
  for (const auto& fragments : chunks) {
    auto s = write_chain_fragments(fragments, **file);
    EXPECT_TRUE(s.is_ok());
    out.push_back(std::move(s).value());
  }
  return out;
}

TEST(PaperChains, FragmentsJoinIntoOnePairPerChainAcrossChunks) {
  testing::ScratchDir dir;
  std::vector<std::vector<ChainFragment>> chunks(3);
  // Candidate 5 (chunk 0) to candidate 7 (chunk 2) through chunk 1: 10 | 20 .. 21 | 30.
  chunks[0].push_back(candidate_and_link(5, 10, 20));
  chunks[1].push_back(two_links(20, 10, 21, 30));
  chunks[2].push_back(candidate_and_link(7, 30, 21));
  // A closed chain of non-candidates over two chunks: no pair.
  chunks[0].push_back(two_links(40, 50, 41, 51));
  chunks[1].push_back(two_links(50, 40, 51, 41));
  // A chain that leaves candidate 8 and comes back to it: no pair.
  chunks[1].push_back(candidate_and_link(8, 60, 61));
  chunks[2].push_back(candidate_and_link(8, 61, 60));
  // An edge held twice from each side (two faces that disagree on orientation), between two
  // chunks, each end a candidate away: 3 and 9.
  chunks[0].push_back({{3, std::uint64_t{70} << 32 | 71}, 2});
  chunks[2].push_back({{std::uint64_t{71} << 32 | 70, 9}, 1});
  Pairs pairs;
  ASSERT_TRUE(join_chain_fragments(write(chunks, dir), MemoryBudget(64 << 20), pairs).is_ok());
  std::sort(pairs.begin(), pairs.end());
  EXPECT_EQ(pairs, (Pairs{{3, 9}, {5, 7}}));
}

TEST(PaperChains, ManyFragmentsAreJoinedInParts) {
  // 200k links: more than one 1 MiB part, so the links are matched a part at a time.
  testing::ScratchDir dir;
  std::vector<std::vector<ChainFragment>> chunks(2);
  constexpr std::uint32_t kChains = 100000;
  for (std::uint32_t k = 0; k < kChains; ++k) {
    const std::uint32_t a = 1000000 + 2 * k, b = a + 1;
    chunks[0].push_back(candidate_and_link(k, a, b));
    chunks[1].push_back({{std::uint64_t{b} << 32 | a, 500000 + k}, 1});
  }
  Pairs pairs;
  ASSERT_TRUE(join_chain_fragments(write(chunks, dir), MemoryBudget(), pairs).is_ok());
  ASSERT_EQ(pairs.size(), kChains);
  std::sort(pairs.begin(), pairs.end());
  for (std::uint32_t k = 0; k < kChains; ++k) EXPECT_EQ(pairs[k], std::make_pair(k, 500000 + k));
}

TEST(PaperChains, LinksSeenFromOneSideOrChainsWithThreeEndsAreBadInput) {
  testing::ScratchDir dir;
  {
    std::vector<std::vector<ChainFragment>> chunks(2);
    chunks[0].push_back(candidate_and_link(5, 10, 20));
    chunks[1].push_back(candidate_and_link(6, 21, 11));  // not the edge 10-20
    Pairs pairs;
    const format::Status s = join_chain_fragments(write(chunks, dir), MemoryBudget(), pairs);
    EXPECT_EQ(s.code(), format::Code::kBadInput) << s.to_string();
  }
  {
    std::vector<std::vector<ChainFragment>> chunks(2);
    // Edge 10-20 left twice from each side joins four fragments into one chain with four ends.
    chunks[0].push_back(candidate_and_link(5, 10, 20));
    chunks[0].push_back(candidate_and_link(9, 10, 20));
    chunks[1].push_back({{std::uint64_t{20} << 32 | 10, 6}, 1});
    chunks[1].push_back({{std::uint64_t{20} << 32 | 10, 4}, 1});
    Pairs pairs;
    const format::Status s = join_chain_fragments(write(chunks, dir), MemoryBudget(), pairs);
    EXPECT_EQ(s.code(), format::Code::kBadInput) << s.to_string();
  }
}

TEST(PaperChains, PairsDigestTellsListsApart) {
  const Pairs a{{1, 2}, {3, 4}}, b{{1, 2}, {3, 5}}, c{{1, 2}};
  EXPECT_EQ(candidate_pairs_digest(a), candidate_pairs_digest(Pairs(a)));
  EXPECT_NE(candidate_pairs_digest(a), candidate_pairs_digest(b));
  EXPECT_NE(candidate_pairs_digest(a), candidate_pairs_digest(c));
}

}  // namespace
}  // namespace gaussmesh::stream
