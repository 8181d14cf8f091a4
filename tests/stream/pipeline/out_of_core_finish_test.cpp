// The chunked finish (stream/pipeline/out_of_core_finish.h), through simplify_out_of_core on the
// fixtures cut into chunks of a few hundred faces: the output
// lands on the target, keeps the input's topology, has no degenerate or duplicate face, is the
// same for one thread and two, stays near the whole-input collapse in quality, and leaves
// nothing behind.
#include "stream/pipeline/out_of_core_finish.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/mesh_topology.h"
#include "stream/finish/quadric_finish.h"
#include "stream/pipeline/out_of_core_simplify.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

struct ChunkedRun {
  Mesh mesh;
  OutOfCoreSimplify result;
};

ChunkedRun run_chunked(const std::string& path, double ratio, std::uint32_t threads, std::uint64_t chunk_faces,
                       double locked_share = kLastRoundLockedShareBeforeOnePiece) {
  testing::ScratchDir tmp;
  OutOfCoreSimplifyOptions options;
  options.threads = threads;
  options.partition.max_chunk_faces = chunk_faces;
  options.partition.tmp_dir = tmp.path().string();
  options.memory = MemoryBudget(std::uint64_t{16} << 20);
  options.memory_explicit = true;
  options.always_chunked_finish = true;
  options.last_round_locked_share_before_one_piece = locked_share;
  options.auto_frequency = true;
  options.finish.ratio = ratio;
  auto ooc = simplify_out_of_core(path, {}, options);
  EXPECT_TRUE(ooc.is_ok()) << ooc.status().to_string();
  ChunkedRun run;
  if (!ooc) return run;
  EXPECT_TRUE(ooc->chunked.has_value());
  EXPECT_TRUE(ooc->parts != nullptr);
  if (ooc->parts) {
    EXPECT_TRUE(ooc->parts->vertices([&](std::span<const Vec3f> b) {
      run.mesh.positions.insert(run.mesh.positions.end(), b.begin(), b.end());
      return format::Status();
    }).is_ok());
    EXPECT_TRUE(ooc->parts->faces([&](std::span<const Triangle> b) {
      run.mesh.triangles.insert(run.mesh.triangles.end(), b.begin(), b.end());
      return format::Status();
    }).is_ok());
    EXPECT_EQ(run.mesh.positions.size(), ooc->parts->vertex_count());
    EXPECT_EQ(run.mesh.triangles.size(), ooc->parts->face_count());
    ooc->parts.reset();  // removes the temporary directory
  }
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  run.result = std::move(ooc).value();
  return run;
}

TEST(ChunkedFinish, LandsOnTheTargetWithTheInputsTopologyOnEveryFixture) {
  // Closed of genus 0 and higher, open with boundaries and holes, CAD with sharp creases.
  for (const char* name : {"cow.off", "homer.off", "knot1.off", "mushroom.off", "fandisk.off", "mech-holes-shark.off",
                           "bunny-lowres.ply"}) {
    const std::string path = testing::fixture(std::string("real/") + name);
    auto input = load_mesh(path);
    ASSERT_TRUE(input.is_ok());
    auto before = compute_topology(input->view());
    ASSERT_TRUE(before.is_ok());
    for (double ratio : {0.1, 0.02}) {
      SCOPED_TRACE(std::string(name) + " ratio " + std::to_string(ratio));
      ChunkedRun run = run_chunked(path, ratio, 2, 400);
      ASSERT_TRUE(run.result.finish.has_value());
      ASSERT_TRUE(run.result.chunked.has_value());
      const auto& chunked = *run.result.chunked;
      EXPECT_GT(chunked.round_pieces.front(), 4u);  // many pieces, so many locked borders
      EXPECT_GE(chunked.round_pieces.size(), 2u);
      EXPECT_EQ(chunked.unheld_pieces, 0u);
      const auto target = run.result.finish_options.target_faces;
      const auto faces = run.mesh.triangles.size();
      if (run.result.finish->stopped_by == std::string("target")) {
        EXPECT_LE(faces, target);
        EXPECT_GE(double(faces), std::floor(0.99 * double(target)) - 1);
      } else {
        // Short of it only where the topology forbids more.
        EXPECT_EQ(run.result.finish->stopped_by, std::string("topology"));
        EXPECT_GT(faces, target);
      }
      auto after = compute_topology(run.mesh.view());
      ASSERT_TRUE(after.is_ok());
      EXPECT_TRUE(after->is_manifold());
      EXPECT_EQ(after->degenerate_faces, 0u);
      EXPECT_EQ(after->duplicate_faces, 0u);
      EXPECT_EQ(after->unreferenced_vertices, 0u);
      EXPECT_EQ(after->is_closed(), before->is_closed());
      EXPECT_EQ(after->components, before->components);
      EXPECT_EQ(after->boundary_loops, before->boundary_loops);
      if (before->genus) {
        EXPECT_EQ(after->genus, before->genus);
      }
    }
  }
}

TEST(ChunkedFinish, RoundTwoLeavesTheTargetToOnePieceWhenItsBordersAreLong) {
  // When what round 2 would leave fits one piece, round 2 aims at the target only with at most
  // kLastRoundLockedShareBeforeOnePiece of it at locked vertices, and otherwise leaves it to round
  // 3, one piece with no locked vertex. At these ratios round 2 has a few pieces whose locked faces
  // take 13-40 % of the target; aiming at it anyway (a share of a half, which none of these
  // passes) costs distance.
  std::size_t deferred = 0;
  double sum_now = 0, sum_half = 0;
  for (const char* name : {"cow.off", "homer.off", "knot1.off"}) {
    const std::string path = testing::fixture(std::string("real/") + name);
    auto input = load_mesh(path);
    ASSERT_TRUE(input.is_ok());
    for (double ratio : {0.3, 0.2}) {
      SCOPED_TRACE(std::string(name) + " ratio " + std::to_string(ratio));
      ChunkedRun now = run_chunked(path, ratio, 2, 400), half = run_chunked(path, ratio, 2, 400, 0.5);
      ASSERT_TRUE(now.result.chunked.has_value() && half.result.chunked.has_value());
      const auto& c = *now.result.chunked;
      const auto target = now.result.finish_options.target_faces;
      ASSERT_EQ(c.round_locked_faces.size() + 1, c.round_faces.size());
      ASSERT_GT(c.round_faces[0], target);
      const bool two_aimed = c.round_faces.size() == 2 || c.round_faces[1] <= target;
      if (two_aimed) {
        // Above a tenth only where what round 2 would leave does not fit one piece.
        EXPECT_LE(double(c.round_locked_faces[0]), kLastRoundLockedShare * double(target));
      } else {
        ++deferred;
        EXPECT_GT(double(c.round_locked_faces[0]), kLastRoundLockedShareBeforeOnePiece * double(target));
        ASSERT_EQ(c.round_pieces.size(), 3u);
        EXPECT_EQ(c.round_pieces[2], 1u);
        EXPECT_EQ(c.round_locked_faces[1], 0u);
      }
      auto d_now = mesh_distance(input->view(), now.mesh.view()), d_half = mesh_distance(input->view(), half.mesh.view());
      ASSERT_TRUE(d_now.is_ok() && d_half.is_ok());
      std::printf("%s at %.1f: RMS %.5f %%, %.5f %% with a share of a half\n", name, ratio, d_now->rms_pct(),
                  d_half->rms_pct());
      sum_now += d_now->rms_pct(), sum_half += d_half->rms_pct();
    }
  }
  EXPECT_GT(deferred, 4u);
  EXPECT_LT(sum_now, sum_half);
}

TEST(ChunkedFinish, OneThreadAndTwoGiveTheSameMesh) {
  const std::string path = testing::fixture("real/homer.off");
  ChunkedRun one = run_chunked(path, 0.05, 1, 400), two = run_chunked(path, 0.05, 2, 400);
  ASSERT_FALSE(one.mesh.triangles.empty());
  EXPECT_EQ(one.mesh.positions.size(), two.mesh.positions.size());
  EXPECT_TRUE(one.mesh.positions == two.mesh.positions);
  EXPECT_TRUE(one.mesh.triangles == two.mesh.triangles);
}

TEST(ChunkedFinish, StaysNearTheWholeInputsCollapse) {
  // Pieces collapsed apart, with their borders locked and then moved, should cost little
  // against collapsing the whole input at once: within 2× its Hausdorff distance here (the
  // benchmark pages have the measured ratios at 1M–100M faces).
  for (const char* name : {"homer.off", "bunny-lowres.ply", "fandisk.off"}) {
    SCOPED_TRACE(name);
    const std::string path = testing::fixture(std::string("real/") + name);
    auto input = load_mesh(path);
    ASSERT_TRUE(input.is_ok());
    ChunkedRun chunked = run_chunked(path, 0.1, 2, 400);
    ASSERT_FALSE(chunked.mesh.triangles.empty());
    FinishOptions whole_options;
    whole_options.target_faces = chunked.result.finish_options.target_faces;
    auto whole = finish_input(compact_input(input->positions, input->triangles).view(), whole_options);
    ASSERT_TRUE(whole.is_ok());
    auto d_chunked = mesh_distance(input->view(), chunked.mesh.view());
    auto d_whole = mesh_distance(input->view(), whole->mesh.view());
    ASSERT_TRUE(d_chunked.is_ok() && d_whole.is_ok());
    std::printf("%s: chunked %.4f %% against whole %.4f %% (Hausdorff), %.5f %% against %.5f %% (RMS)\n", name,
                d_chunked->hausdorff_pct(), d_whole->hausdorff_pct(), d_chunked->rms_pct(), d_whole->rms_pct());
    EXPECT_LE(d_chunked->hausdorff, 2 * d_whole->hausdorff);
    EXPECT_LE(d_chunked->rms, 2 * d_whole->rms);
  }
}

TEST(ChunkedFinish, AnErrorBoundAloneStopsEveryRound) {
  const std::string path = testing::fixture("real/bunny-lowres.ply");
  testing::ScratchDir tmp;
  OutOfCoreSimplifyOptions options;
  options.threads = 2;
  options.partition.max_chunk_faces = 400;
  options.partition.tmp_dir = tmp.path().string();
  options.memory = MemoryBudget(std::uint64_t{16} << 20);
  options.memory_explicit = true;
  options.always_chunked_finish = true;
  options.auto_frequency = true;
  options.finish.max_error = 0.5;
  options.finish.max_error_relative = true;
  auto ooc = simplify_out_of_core(path, {}, options);
  ASSERT_TRUE(ooc.is_ok()) << ooc.status().to_string();
  ASSERT_TRUE(ooc->parts != nullptr);
  EXPECT_LT(ooc->parts->face_count(), ooc->faces);
  ASSERT_TRUE(ooc->finish.has_value());
  EXPECT_LE(ooc->finish->estimated_error, ooc->finish_options.max_error / kMaxErrorMargin * (1 + 1e-9));
  EXPECT_EQ(ooc->finish->stopped_by, std::string("max_error"));
}

}  // namespace
}  // namespace gaussmesh::stream
