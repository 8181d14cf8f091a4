// simplify out of core (stream/pipeline/out_of_core_simplify.h): for any chunking — hundreds of chunks on the
// fixtures, with smoothing and several orientations — the output is the in-core simplify's,
// vertex for vertex and triangle for triangle; and nothing is left in the temporary directory.
#include "stream/pipeline/out_of_core_simplify.h"

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

struct Case {
  std::string name;  // a fixture under real/, or a path
  std::uint32_t smooth = 0;
  std::size_t orientations = 1;
  std::uint64_t chunk_faces = 32;
  std::uint32_t threads = 2;
  SampleTest test = SampleTest::kExact;
  std::uint64_t seed = 1;  // orientation k is gauss_rotation_from_seed(seed + k)
};


// fetched (optional): adds the patches whose input faces the mesher fetched.
void expect_same_as_in_core(const Case& c, std::size_t* fetched = nullptr) {
  SCOPED_TRACE(c.name + " smooth " + std::to_string(c.smooth) + " orientations " + std::to_string(c.orientations) +
               " chunk faces " + std::to_string(c.chunk_faces) + " test " + sample_test_name(c.test));
  testing::ScratchDir tmp;
  const std::string path = c.name.find('/') == std::string::npos ? testing::fixture("real/" + c.name) : c.name;
  auto mesh = load_mesh(path);
  ASSERT_TRUE(mesh.is_ok());
  OutOfCoreSimplifyOptions options;
  options.spheres.clear();
  for (std::size_t k = 0; k < c.orientations; ++k) {
    GaussSphereOptions g;
    g.frequency = 4;
    g.rotation = gauss_rotation_from_seed(c.seed + k);
    options.spheres.push_back(g);
  }
  options.sampler.smooth_iterations = c.smooth;
  options.sampler.sample_test = c.test;
  options.threads = c.threads;
  options.partition.max_chunk_faces = c.chunk_faces;
  options.memory = MemoryBudget(std::uint64_t{64} << 20);
  options.partition.tmp_dir = tmp.path().string();
  auto ooc = simplify_out_of_core(path, {}, options);
  ASSERT_TRUE(ooc.is_ok()) << ooc.status().to_string();
  SimplifyOptions in_core_options;
  in_core_options.spheres = options.spheres;
  in_core_options.sampler = options.sampler;
  auto in_core = simplify_mesh(mesh->view(), in_core_options);
  ASSERT_TRUE(in_core.is_ok());
  ASSERT_FALSE(in_core->mesher_fallback);
  EXPECT_EQ(ooc->chosen, in_core->orientation_index);
  if (c.orientations > 1) std::printf("orientation %zu of %zu chosen\n", ooc->chosen, c.orientations);
  EXPECT_EQ(ooc->samples_per_orientation, in_core->samples_per_orientation);
  EXPECT_EQ(ooc->patches, in_core->patches);
  EXPECT_EQ(ooc->candidates, in_core->candidates);
  EXPECT_EQ(ooc->samples, in_core->samples);
  if (c.test == SampleTest::kPaper) {
    EXPECT_EQ(ooc->tree_filtered, in_core->sampling.tree_filtered);
    EXPECT_EQ(ooc->unwinding_filtered, in_core->sampling.unwinding_filtered);
    EXPECT_EQ(ooc->noisy_filtered, in_core->sampling.noisy_filtered);
    std::size_t pairs = 0;
    const std::uint64_t digest = in_core_pairs_digest(*mesh, options.spheres[ooc->chosen], options.sampler, &pairs);
    EXPECT_EQ(ooc->candidate_pairs, pairs);
    EXPECT_EQ(ooc->candidate_pairs_digest, digest);
  }
  EXPECT_EQ(ooc->birth, in_core->birth);
  EXPECT_EQ(ooc->mesh.positions, in_core->mesh.positions);
  ASSERT_EQ(ooc->mesh.triangles.size(), in_core->mesh.triangles.size());
  std::size_t different = 0;
  for (std::size_t k = 0; k < in_core->mesh.triangles.size(); ++k) {
    const auto& a = ooc->mesh.triangles[k].v;
    const auto& b = in_core->mesh.triangles[k].v;
    different += !(a[0] == b[0] && a[1] == b[1] && a[2] == b[2]);
  }
  EXPECT_EQ(different, 0u);
  EXPECT_GE(ooc->chunks, mesh->triangles.size() / (2 * c.chunk_faces));
  // Fetched faces are read from the chunks that own the patches' pieces, not from every chunk.
  if (ooc->fetched_patches > 0) {
    EXPECT_GT(ooc->fetched_chunks, 0u);
    EXPECT_LT(ooc->fetched_chunks, ooc->chunks / 4);
  } else {
    EXPECT_EQ(ooc->fetched_chunks, 0u);
  }
  if (fetched) *fetched += ooc->fetched_patches;
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  std::printf("%s: %zu chunks, %zu output faces, %zu half-edges stitched, %zu faces of %zu patches fetched, "
              "from %zu chunks, %zu samples, %zu candidate pairs, %zu chain fragments\n",
              c.name.c_str(), ooc->chunks, ooc->mesh.triangles.size(), ooc->stitch_half_edges, ooc->fetched_faces,
              ooc->fetched_patches, ooc->fetched_chunks, ooc->samples, ooc->candidate_pairs, ooc->chain_fragments);
}

TEST(OutOfCoreSimplify, EveryFixtureWithHundredsOfChunksGivesTheInCoreOutput) {
  std::size_t fetched = 0;
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                           "bunny-lowres.ply"})
    expect_same_as_in_core({name}, &fetched);
  // mech-holes-shark has a patch only its input faces mesh: the fetch pass ran and gave the
  // in-core output.
  EXPECT_GT(fetched, 0u);
}

// The paper test: its noisy filter follows candidate chains across chunks (stream/stitch/paper_chains.h)
// and its candidates are re-evaluated after the merge from their star geometry; hundreds of
// chunks cut most chains.
TEST(OutOfCoreSimplify, PaperTestOnEveryFixtureWithHundredsOfChunksGivesTheInCoreOutput) {
  for (std::uint32_t smooth : {0u, 2u})
    for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                             "bunny-lowres.ply"})
      expect_same_as_in_core({name, smooth, 1, 32, 2, SampleTest::kPaper});
}

TEST(OutOfCoreSimplify, PaperTestChunkSizesAndThreads) {
  expect_same_as_in_core({"cow.off", 1, 1, 12, 1, SampleTest::kPaper});  // ~1000 chunks
  expect_same_as_in_core({"homer.off", 0, 1, 1000, 2, SampleTest::kPaper});
  expect_same_as_in_core({"knot1.off", 0, 1, 1u << 20, 2, SampleTest::kPaper});  // one chunk
}

// Several orientations: each runs the passes up to its samples, the fewest win (ties: the
// first), and the chosen one runs again to the end.
TEST(OutOfCoreSimplify, PaperTestWithSeveralOrientations) {
  // Seeds where a later orientation wins: cow 2, 3, 4 (the second), homer 3, 4 (the second).
  expect_same_as_in_core({"cow.off", 0, 3, 48, 2, SampleTest::kPaper, 2});
  expect_same_as_in_core({"homer.off", 0, 2, 32, 2, SampleTest::kPaper, 3});
  expect_same_as_in_core({"cow.off", 2, 2, 32, 1, SampleTest::kPaper, 1});
}

TEST(OutOfCoreSimplify, SmoothingOrientationsAndChunkSizes) {
  expect_same_as_in_core({"cow.off", 1, 3, 48, 2});
  expect_same_as_in_core({"fandisk.off", 0, 1, 1000, 1});
  expect_same_as_in_core({"homer.off", 0, 2, 1u << 20, 2});  // one chunk
}

// A noisy generated torus with collapsed faces (repeated indices, some joining far-apart
// vertices) and vertices no face uses, through PLY, with smoothing and two orientations. Noise
// and the defects make some patches need their input faces (the mesher's collapse step): the
// stitch fetches them from the chunks and the output is still the in-core one.
TEST(OutOfCoreSimplify, NoisyTorusWithDefectsFetchesPatchFaces) {
  testing::ScratchDir dir;
  testing::ShapeOptions shape;
  shape.vertices = 12000;
  shape.noise = 0.002;
  Mesh torus = testing::make_torus(1.0, 0.35, shape);
  const auto nv = static_cast<std::uint32_t>(torus.positions.size());
  for (std::uint32_t i = 0; i < 40; ++i) torus.triangles.push_back({{(i * 7919) % nv, (i * 7919) % nv, (i * 104729) % nv}});
  for (int i = 0; i < 20; ++i) torus.positions.push_back({float(i) * 0.01f, 2.5f, 0.0f});
  const std::string path = dir.file("torus.ply");
  {
    auto out = format::OutputFile::create(path, true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_ply(**out, torus.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  expect_same_as_in_core({path, 1, 2, 200, 2});
  expect_same_as_in_core({path, 1, 1, 200, 2, SampleTest::kPaper});
}

// Repeats of a face's vertex set (CAD exports have them): the mesher leaves them out of its
// adjacency; every chunk holding a face holds its repeats, so out of core does the same.
TEST(OutOfCoreSimplify, RepeatedFacesGiveTheInCoreOutput) {
  testing::ScratchDir dir;
  testing::ShapeOptions shape;
  shape.vertices = 6000;
  Mesh torus = testing::make_torus(1.0, 0.4, shape);
  const std::size_t nf = torus.triangles.size();
  for (std::size_t i = 0; i < 60; ++i) {
    const auto t = torus.triangles[(i * 7919) % nf];
    if (i % 3 == 0) torus.triangles.push_back(t);                            // the same face
    if (i % 3 == 1) torus.triangles.push_back({{t.v[1], t.v[2], t.v[0]}});  // rotated
    if (i % 3 == 2) torus.triangles.push_back({{t.v[0], t.v[2], t.v[1]}});  // flipped
  }
  const std::string path = dir.file("torus.ply");
  {
    auto out = format::OutputFile::create(path, true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_ply(**out, torus.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  expect_same_as_in_core({path, 0, 1, 120, 2});
  expect_same_as_in_core({path, 0, 1, 120, 2, SampleTest::kPaper});
}

TEST(OutOfCoreSimplify, ChunksInsideOneFlatPatchReadNoLoopFaces) {
  // A finely gridded cube: its sides are flat (one label each), so its only feature edges are
  // the cube's 12 edges. Chunks inside a side have no feature edge and no sample: their loop
  // chunks hold no face and the loops pass reads nothing for them but their pieces' areas. Same
  // output as in core.
  constexpr int n = 48;
  Mesh cube;
  std::map<std::array<int, 3>, std::uint32_t> id;
  auto vertex = [&](std::array<int, 3> p) {
    auto [it, added] = id.emplace(p, static_cast<std::uint32_t>(cube.positions.size()));
    if (added) cube.positions.push_back({p[0] / float(n), p[1] / float(n), p[2] / float(n)});
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto at = [&](int a, int b) {
            std::array<int, 3> p{};
            p[axis] = side * n;
            p[(axis + 1) % 3] = a;
            p[(axis + 2) % 3] = b;
            return vertex(p);
          };
          const std::uint32_t q[4] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
          // Outward: counter-clockwise seen from outside on the far side, the other way on the near one.
          if (side == 1) {
            cube.triangles.push_back({{q[0], q[1], q[2]}});
            cube.triangles.push_back({{q[0], q[2], q[3]}});
          } else {
            cube.triangles.push_back({{q[0], q[2], q[1]}});
            cube.triangles.push_back({{q[0], q[3], q[2]}});
          }
        }
  testing::ScratchDir tmp;
  const std::string path = tmp.file("cube.ply");
  {
    auto out = format::OutputFile::create(path, true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE(format::write_ply(**out, cube.view(), {}).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  for (const SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) {
    Case c{path};
    c.chunk_faces = 400;
    c.test = test;
    expect_same_as_in_core(c);
  }
  OutOfCoreSimplifyOptions options;
  options.spheres.assign(1, {});
  options.spheres[0].frequency = 4;
  options.partition.max_chunk_faces = 400;
  options.partition.tmp_dir = (tmp.path() / "run").string();
  std::filesystem::create_directory(options.partition.tmp_dir);
  auto run = simplify_out_of_core(path, {}, options);
  ASSERT_TRUE(run.is_ok()) << run.status().to_string();
  // Every chunk a loop chunk; the faces the loops pass reads are those near the cube's edges: 12 edges of
  // n segments, a few rings of faces on each side of them.
  EXPECT_EQ(run->loop_chunks, run->chunks);
  EXPECT_LT(run->loop_faces, cube.triangles.size() / 4);
  EXPECT_EQ(run->mesh.triangles.size(), 12u);
  std::printf("cube: %zu chunks, %zu of %zu faces read by the loops pass\n", run->chunks, static_cast<std::size_t>(run->loop_faces),
              cube.triangles.size());
}

}  // namespace
}  // namespace gaussmesh::stream
