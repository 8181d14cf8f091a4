// simplify out of core (stream/chunk_simplify.h): for any chunking — hundreds of chunks on the
// fixtures, with smoothing and several orientations — the output is the in-core simplify's,
// vertex for vertex and triangle for triangle; and nothing is left in the temporary directory.
#include "stream/chunk_simplify.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/simplify.h"
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
};

void expect_same_as_in_core(const Case& c) {
  SCOPED_TRACE(c.name + " smooth " + std::to_string(c.smooth) + " orientations " + std::to_string(c.orientations) +
               " chunk faces " + std::to_string(c.chunk_faces));
  testing::ScratchDir tmp;
  const std::string path = c.name.find('/') == std::string::npos ? testing::fixture("real/" + c.name) : c.name;
  auto mesh = load_mesh(path);
  ASSERT_TRUE(mesh.is_ok());
  OutOfCoreSimplifyOptions options;
  options.spheres.clear();
  for (std::size_t k = 0; k < c.orientations; ++k) {
    GaussSphereOptions g;
    g.frequency = 4;
    g.rotation = gauss_rotation_from_seed(1 + k);
    options.spheres.push_back(g);
  }
  options.sampler.smooth_iterations = c.smooth;
  options.threads = c.threads;
  options.partition.max_chunk_faces = c.chunk_faces;
  options.partition.memory_bytes = std::uint64_t{64} << 20;
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
  EXPECT_EQ(ooc->samples_per_orientation, in_core->samples_per_orientation);
  EXPECT_EQ(ooc->patches, in_core->patches);
  EXPECT_EQ(ooc->candidates, in_core->candidates);
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
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  std::printf("%s: %zu chunks, %zu output faces, %zu half-edges stitched, %zu faces of %zu patches fetched\n",
              c.name.c_str(), ooc->chunks, ooc->mesh.triangles.size(), ooc->stitch_half_edges, ooc->fetched_faces,
              ooc->fetched_patches);
}

TEST(ChunkSimplify, EveryFixtureWithHundredsOfChunksGivesTheInCoreOutput) {
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                           "bunny-lowres.ply"})
    expect_same_as_in_core({name});
}

TEST(ChunkSimplify, SmoothingOrientationsAndChunkSizes) {
  expect_same_as_in_core({"cow.off", 1, 3, 48, 2});
  expect_same_as_in_core({"fandisk.off", 0, 1, 1000, 1});
  expect_same_as_in_core({"homer.off", 0, 2, 1u << 20, 2});  // one chunk
}

// A noisy generated torus with collapsed faces (repeated indices, some joining far-apart
// vertices) and vertices no face uses, through PLY, with smoothing and two orientations. Noise
// and the defects make some patches need their input faces (the mesher's collapse step): the
// stitch fetches them from the chunks and the output is still the in-core one.
TEST(ChunkSimplify, NoisyTorusWithDefectsFetchesPatchFaces) {
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
}

}  // namespace
}  // namespace gaussmesh::stream
