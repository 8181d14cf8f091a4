// The out-of-core sampling pipeline (stream/pipeline/out_of_core_sample.h): for any chunking —
// hundreds of chunks on small meshes, with smoothing and several orientations — the out-of-core
// samples are the in-core run's, vertex for vertex, and the per-chunk counts add up to the whole
// mesh's.
#include "stream/pipeline/out_of_core_sample.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "stream/stitch/paper_chains.h"
#include "tests/support/paper_pairs.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

struct Case {
  std::string path;
  std::uint32_t smooth = 0;
  std::size_t orientations = 1;
  std::uint64_t chunk_faces = 24;
  std::uint32_t threads = 2;
  SampleTest test = SampleTest::kExact;
};


void expect_same_as_in_core(const Case& c, const std::string& tmp) {
  SCOPED_TRACE(c.path + " smooth " + std::to_string(c.smooth) + " orientations " + std::to_string(c.orientations) +
               " chunk faces " + std::to_string(c.chunk_faces) + " test " + sample_test_name(c.test));
  auto mesh = load_mesh(c.path);
  ASSERT_TRUE(mesh.is_ok()) << mesh.status().to_string();
  OutOfCoreSamplingOptions options;
  options.spheres.clear();
  for (std::size_t k = 0; k < c.orientations; ++k) {
    GaussSphereOptions g;
    g.frequency = 4;
    g.rotation = gauss_rotation_from_seed(11 + k);
    options.spheres.push_back(g);
  }
  options.sampler.smooth_iterations = c.smooth;
  options.sampler.sample_test = c.test;
  options.threads = c.threads;
  options.partition.max_chunk_faces = c.chunk_faces;
  options.memory = MemoryBudget(std::uint64_t{64} << 20);
  options.partition.tmp_dir = tmp;
  auto ooc = sample_out_of_core(c.path, {}, options);
  ASSERT_TRUE(ooc.is_ok()) << ooc.status().to_string();
  auto in_core = sample_mesh_best_orientation(mesh->view(), options.spheres, options.sampler);
  ASSERT_TRUE(in_core.is_ok());

  EXPECT_EQ(ooc->faces, mesh->triangles.size());
  EXPECT_EQ(ooc->vertices, mesh->positions.size());
  EXPECT_EQ(ooc->samples_per_orientation, in_core->samples_per_orientation);
  EXPECT_EQ(ooc->chosen, in_core->chosen);
  const auto& want = in_core->result.samples;
  ASSERT_EQ(ooc->samples.size(), want.size());
  for (std::size_t k = 0; k < want.size(); ++k) {
    const GlobalSample& s = ooc->samples[k];
    ASSERT_EQ(s.vertex, want[k].vertex) << "sample " << k;
    EXPECT_EQ(s.gauss_vertex, want[k].gauss_vertex) << "vertex " << s.vertex;
    EXPECT_EQ(s.characteristic, want[k].characteristic) << "vertex " << s.vertex;
    EXPECT_EQ(s.position, mesh->positions[s.vertex]) << "vertex " << s.vertex;
  }
  if (c.test == SampleTest::kPaper) {
    std::size_t pairs = 0;
    const std::uint64_t digest = in_core_pairs_digest(*mesh, options.spheres[ooc->chosen], options.sampler, &pairs);
    EXPECT_EQ(ooc->candidate_pairs, pairs);
    EXPECT_EQ(ooc->candidate_pairs_digest, digest);
  }
  // Owned counts add up to the whole mesh's.
  EXPECT_EQ(ooc->stats.owned_faces, mesh->triangles.size());
  EXPECT_EQ(ooc->stats.exact_samples, in_core->result.stats.exact_samples);
  EXPECT_EQ(ooc->stats.candidates_initial, in_core->result.stats.candidates_initial);
  EXPECT_EQ(ooc->stats.degenerate_faces, in_core->result.stats.degenerate_faces);
  EXPECT_EQ(ooc->stats.unlabelled_faces, in_core->result.stats.unlabelled_faces);
  // The chunking asked for happened (a chunk owns about 3/4 of chunk_faces in faces).
  EXPECT_GE(ooc->chunks, mesh->triangles.size() / (2 * c.chunk_faces));
  std::printf("%s: %zu chunks\n", c.path.c_str(), ooc->chunks);
  // The run's temporary directory is gone.
  EXPECT_TRUE(std::filesystem::is_empty(tmp));
}

TEST(OutOfCoreSample, FixturesGiveTheInCoreSamplesWithHundredsOfChunks) {
  testing::ScratchDir tmp;
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off",
                           "mushroom.off", "bunny-lowres.ply"}) {
    expect_same_as_in_core({testing::fixture(std::string("real/") + name)}, tmp.path().string());
  }
}

TEST(OutOfCoreSample, SmoothingAndOrientationsAndChunkSizes) {
  testing::ScratchDir tmp;
  const std::string cow = testing::fixture("real/cow.off");
  expect_same_as_in_core({cow, 2, 3, 48, 2}, tmp.path().string());
  expect_same_as_in_core({cow, 0, 1, 1000, 1}, tmp.path().string());
  expect_same_as_in_core({cow, 1, 2, 1u << 20, 2}, tmp.path().string());  // one chunk
}

TEST(OutOfCoreSample, NoisyShapeWithSmoothing) {
  testing::ScratchDir tmp;
  testing::ShapeOptions shape;
  shape.vertices = 6000;
  shape.noise = 0.01;
  const Mesh sphere = testing::make_sphere(shape);
  const std::string path = tmp.file("noisy.ply");
  {
    auto out = format::OutputFile::create(path, true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_ply(**out, sphere.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  const std::filesystem::path runs = tmp.path() / "runs";
  std::filesystem::create_directory(runs);
  expect_same_as_in_core({path, 3, 2, 100, 2}, runs.string());
  // The paper test too (its samples after the merge, the chains and the noisy filter).
  expect_same_as_in_core({path, 0, 1, 100, 2, SampleTest::kPaper}, runs.string());
  expect_same_as_in_core({path, 3, 1, 60, 1, SampleTest::kPaper}, runs.string());
}

// The paper test runs the stitch up to its samples: the untriangulatable merge, the candidates'
// records after it, candidate chains across chunks and the noisy filter.
TEST(OutOfCoreSample, PaperTestGivesTheInCoreSamplesWithHundredsOfChunks) {
  testing::ScratchDir tmp;
  for (std::uint32_t smooth : {0u, 2u})
    for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off",
                             "mushroom.off", "bunny-lowres.ply"})
      expect_same_as_in_core({testing::fixture(std::string("real/") + name), smooth, 1, 24, 2, SampleTest::kPaper},
                             tmp.path().string());
}

// Several orientations: each runs the stitch up to its samples, the fewest win (ties: the first).
TEST(OutOfCoreSample, PaperTestWithSeveralOrientations) {
  testing::ScratchDir tmp;
  expect_same_as_in_core({testing::fixture("real/cow.off"), 0, 3, 24, 2, SampleTest::kPaper}, tmp.path().string());
  expect_same_as_in_core({testing::fixture("real/homer.off"), 0, 2, 48, 1, SampleTest::kPaper}, tmp.path().string());  // the second wins
  expect_same_as_in_core({testing::fixture("real/fandisk.off"), 2, 2, 48, 1, SampleTest::kPaper}, tmp.path().string());
}

}  // namespace
}  // namespace gaussmesh::stream
