// The untriangulatable-patch merge on the patch graph (PatchMergeGraph, stream/sampling/patch_filters.h)
// on explicit records, without a mesh: the plan's rules on small hand-made graphs, and random
// graphs against a plain reference that recomputes everything from the input each round
// (patches as components of input patches, candidate counts and shared-edge counts from
// scratch). The mesh-level equality with the previous O(mesh) rounds is in
// sampler_regression_test.cpp.
#include "stream/sampling/patch_filters.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "stream/core/mesh.h"

namespace gaussmesh::stream {
namespace {

// Input from pairs and candidate lists.
PatchGraphInput make_input(const std::vector<std::uint32_t>& labels, const std::vector<PatchPair>& pairs,
                           const std::vector<std::vector<std::uint32_t>>& candidates) {
  PatchGraphInput in;
  in.patch_label = labels;
  in.patch_size.assign(labels.size(), 1);
  patch_neighbors_from_pairs(pairs, in);
  in.candidate_offsets.push_back(0);
  for (const auto& list : candidates) {
    in.candidate_patches.insert(in.candidate_patches.end(), list.begin(), list.end());
    in.candidate_offsets.push_back(static_cast<std::uint32_t>(in.candidate_patches.size()));
  }
  return in;
}

const PatchMergeGraph::Reevaluate keep_all = [](PatchMergeGraph&, std::span<const std::uint32_t>,
                                                std::vector<std::uint8_t>&) {};

TEST(PatchMergeGraph, JoinsTheNeighbourSharingMostEdgesTiesToLowestId) {
  // 0 (no candidate) touches 1 by 2 edges and 2 by 3 edges: joins 2. 3 (no candidate) touches
  // 1 and 2 by 2 edges each: joins 1 (tie, lowest id). 1 and 2 have 3 candidates each.
  const std::vector<std::vector<std::uint32_t>> cands = {{1}, {1}, {1}, {2}, {2}, {2}};
  const PatchGraphInput in = make_input({10, 11, 12, 13}, {{0, 1, 2}, {0, 2, 3}, {1, 3, 2}, {2, 3, 2}}, cands);
  PatchMergeGraph g;
  g.reset(in);
  EXPECT_EQ(g.round(keep_all), 2u);
  EXPECT_EQ(g.patch(0), 0u);  // 0 and 2 are one patch, named by its lowest id
  EXPECT_EQ(g.patch(2), 0u);
  EXPECT_EQ(g.label(0), 12u);
  EXPECT_EQ(g.patch(3), 1u);
  EXPECT_EQ(g.label(3), 11u);
  EXPECT_EQ(g.candidate_count(0), 3u);
  EXPECT_EQ(g.round(keep_all), 0u);
  PatchMergeResult r;
  g.finish(r);
  EXPECT_EQ(r.patch_of, (std::vector<std::uint32_t>{0, 1, 0, 1}));
  EXPECT_EQ(r.patch_label, (std::vector<std::uint32_t>{12, 11}));
  EXPECT_EQ(r.patch_size, (std::vector<std::uint32_t>{2, 2}));
  EXPECT_EQ(r.adjacency, (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 1}}));
  EXPECT_EQ(r.merged_patches, 2u);
  EXPECT_EQ(r.rounds, 1u);
}

TEST(PatchMergeGraph, APatchThatAbsorbsOrWhoseTargetLeavesWaitsForTheNextRound) {
  // A chain 0 - 1 - 2 - 3 - 4 of patches without candidates, 4 also touching 5 (3 candidates).
  // Round 1: 0 joins 1 (1 absorbs, so 1 stays); 2's best is 1 (2 edges), and 1 is not leaving:
  // 2 joins 1 too; 3's best is 4 (3 edges): joins 4; 4 absorbs: stays.
  const std::vector<std::vector<std::uint32_t>> cands = {{5}, {5}, {5}};
  const PatchGraphInput in =
      make_input({1, 2, 3, 4, 5, 6}, {{0, 1, 1}, {1, 2, 2}, {2, 3, 1}, {3, 4, 3}, {4, 5, 1}}, cands);
  PatchMergeGraph g;
  g.reset(in);
  EXPECT_EQ(g.round(keep_all), 3u);
  EXPECT_EQ(g.patch(2), 0u);
  EXPECT_EQ(g.label(0), 2u);
  EXPECT_EQ(g.patch(3), 3u);
  EXPECT_EQ(g.label(3), 5u);
  // Round 2: {0, 1, 2} touches {3, 4} by 1 edge: joins it; {3, 4} absorbs. Round 3: {0..4}
  // (no candidate) joins 5.
  EXPECT_EQ(g.round(keep_all), 1u);
  EXPECT_EQ(g.patch(4), 0u);
  EXPECT_EQ(g.label(1), 5u);
  EXPECT_EQ(g.round(keep_all), 1u);
  EXPECT_EQ(g.label(0), 6u);
  EXPECT_EQ(g.round(keep_all), 0u);
}

TEST(PatchMergeGraph, ALeavingPatchAlsoJoinsOtherNeighboursOfItsTargetsLabel) {
  // 1 (no candidate) joins 0 (label 7, 2 shared edges); 1 also touches 2, label 7 too, which
  // is not adjacent to 0: all three become one patch. 3 touches 1 and 2: its edges add up.
  const std::vector<std::vector<std::uint32_t>> cands = {{0, 3}, {0, 3}, {0, 3}, {2, 3}, {2, 3}, {2, 3}};
  const PatchGraphInput in = make_input({7, 8, 7, 9}, {{0, 1, 2}, {1, 2, 1}, {1, 3, 1}, {2, 3, 4}, {0, 3, 1}}, cands);
  PatchMergeGraph g;
  g.reset(in);
  EXPECT_EQ(g.round(keep_all), 1u);
  EXPECT_EQ(g.patch(1), 0u);
  EXPECT_EQ(g.patch(2), 0u);
  EXPECT_EQ(g.label(2), 7u);
  EXPECT_EQ(g.candidate_count(0), 6u);  // candidates of 0 and of 2, each once
  PatchMergeResult r;
  g.finish(r);
  EXPECT_EQ(r.patch_of, (std::vector<std::uint32_t>{0, 0, 0, 1}));
  EXPECT_EQ(r.adjacency, (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 1}}));
}

TEST(PatchMergeGraph, CandidatesThatLoseCandidacyStopCountingAndAreReportedOnce) {
  // 0 has 3 candidates, 1 none, 2 three. 1 joins 0 (more edges); the callback sees the
  // candidates counting for 1 ({0, 1}: they also count for 0) and drops candidate 1, so 0
  // keeps 2 candidates and joins 2 in the next round.
  const std::vector<std::vector<std::uint32_t>> cands = {{0, 1}, {0, 1}, {0}, {2}, {2}, {2}};
  const PatchGraphInput in = make_input({1, 2, 3}, {{0, 1, 3}, {1, 2, 1}, {0, 2, 1}}, cands);
  PatchMergeGraph g;
  g.reset(in);
  std::vector<std::vector<std::uint32_t>> seen;
  const PatchMergeGraph::Reevaluate drop_one = [&](PatchMergeGraph& graph, std::span<const std::uint32_t> touched,
                                                   std::vector<std::uint8_t>& still) {
    seen.emplace_back(touched.begin(), touched.end());
    ASSERT_EQ(still.size(), touched.size());
    for (std::size_t k = 0; k < touched.size(); ++k) still[k] = touched[k] != 1;
    EXPECT_EQ(graph.current_label(1), seen.size() == 1 ? 1u : 3u);  // after the round
  };
  EXPECT_EQ(g.merge(drop_one), 2u);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], (std::vector<std::uint32_t>{0, 1}));
  EXPECT_EQ(seen[1], (std::vector<std::uint32_t>{0, 2}));  // 1 is no candidate any more
  PatchMergeResult r;
  g.finish(r);
  EXPECT_EQ(r.patch_of, (std::vector<std::uint32_t>{0, 0, 0}));
  EXPECT_EQ(r.patch_label, (std::vector<std::uint32_t>{3}));
  EXPECT_EQ(r.is_candidate, (std::vector<std::uint8_t>{1, 0, 1, 1, 1, 1}));
}

TEST(PatchMergeGraph, StopsAfterMaxRoundsAndLeavesIsolatedPatchesAlone) {
  // 0 and 1: no candidates, no neighbours. A chain 2 - 3 - ... - 9 of patches without
  // candidates merges one step per round at most; max_rounds = 2 stops it early.
  std::vector<std::uint32_t> labels(10);
  std::iota(labels.begin(), labels.end(), 0u);
  std::vector<PatchPair> pairs;
  for (std::uint32_t p = 2; p + 1 < 10; ++p) pairs.push_back({p, p + 1, p});  // more edges further on
  const PatchGraphInput in = make_input(labels, pairs, {});
  PatchMergeGraph g;
  g.reset(in);
  EXPECT_EQ(g.merge(keep_all, 2), 2u);
  EXPECT_GT(g.round(keep_all), 0u);  // more was left to merge
  PatchMergeResult r;
  g.finish(r);
  EXPECT_EQ(r.patch_of[0], 0u);
  EXPECT_EQ(r.patch_of[1], 1u);
}

// ---- Random graphs against a plain reference -----------------------------------------------

// Recomputes components, candidate counts and shared edges from the input every round.
struct Reference {
  const PatchGraphInput& in;
  std::vector<std::uint32_t> comp;   // per input patch: its current patch (lowest input id)
  std::vector<std::uint32_t> label;  // per current patch
  std::vector<std::uint8_t> alive;   // per candidate
  std::size_t merged = 0, rounds = 0;

  explicit Reference(const PatchGraphInput& input)
      : in(input), comp(input.patch_label.size()), label(input.patch_label),
        alive(input.candidate_offsets.size() - 1, 1) {
    std::iota(comp.begin(), comp.end(), 0u);
  }
  std::set<std::uint32_t> patches_of(std::uint32_t c) const {
    std::set<std::uint32_t> s;
    for (std::uint32_t j = in.candidate_offsets[c]; j < in.candidate_offsets[c + 1]; ++j) s.insert(comp[in.candidate_patches[j]]);
    return s;
  }
  std::map<std::uint32_t, std::uint32_t> counts() const {
    std::map<std::uint32_t, std::uint32_t> n;
    for (std::uint32_t c = 0; c < alive.size(); ++c)
      if (alive[c])
        for (std::uint32_t p : patches_of(c)) ++n[p];
    return n;
  }
  std::map<std::uint32_t, std::map<std::uint32_t, std::uint32_t>> shared() const {
    std::map<std::uint32_t, std::map<std::uint32_t, std::uint32_t>> e;
    for (std::uint32_t p = 0; p < comp.size(); ++p)
      for (std::uint32_t j = in.neighbor_offsets[p]; j < in.neighbor_offsets[p + 1]; ++j) {
        const std::uint32_t a = comp[p], b = comp[in.neighbors[j].patch];
        if (a != b) e[a][b] += in.neighbors[j].edges;
      }
    return e;
  }
  // One round; touched gets the candidates to re-evaluate; decide says which stay.
  template <typename Decide>
  std::size_t round(std::vector<std::uint32_t>& touched, const Decide& decide) {
    std::set<std::uint32_t> roots(comp.begin(), comp.end());
    const auto n = counts();
    const auto e = shared();
    std::map<std::uint32_t, std::uint32_t> target;
    std::set<std::uint32_t> absorbs;
    for (std::uint32_t p : roots) {
      if ((n.count(p) && n.at(p) >= 3) || !e.count(p)) continue;
      std::uint32_t best = 0, most = 0;
      for (const auto& [q, k] : e.at(p))
        if (k > most) {
          best = q;
          most = k;
        }
      if (absorbs.count(p) || target.count(best)) continue;
      target[p] = best;
      absorbs.insert(best);
    }
    touched.clear();
    if (target.empty()) return 0;
    for (std::uint32_t c = 0; c < alive.size(); ++c) {
      if (!alive[c]) continue;
      for (std::uint32_t p : patches_of(c))
        if (target.count(p)) {
          touched.push_back(c);
          break;
        }
    }
    std::map<std::uint32_t, std::uint32_t> relabel;
    for (std::uint32_t p : roots) relabel[p] = target.count(p) ? label[target.at(p)] : label[p];
    // Adjacent patches with equal labels become one (lowest id).
    std::vector<std::uint32_t> up(comp.size());
    std::iota(up.begin(), up.end(), 0u);
    auto find = [&](std::uint32_t x) {
      while (up[x] != x) x = up[x];
      return x;
    };
    for (const auto& [p, list] : e)
      for (const auto& [q, k] : list)
        if (relabel.at(p) == relabel.at(q)) {
          const std::uint32_t a = find(p), b = find(q);
          if (a != b) up[std::max(a, b)] = std::min(a, b);
        }
    for (std::uint32_t p : roots) label[find(p)] = relabel.at(p);
    for (auto& c : comp) c = find(c);
    for (std::uint32_t c : touched) alive[c] = decide(c);
    merged += target.size();
    ++rounds;
    return target.size();
  }
};

struct Rng {
  std::uint64_t s;
  std::uint32_t next(std::uint32_t n) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::uint32_t>((s >> 33) % n);
  }
};

// A random graph: patches on a ring of clusters with random extra links, few labels (so that
// leaving patches often touch other patches of their target's label), adjacent labels
// different, candidates on 1-4 neighbouring patches, sparse enough that many patches have
// fewer than 3.
PatchGraphInput random_graph(std::uint64_t seed, std::uint32_t np) {
  Rng rng{seed};
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> edges;
  auto link = [&](std::uint32_t a, std::uint32_t b) {
    if (a == b) return;
    edges[{std::min(a, b), std::max(a, b)}] = 1 + rng.next(4);
  };
  for (std::uint32_t p = 0; p < np; ++p) {
    link(p, (p + 1) % np);
    for (std::uint32_t k = rng.next(3); k > 0; --k) link(p, (p + 1 + rng.next(6)) % np);
    if (rng.next(10) == 0) link(p, rng.next(np));
  }
  std::vector<std::vector<std::uint32_t>> around(np);
  for (const auto& [pq, e] : edges) {
    around[pq.first].push_back(pq.second);
    around[pq.second].push_back(pq.first);
  }
  std::vector<std::uint32_t> labels(np, 0xFFFFFFFFu);
  for (std::uint32_t p = 0; p < np; ++p) {
    for (int tries = 0; tries < 20 && labels[p] == 0xFFFFFFFFu; ++tries) {
      const std::uint32_t l = rng.next(5);
      bool clash = false;
      for (std::uint32_t q : around[p]) clash = clash || labels[q] == l;
      if (!clash) labels[p] = l;
    }
    if (labels[p] == 0xFFFFFFFFu) labels[p] = 100 + p;
  }
  std::vector<PatchPair> pairs;
  for (const auto& [pq, e] : edges) pairs.push_back({pq.first, pq.second, e});
  std::vector<std::vector<std::uint32_t>> cands;
  const std::uint32_t nc = np * (1 + rng.next(3)) / 2;
  for (std::uint32_t c = 0; c < nc; ++c) {
    std::set<std::uint32_t> list;
    std::uint32_t p = rng.next(np);
    list.insert(p);
    for (std::uint32_t k = rng.next(4); k > 0 && !around[p].empty(); --k) list.insert(around[p][rng.next(around[p].size())]);
    cands.emplace_back(list.begin(), list.end());
  }
  PatchGraphInput in = make_input(labels, pairs, cands);
  for (std::uint32_t p = 0; p < np; ++p) in.patch_size[p] = 1 + rng.next(9);
  return in;
}

TEST(PatchMergeGraph, RandomGraphsEqualAReferenceThatRecomputesEverythingEachRound) {
  std::size_t merged = 0, max_rounds = 0, dropped = 0;
  PatchMergeGraph g;  // reused across graphs
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const PatchGraphInput in = random_graph(seed, 50 + 17 * static_cast<std::uint32_t>(seed % 9));
    auto decide = [seed](std::uint32_t c, std::size_t round) {
      return ((c * 2654435761u) ^ (round * 40503u) ^ seed) % 3 != 0;
    };
    Reference ref(in);
    g.reset(in);
    std::vector<std::uint32_t> want_touched;
    for (int round = 0; round < kMaxMergeRounds; ++round) {
      std::vector<std::uint32_t> got_touched;
      const PatchMergeGraph::Reevaluate reevaluate = [&](PatchMergeGraph& graph, std::span<const std::uint32_t> touched,
                                                         std::vector<std::uint8_t>& still) {
        got_touched.assign(touched.begin(), touched.end());
        for (std::size_t k = 0; k < touched.size(); ++k) {
          still[k] = decide(touched[k], graph.rounds());
          // Labels are those after the round.
          for (std::uint32_t j = in.candidate_offsets[touched[k]]; j < in.candidate_offsets[touched[k] + 1]; ++j) {
            const std::uint32_t p = in.candidate_patches[j];
            ASSERT_EQ(graph.current_patch(p), graph.patch(p));
          }
        }
      };
      const std::size_t got = g.round(reevaluate);
      const std::size_t want = ref.round(want_touched, [&](std::uint32_t c) { return decide(c, ref.rounds + 1); });
      ASSERT_EQ(got, want) << "round " << round;
      if (got == 0) break;
      ASSERT_EQ(got_touched, want_touched) << "round " << round;
      for (std::uint32_t p = 0; p < ref.comp.size(); ++p) {
        ASSERT_EQ(g.patch(p), ref.comp[p]) << "round " << round << " patch " << p;
        ASSERT_EQ(g.label(p), ref.label[ref.comp[p]]) << "round " << round << " patch " << p;
      }
      const auto counts = ref.counts();
      for (std::uint32_t p = 0; p < ref.comp.size(); ++p) {
        if (ref.comp[p] != p) continue;
        ASSERT_EQ(g.candidate_count(p), counts.count(p) ? counts.at(p) : 0u) << "patch " << p;
      }
    }
    PatchMergeResult r;
    g.finish(r);
    // Final numbering, labels, sizes, adjacency and candidates.
    std::map<std::uint32_t, std::uint32_t> id;
    for (std::uint32_t p = 0; p < ref.comp.size(); ++p)
      if (ref.comp[p] == p) id.emplace(p, static_cast<std::uint32_t>(id.size()));
    ASSERT_EQ(r.patch_label.size(), id.size());
    std::vector<std::uint32_t> size(id.size(), 0);
    for (std::uint32_t p = 0; p < ref.comp.size(); ++p) {
      EXPECT_EQ(r.patch_of[p], id.at(ref.comp[p]));
      size[id.at(ref.comp[p])] += in.patch_size[p];
    }
    for (const auto& [p, k] : id) EXPECT_EQ(r.patch_label[k], ref.label[p]);
    EXPECT_EQ(r.patch_size, size);
    std::set<std::pair<std::uint32_t, std::uint32_t>> adjacency;
    for (const auto& [p, list] : ref.shared())
      for (const auto& [q, k] : list)
        if (p < q) adjacency.insert({id.at(p), id.at(q)});
    const std::vector<std::pair<std::uint32_t, std::uint32_t>> want_adjacency(adjacency.begin(), adjacency.end());
    EXPECT_EQ(r.adjacency, want_adjacency);
    EXPECT_EQ(r.is_candidate, ref.alive);
    EXPECT_EQ(r.merged_patches, ref.merged);
    EXPECT_EQ(r.rounds, ref.rounds);
    merged += ref.merged;
    max_rounds = std::max(max_rounds, ref.rounds);
    dropped += static_cast<std::size_t>(std::count(ref.alive.begin(), ref.alive.end(), 0));
  }
  std::printf("random graphs: %zu patches merged, up to %zu rounds, %zu candidates dropped\n", merged, max_rounds, dropped);
  EXPECT_GE(max_rounds, 4u);
  EXPECT_GT(dropped, 0u);
}

// ---- The in-core builder ------------------------------------------------------------------------

TEST(PatchMergeGraph, BuilderCountsSharedEdgesAndCollapsedFacesCountForTheirPatch) {
  // A strip of four triangles 0..3 over vertices 0..5, plus a collapsed face on vertex 2.
  //   1---3---5
  //  / \ / \ /
  // 0---2---4
  Mesh m;
  m.positions = {{0, 0, 0}, {0.5f, 1, 0}, {1, 0, 0}, {1.5f, 1, 0}, {2, 0, 0}, {2.5f, 1, 0}};
  m.triangles = {{{0, 2, 1}}, {{1, 2, 3}}, {{2, 4, 3}}, {{3, 4, 5}}, {{2, 2, 4}}};
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  const std::vector<std::uint32_t> labels = {5, 5, 6, 7, 0xFFFFFFFFu};
  std::vector<std::uint8_t> feature(5, 0);
  for (std::uint32_t f = 0; f < 5; ++f)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = adj.edge_neighbor[3 * f + i];
      if (g == MeshAdjacency::kNoFace || labels[g] != labels[f]) feature[f] |= static_cast<std::uint8_t>(1u << i);
    }
  const Patches p = find_patches(adj, labels, feature);
  ASSERT_EQ(p.patch_label, (std::vector<std::uint32_t>{5, 6, 7, 0xFFFFFFFFu}));
  PatchGraphInput in;
  PatchGraphBuildScratch scratch;
  const std::vector<std::uint32_t> candidates = {2, 3};
  build_patch_graph(m.view(), adj, p, feature, candidates, in, scratch);
  EXPECT_EQ(in.patch_size, (std::vector<std::uint32_t>{2, 1, 1, 1}));
  ASSERT_EQ(in.neighbor_offsets, (std::vector<std::uint32_t>{0, 1, 3, 4, 4}));
  EXPECT_EQ(in.neighbors[0].patch, 1u);  // in the order the patch's faces meet them
  EXPECT_EQ(in.neighbors[0].edges, 1u);
  EXPECT_EQ(in.neighbors[1].patch, 2u);
  EXPECT_EQ(in.neighbors[2].patch, 0u);
  EXPECT_EQ(in.neighbors[3].patch, 1u);
  // Vertex 2: star patches 0, 1 and the collapsed face's patch 3; vertex 3: 0, 1, 2.
  EXPECT_EQ(in.candidate_offsets, (std::vector<std::uint32_t>{0, 3, 6}));
  std::vector<std::uint32_t> first(in.candidate_patches.begin(), in.candidate_patches.begin() + 3);
  std::vector<std::uint32_t> second(in.candidate_patches.begin() + 3, in.candidate_patches.end());
  std::sort(first.begin(), first.end());
  std::sort(second.begin(), second.end());
  EXPECT_EQ(first, (std::vector<std::uint32_t>{0, 1, 3}));
  EXPECT_EQ(second, (std::vector<std::uint32_t>{0, 1, 2}));
}

}  // namespace
}  // namespace gaussmesh::stream
