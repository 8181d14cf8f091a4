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

TEST(ChunkSimplify, EveryFixtureWithHundredsOfChunksGivesTheInCoreOutput) {
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
TEST(ChunkSimplify, PaperTestOnEveryFixtureWithHundredsOfChunksGivesTheInCoreOutput) {
  for (std::uint32_t smooth : {0u, 2u})
    for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "mushroom.off",
                             "bunny-lowres.ply"})
      expect_same_as_in_core({name, smooth, 1, 32, 2, SampleTest::kPaper});
}

TEST(ChunkSimplify, PaperTestChunkSizesAndThreads) {
  expect_same_as_in_core({"cow.off", 1, 1, 12, 1, SampleTest::kPaper});  // ~1000 chunks
  expect_same_as_in_core({"homer.off", 0, 1, 1000, 2, SampleTest::kPaper});
  expect_same_as_in_core({"knot1.off", 0, 1, 1u << 20, 2, SampleTest::kPaper});  // one chunk
}

// Several orientations: each runs the passes up to its samples, the fewest win (ties: the
// first), and the chosen one runs again to the end.
TEST(ChunkSimplify, PaperTestWithSeveralOrientations) {
  // Seeds where a later orientation wins: cow 2, 3, 4 (the second), homer 3, 4 (the second).
  expect_same_as_in_core({"cow.off", 0, 3, 48, 2, SampleTest::kPaper, 2});
  expect_same_as_in_core({"homer.off", 0, 2, 32, 2, SampleTest::kPaper, 3});
  expect_same_as_in_core({"cow.off", 2, 2, 32, 1, SampleTest::kPaper, 1});
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
  expect_same_as_in_core({path, 1, 1, 200, 2, SampleTest::kPaper});
}

// Repeats of a face's vertex set (CAD exports have them): the mesher leaves them out of its
// adjacency; every chunk holding a face holds its repeats, so out of core does the same.
TEST(ChunkSimplify, RepeatedFacesGiveTheInCoreOutput) {
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

// Every chunk's run vertices as segments of one new file (as pass C writes them).
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

TEST(ChunkSimplify, LoopChunksFindTheWholeChunksLoopsUnderAnyCoarserPatches) {
  // Pass C reads, where it can, a loop chunk: the faces near the chunk's feature edges
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

TEST(ChunkSimplify, ChunksInsideOneFlatPatchReadNoLoopFaces) {
  // A finely gridded cube: its sides are flat (one label each), so its only feature edges are
  // the cube's 12 edges. Chunks inside a side have no feature edge and no sample: their loop
  // chunks hold no face and pass C reads nothing for them but their pieces' areas (until
  // session 17 a loop chunk held the chunk's whole border). Same output as in core.
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
  // Every chunk a loop chunk; the faces pass C reads are those near the cube's edges: 12 edges of
  // n segments, a few rings of faces on each side of them.
  EXPECT_EQ(run->loop_chunks, run->chunks);
  EXPECT_LT(run->loop_faces, cube.triangles.size() / 4);
  EXPECT_EQ(run->mesh.triangles.size(), 12u);
  std::printf("cube: %zu chunks, %zu of %zu faces read by pass C\n", run->chunks, static_cast<std::size_t>(run->loop_faces),
              cube.triangles.size());
}

TEST(ChunkSimplify, DamagedLoopChunksAreBadInput) {
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

TEST(ChunkSimplify, StitchLoopsJoinsRunsAcrossChunksFromTheirLowestHalfEdge) {
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

TEST(ChunkSimplify, StitchLoopsRefusesRunsThatDoNotCloseOrDisagreeWithTheirFiles) {
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
