// Tests of the ingest and partition passes (stream/partition/chunk_partition.h): every chunk holds exactly the faces within
// k vertex rings of the vertices it owns (against an in-memory BFS), ownership is a partition,
// ids and positions round-trip bit-exactly, badly ordered input gives the same chunks, high
// valence overflows no set, and temporary files disappear on success, bad input and full disks.
#include "stream/partition/chunk_partition.h"

#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "tests/support/records.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

namespace fs = std::filesystem;
using format::Code;

void write_mesh(const std::string& path, const Mesh& mesh) {
  auto out = format::OutputFile::create(path, true);
  ASSERT_TRUE(out.is_ok()) << out.status().to_string();
  ASSERT_TRUE(format::write_ply(**out, mesh.view(), {}).is_ok());
  ASSERT_TRUE((*out)->commit().is_ok());
}

bool is_empty_dir(const std::string& dir) { return fs::is_empty(dir); }

// The chunks as the reference sees them: ownership from the files, each chunk's face set.
struct Loaded {
  std::vector<std::uint32_t> owner;              // per vertex; kNone for unreferenced
  std::vector<std::vector<std::uint64_t>> faces;  // per chunk, global face ids
};
constexpr std::uint32_t kNone = 0xFFFFFFFFu;

// Loads every chunk and checks what a chunk must hold on its own: ids and positions against the
// mesh, one owner per vertex and per face, the face owner rule, the counts.
Loaded load_and_check(const Partition& partition, const Mesh& mesh, const std::string& tag) {
  Loaded loaded;
  loaded.owner.assign(mesh.positions.size(), kNone);
  std::vector<std::uint32_t> face_owner(mesh.triangles.size(), kNone);
  std::uint64_t owned_vertices = 0;
  for (const ChunkInfo& info : partition.chunks) {
    owned_vertices += info.owned_vertices;
    auto chunk = load_chunk(info);
    EXPECT_TRUE(chunk.is_ok()) << tag << ": " << chunk.status().to_string();
    if (!chunk) {
      loaded.faces.emplace_back();
      continue;
    }
    const ChunkMesh& c = *chunk;
    EXPECT_EQ(c.chunk, info.id);
    EXPECT_TRUE(std::adjacent_find(c.global_vertex.begin(), c.global_vertex.end(), std::greater_equal<>()) ==
                c.global_vertex.end())
        << tag << ": chunk " << info.id << " numbers its vertices out of global order";
    for (std::size_t l = 0; l < c.global_vertex.size(); ++l) {
      const std::uint32_t g = c.global_vertex[l];
      EXPECT_EQ(std::memcmp(&c.positions[l], &mesh.positions[g], sizeof(format::Vec3f)), 0) << tag << " vertex " << g;
      EXPECT_EQ(partition.owner_of(c.positions[l]) == info.id, c.owned_vertex[l] != 0)
          << tag << ": owner_of disagrees with chunk " << info.id << " on vertex " << g;
      if (c.owned_vertex[l]) {
        EXPECT_EQ(loaded.owner[g], kNone) << tag << ": vertex " << g << " owned twice";
        loaded.owner[g] = info.id;
      }
    }
    for (std::size_t l = 0; l < c.triangles.size(); ++l) {
      const format::Triangle& t = mesh.triangles[c.global_face[l]];
      for (int j = 0; j < 3; ++j) EXPECT_EQ(c.global_vertex[c.triangles[l].v[j]], t.v[j]) << tag << " face " << c.global_face[l];
      if (c.owned_face[l]) {
        EXPECT_EQ(face_owner[c.global_face[l]], kNone) << tag << ": face " << c.global_face[l] << " owned twice";
        face_owner[c.global_face[l]] = info.id;
      }
    }
    loaded.faces.push_back(c.global_face);
  }
  EXPECT_EQ(owned_vertices, mesh.positions.size()) << tag;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const format::Triangle& t = mesh.triangles[f];
    const std::uint32_t lowest = std::min({t.v[0], t.v[1], t.v[2]});
    EXPECT_NE(loaded.owner[lowest], kNone) << tag << ": vertex " << lowest << " of face " << f << " has no owner";
    EXPECT_EQ(face_owner[f], loaded.owner[lowest]) << tag << ": face " << f << " not owned by its lowest vertex's chunk";
  }
  return loaded;
}

// F_k(C) by BFS over the whole mesh: V_0 = owned, F_{i+1} = faces with a corner in V_i (by
// index: degenerate faces included), V_{i+1} = their corners.
std::vector<std::vector<std::uint64_t>> reference_chunks(const Mesh& mesh, const std::vector<std::uint32_t>& owner,
                                                         std::size_t chunks, std::uint32_t rings) {
  const std::size_t nv = mesh.positions.size();
  std::vector<std::uint32_t> offsets(nv + 1, 0), incident;
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t.v) ++offsets[v + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  incident.resize(offsets.back());
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (std::uint32_t v : mesh.triangles[f].v) incident[fill[v]++] = f;
  std::vector<std::vector<std::uint32_t>> owned(chunks);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (owner[v] != kNone) owned[owner[v]].push_back(v);
  std::vector<std::uint32_t> vertex_mark(nv, kNone), face_mark(mesh.triangles.size(), kNone);
  std::vector<std::vector<std::uint64_t>> result(chunks);
  for (std::uint32_t c = 0; c < chunks; ++c) {
    std::vector<std::uint32_t> frontier = owned[c], next;
    for (std::uint32_t v : frontier) vertex_mark[v] = c;
    for (std::uint32_t r = 0; r < rings; ++r) {
      next.clear();
      for (std::uint32_t v : frontier)
        for (std::uint32_t s = offsets[v]; s < offsets[v + 1]; ++s) {
          const std::uint32_t f = incident[s];
          if (face_mark[f] == c) continue;
          face_mark[f] = c;
          result[c].push_back(f);
          for (std::uint32_t w : mesh.triangles[f].v)
            if (vertex_mark[w] != c) {
              vertex_mark[w] = c;
              next.push_back(w);
            }
        }
      frontier.swap(next);
    }
    std::sort(result[c].begin(), result[c].end());
  }
  return result;
}

// Partitions mesh (written as PLY) and checks every chunk against the reference.
// threads > 1 compresses on a second thread (the chunk size is max_chunk_faces either way).
// `write` writes the input file (write_mesh: binary PLY of x, y, z alone). `check` sees the
// partition before its chunks are checked.
void check_exact(const Mesh& mesh, const std::string& name, std::uint64_t max_chunk_faces, std::uint32_t rings,
                 std::size_t min_chunks, std::uint32_t max_open_chunks = 0, std::uint32_t threads = 1,
                 std::uint64_t* untagged_frames = nullptr,
                 const std::function<void(const std::string&, const Mesh&)>& write = write_mesh,
                 const std::function<void(const Partition&)>& check = nullptr) {
  const std::string tag = name + " rings " + std::to_string(rings) + " threads " + std::to_string(threads);
  testing::ScratchDir dir;
  const std::string input = dir.file("in.ply");
  write(input, mesh);
  PartitionOptions options;
  options.rings = rings;
  options.max_chunk_faces = max_chunk_faces;
  options.max_open_chunks = max_open_chunks;
  options.threads = threads;
  options.memory_bytes = 32ull << 20;
  options.tmp_dir = dir.path().string();
  auto partition = partition_mesh(input, {}, options);
  ASSERT_TRUE(partition.is_ok()) << tag << ": " << partition.status().to_string();
  EXPECT_EQ(partition->vertices, mesh.positions.size()) << tag;
  EXPECT_EQ(partition->faces, mesh.triangles.size()) << tag;
  EXPECT_GE(partition->chunks.size(), min_chunks) << tag;
  if (untagged_frames) *untagged_frames = partition->untagged_frames;
  if (check) check(*partition);
  const Loaded loaded = load_and_check(*partition, mesh, tag);
  const auto expected = reference_chunks(mesh, loaded.owner, partition->chunks.size(), rings);
  for (std::size_t c = 0; c < expected.size(); ++c) {
    EXPECT_EQ(loaded.faces[c], expected[c]) << tag << ": chunk " << c << " holds " << loaded.faces[c].size()
                                            << " faces, F_k(C) has " << expected[c].size();
    EXPECT_EQ(partition->chunks[c].faces, expected[c].size()) << tag << " chunk " << c;
  }
}

Mesh sphere_mesh() {
  testing::ShapeOptions o;
  o.vertices = 10000;  // ~20k faces
  o.seed = 3;
  return testing::make_sphere(o);
}

Mesh torus_mesh() {
  testing::ShapeOptions o;
  o.vertices = 10000;
  o.seed = 5;
  o.noise = 0.001;
  return testing::make_torus(1, 0.4, o);
}

// A torus with degenerate faces (repeated index) and vertices no face uses.
Mesh torus_with_defects() {
  Mesh mesh = torus_mesh();
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh.positions.size());
  std::mt19937 rng(11);
  for (int i = 0; i < 50; ++i) {
    const std::uint32_t a = rng() % nv, b = rng() % nv;
    mesh.triangles.push_back({{a, a, b}});
  }
  mesh.triangles.push_back({{7, 7, 7}});
  for (int i = 0; i < 30; ++i) mesh.positions.push_back({float(i) * 0.01f, 0.5f, -0.2f});
  return mesh;
}

TEST(ChunkPartition, ChunksHoldExactlyTheirRingsOnShapes) {
  const Mesh sphere = sphere_mesh();
  const Mesh torus = torus_with_defects();
  ASSERT_GT(sphere.triangles.size(), 15000u);
  for (std::uint32_t rings : {1u, 3u, 5u}) {
    check_exact(sphere, "sphere", 100, rings, 100, 0, rings == 3 ? 2 : 1);
    check_exact(torus, "torus with defects", 100, rings, 100, 0, rings == 5 ? 2 : 1);
  }
}

TEST(ChunkPartition, ChunksHoldExactlyTheirRingsOnTheCow) {
  auto cow = load_mesh(testing::fixture("real/cow.off"));
  ASSERT_TRUE(cow.is_ok()) << cow.status().to_string();
  for (std::uint32_t rings : {1u, 3u, 5u}) check_exact(*cow, "cow", 30, rings, 100);
}

// owner_of (the cell map kept after the partition pass) names the chunk whose file flags a vertex as owned,
// for every vertex of every chunk, on real meshes cut into hundreds of chunks and with 1 chunk.
TEST(ChunkPartition, OwnerOfAgreesWithTheChunkFiles) {
  for (const char* name : {"cow.off", "fandisk.off", "homer.off", "knot1.off", "mech-holes-shark.off", "bunny-lowres.ply"}) {
    for (std::uint64_t chunk_faces : {std::uint64_t{32}, std::uint64_t{1} << 30}) {
      SCOPED_TRACE(std::string(name) + " chunk faces " + std::to_string(chunk_faces));
      testing::ScratchDir dir;
      PartitionOptions options;
      options.rings = 3;
      options.max_chunk_faces = chunk_faces;
      options.memory_bytes = 32ull << 20;
      options.tmp_dir = dir.path().string();
      auto partition = partition_mesh(testing::fixture(std::string("real/") + name), {}, options);
      ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
      if (chunk_faces == 32) {
        EXPECT_GE(partition->chunks.size(), 100u);
      }
      std::size_t vertices = 0, wrong = 0;
      for (const ChunkInfo& info : partition->chunks) {
        auto chunk = load_chunk(info);
        ASSERT_TRUE(chunk.is_ok()) << chunk.status().to_string();
        for (std::size_t l = 0; l < chunk->positions.size(); ++l) {
          const std::uint32_t owner = partition->owner_of(chunk->positions[l]);
          ++vertices;
          if (chunk->owned_vertex[l] ? owner != info.id : owner == info.id) ++wrong;
          EXPECT_LT(owner, partition->chunks.size());
        }
      }
      EXPECT_GT(vertices, 0u);
      EXPECT_EQ(wrong, 0u);
      // Positions outside the bounds and NaN clamp to a chunk, as in the partition pass.
      const float nan = std::nanf("");
      for (const format::Vec3f& p : {format::Vec3f{nan, nan, nan}, format::Vec3f{-1e30f, 1e30f, 0.f}})
        EXPECT_LT(partition->owner_of(p), partition->chunks.size());
    }
  }
  // No chunks at all: 0.
  EXPECT_EQ(Partition().owner_of({0, 0, 0}), 0u);
}

TEST(ChunkPartition, SeveralWriterRoundsGiveTheSameChunks) {
  // At most 7 chunk files open at once: the final scan runs once per 7 chunks.
  check_exact(sphere_mesh(), "sphere, 7 writers", 100, 3, 100, 7);
  check_exact(sphere_mesh(), "sphere, 7 writers", 100, 3, 100, 7, 2);
}

TEST(ChunkPartition, ChunkSizeFollowsTheBudget) {
  const Mesh torus = torus_mesh();
  testing::ScratchDir dir;
  write_mesh(dir.file("in.ply"), torus);
  PartitionOptions options;
  options.tmp_dir = dir.path().string();
  options.memory_bytes = 16ull << 20;
  options.threads = 64;  // 16 MiB / 64 / 200 B = 1310 faces per chunk
  auto partition = partition_mesh(dir.file("in.ply"), {}, options);
  ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
  const double expected = 0.75 * 1310 * double(torus.positions.size()) / double(torus.triangles.size());
  std::uint64_t largest = 0;
  for (const ChunkInfo& info : partition->chunks) largest = std::max(largest, info.owned_vertices);
  EXPECT_NEAR(double(torus.positions.size()) / double(partition->chunks.size()), expected, expected * 0.25);
  // Cells fill chunks greedily: no chunk owns more than the planner's share (no cell here
  // holds more than a quarter of it).
  EXPECT_LE(double(largest), std::ceil(expected)) << "largest chunk owns " << largest << " vertices";
  options.threads = 1;  // one chunk: the whole torus fits
  auto whole = partition_mesh(dir.file("in.ply"), {}, options);
  ASSERT_TRUE(whole.is_ok());
  ASSERT_EQ(whole->chunks.size(), 1u);
  EXPECT_EQ(whole->chunks[0].faces, torus.triangles.size());
  EXPECT_EQ(whole->chunks[0].owned_faces, torus.triangles.size());
}

// mesh with vertex v numbered to_new[v] and its faces in face_order.
Mesh renumbered(const Mesh& mesh, const std::vector<std::uint32_t>& to_new, const std::vector<std::uint32_t>& face_order) {
  Mesh m;
  m.positions.resize(mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) m.positions[to_new[v]] = mesh.positions[v];
  for (std::uint32_t f : face_order) {
    const auto& t = mesh.triangles[f];
    m.triangles.push_back({{to_new[t.v[0]], to_new[t.v[1]], to_new[t.v[2]]}});
  }
  return m;
}

TEST(ChunkPartition, ShuffledIdsGiveTheSameChunks) {
  const Mesh mesh = torus_mesh();
  const std::uint32_t seed = 20260501;
  std::mt19937 rng(seed);
  std::vector<std::uint32_t> to_new(mesh.positions.size()), face_order(mesh.triangles.size());
  std::iota(to_new.begin(), to_new.end(), 0u);
  std::iota(face_order.begin(), face_order.end(), 0u);
  std::shuffle(to_new.begin(), to_new.end(), rng);
  std::shuffle(face_order.begin(), face_order.end(), rng);
  const Mesh shuffled = renumbered(mesh, to_new, face_order);
  auto run = [&](const Mesh& m, const std::string& name) {
    testing::ScratchDir dir;
    write_mesh(dir.file("in.ply"), m);
    PartitionOptions options;
    options.rings = 3;
    options.max_chunk_faces = 150;
    options.memory_bytes = 16ull << 20;
    options.tmp_dir = dir.path().string();
    auto partition = partition_mesh(dir.file("in.ply"), {}, options);
    EXPECT_TRUE(partition.is_ok()) << partition.status().to_string();
    Loaded loaded = load_and_check(*partition, m, name);
    const auto expected = reference_chunks(m, loaded.owner, partition->chunks.size(), 3);
    for (std::size_t c = 0; c < expected.size(); ++c) EXPECT_EQ(loaded.faces[c], expected[c]) << name << " chunk " << c;
    return loaded;
  };
  const Loaded ordered = run(mesh, "ordered");
  const Loaded bad = run(shuffled, "shuffled, seed " + std::to_string(seed));
  ASSERT_EQ(ordered.faces.size(), bad.faces.size());
  EXPECT_GE(ordered.faces.size(), 50u);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    EXPECT_EQ(ordered.owner[v], bad.owner[to_new[v]]) << "vertex " << v << ", seed " << seed;
  }
  for (std::size_t c = 0; c < ordered.faces.size(); ++c) {
    std::vector<std::uint64_t> mapped;
    for (std::uint64_t f : bad.faces[c]) mapped.push_back(face_order[f]);
    std::sort(mapped.begin(), mapped.end());
    EXPECT_EQ(mapped, ordered.faces[c]) << "chunk " << c << ", seed " << seed;
  }
}

TEST(ChunkPartition, TheBlockCacheGrowsForShuffledInputOnly) {
  // The block cache starts at 1/8 of its budget (16 MiB: 0.94 of 7.5 MiB) and doubles when
  // recently evicted blocks come back. A 600 x 600 height field numbered row by row is scanned
  // with blocks reused soon after they are loaded: the cache keeps its size. The same mesh with
  // ids and faces shuffled touches its vertex arrays at random: the cache grows until they fit.
  // Both give the same number of chunks.
  constexpr std::uint32_t kSide = 600;
  Mesh grid;
  for (std::uint32_t i = 0; i < kSide; ++i)
    for (std::uint32_t j = 0; j < kSide; ++j)
      grid.positions.push_back({float(i) / kSide, float(j) / kSide, 0.05f * std::sin(0.05f * float(i * j))});
  for (std::uint32_t i = 0; i + 1 < kSide; ++i) {
    for (std::uint32_t j = 0; j + 1 < kSide; ++j) {
      const std::uint32_t v = i * kSide + j;
      grid.triangles.push_back({{v, v + kSide, v + 1}});
      grid.triangles.push_back({{v + 1, v + kSide, v + kSide + 1}});
    }
  }
  std::vector<std::uint32_t> to_new(grid.positions.size()), faces(grid.triangles.size());
  std::iota(to_new.begin(), to_new.end(), 0u);
  std::iota(faces.begin(), faces.end(), 0u);
  const Mesh& ordered = grid;
  std::mt19937 rng(20261202);
  std::shuffle(to_new.begin(), to_new.end(), rng);
  std::shuffle(faces.begin(), faces.end(), rng);
  const Mesh shuffled = renumbered(grid, to_new, faces);
  auto run = [&](const Mesh& m) {
    testing::ScratchDir dir;
    write_mesh(dir.file("in.ply"), m);
    PartitionOptions options;
    options.memory_bytes = 16ull << 20;
    options.tmp_dir = dir.path().string();
    auto partition = partition_mesh(dir.file("in.ply"), {}, options);
    EXPECT_TRUE(partition.is_ok()) << partition.status().to_string();
    return partition.is_ok() ? std::pair(partition->cache_bytes, partition->chunks.size()) : std::pair(std::uint64_t{0}, std::size_t{0});
  };
  const auto [ordered_bytes, ordered_chunks] = run(ordered);
  const auto [shuffled_bytes, shuffled_chunks] = run(shuffled);
  std::printf("cache: %.2f MiB row by row, %.2f MiB shuffled (%zu chunks)\n", ordered_bytes / 1048576.0,
              shuffled_bytes / 1048576.0, ordered_chunks);
  EXPECT_EQ(ordered_chunks, shuffled_chunks);
  EXPECT_GT(ordered_bytes, 0u);
  EXPECT_LE(ordered_bytes, std::uint64_t{1} << 20);  // its starting size
  EXPECT_GE(shuffled_bytes, 4 * ordered_bytes);  // two doublings at least (3.75 MiB holds its arrays)
}

TEST(ChunkPartition, ScatteredIdsTakeTheSortAndGiveExactChunks) {
  // load_chunk numbers a chunk's vertices through a two-level bitmap (the blocks of 2^13 ids that
  // hold one) when those blocks take at most 48 bytes a face, else by sorting. Two halves of the
  // ids 300,000 apart, with unused vertices between them, put chunks on the seam over two far
  // blocks: still the bitmap. The ids shuffled over the same range leave about one id a block:
  // the sort. Both must give exact chunks.
  testing::ShapeOptions o;
  o.vertices = 1500;
  o.seed = 9;
  const Mesh compact = testing::make_sphere(o);
  const std::size_t n = compact.positions.size();
  constexpr std::uint32_t kGap = 300000;
  std::vector<std::uint32_t> halves(n), shuffled(n);
  for (std::uint32_t v = 0; v < n; ++v) halves[v] = v < n / 2 ? v : v + kGap;
  std::vector<std::uint32_t> slots(n + kGap);
  std::iota(slots.begin(), slots.end(), 0u);
  std::mt19937 random(17);
  std::shuffle(slots.begin(), slots.end(), random);
  std::copy_n(slots.begin(), n, shuffled.begin());
  // The ring rounds' tags read owners through a 512 KiB window here (32 MiB budget): the halves
  // stay tagged, the shuffled ids (owners.bin 1.2 MB, read at random) switch the tags off, and
  // the cache alone must give the same exact chunks.
  for (const auto& [ids, what] : {std::pair{halves, "sphere, two far halves"}, std::pair{shuffled, "sphere, ids shuffled"}}) {
    Mesh spread;
    spread.positions.resize(n + kGap);
    for (std::size_t k = 0; k < spread.positions.size(); ++k) spread.positions[k] = compact.positions[k % n];
    for (std::uint32_t v = 0; v < n; ++v) spread.positions[ids[v]] = compact.positions[v];
    for (const format::Triangle& t : compact.triangles) spread.triangles.push_back({{ids[t.v[0]], ids[t.v[1]], ids[t.v[2]]}});
    for (std::uint32_t threads : {1u, 2u}) {
      std::uint64_t untagged = 0;
      check_exact(spread, what, 100, 3, 10, 0, threads, &untagged);
      if (ids == halves) EXPECT_EQ(untagged, 0u) << what << " threads " << threads;
      else EXPECT_GE(untagged, 1u) << what << " threads " << threads;
    }
  }
}

TEST(ChunkPartition, LocalDisorderLeavesTheOtherFramesTagged) {
  // The ring rounds' tags go off for a face frame whose windows miss (about once per 256 faces)
  // and for a few frames after it, not for the rest of the scan. A torus of ~440k faces is five
  // face-spill frames (87,381 faces of 12 bytes each); 5,000 faces from all over it, moved into
  // the middle of the second frame, reference ids across the whole of owners.bin (880 KB,
  // read through a 512 KiB window at a 32 MiB budget). Round 1 and the final scan each leave
  // that frame partly untagged and pass over the third; the fourth and fifth are tagged again
  // (a switch that stayed off would leave four frames in each). Round 2 reads only the frontier
  // bitmap (27 KB) and misses nowhere. The chunks stay exact either way.
  testing::ShapeOptions o;
  o.vertices = 215000;
  o.seed = 4;
  const Mesh torus = testing::make_torus(1.0, 0.4, o);
  ASSERT_GT(torus.triangles.size(), 4 * 87381u);
  ASSERT_LT(torus.triangles.size(), 5 * 87381u);
  Mesh moved = torus;
  moved.triangles.clear();
  std::vector<std::uint8_t> taken(torus.triangles.size(), 0);
  std::mt19937 random(5);
  std::vector<format::Triangle> far;
  std::uniform_int_distribution<std::size_t> pick(0, torus.triangles.size() - 1);
  while (far.size() < 5000) {
    const std::size_t f = pick(random);
    if (f < 100000 || taken[f]) continue;
    taken[f] = 1;
    far.push_back(torus.triangles[f]);
  }
  for (std::size_t f = 0; f < torus.triangles.size(); ++f) {
    if (f == 100000) moved.triangles.insert(moved.triangles.end(), far.begin(), far.end());
    if (!taken[f]) moved.triangles.push_back(torus.triangles[f]);
  }
  std::uint64_t untagged = 0;
  check_exact(moved, "torus, a stretch of faces from all over", 20000, 3, 10, 0, 2, &untagged);
  EXPECT_GE(untagged, 2u);
  EXPECT_LE(untagged, 4u);
}

// A binary little-endian PLY whose vertex records carry more than x, y, z, in another order:
// uchar quality, float x, float nx, double weight, float y, float z (29 bytes; x at 1, y at 17,
// z at 21).
void write_wide_ply(const std::string& path, const Mesh& mesh) {
  std::string out = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(mesh.positions.size()) +
                    "\nproperty uchar quality\nproperty float x\nproperty float nx\nproperty double weight\n"
                    "property float y\nproperty float z\nelement face " + std::to_string(mesh.triangles.size()) +
                    "\nproperty list uchar int vertex_indices\nend_header\n";
  auto put = [&](const void* p, std::size_t n) { out.append(static_cast<const char*>(p), n); };
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const std::uint8_t quality = static_cast<std::uint8_t>(v);
    const float nx = 0.5f;
    const double weight = static_cast<double>(v) / 3;
    put(&quality, 1);
    put(&mesh.positions[v].x, 4);
    put(&nx, 4);
    put(&weight, 8);
    put(&mesh.positions[v].y, 4);
    put(&mesh.positions[v].z, 4);
  }
  for (const format::Triangle& t : mesh.triangles) {
    const std::uint8_t three = 3;
    put(&three, 1);
    put(t.v, 12);
  }
  testing::write_file(path, out);
}

void write_ascii_ply(const std::string& path, const Mesh& mesh) {
  auto out = format::OutputFile::create(path, true);
  ASSERT_TRUE(out.is_ok()) << out.status().to_string();
  format::PlyWriteOptions options;
  options.binary = false;
  ASSERT_TRUE(format::write_ply(**out, mesh.view(), options).is_ok());
  ASSERT_TRUE((*out)->commit().is_ok());
}

TEST(ChunkPartition, PositionsComeFromTheInputWhenItHoldsThem) {
  // A binary little-endian PLY names where each vertex's x, y, z lie: the partition reads them
  // back from the input and writes no position files (they stay empty); an ascii PLY has no such
  // records, and its positions are spilled. Both give exact chunks with the mesh's positions
  // (load_and_check compares every loaded position with the mesh's, bit for bit).
  const Mesh mesh = torus_mesh();
  auto from_input = [](bool expected) {
    return [expected](const Partition& partition) {
      ASSERT_FALSE(partition.chunks.empty());
      const VertexFiles& files = *partition.chunks[0].vertex_files;
      EXPECT_EQ(files.input.has_value(), expected);
      std::uintmax_t spilled = 0;
      for (const std::string& path : files.positions) spilled += fs::file_size(path);
      if (expected) EXPECT_EQ(spilled, 0u);
      else EXPECT_EQ(spilled, 12 * partition.vertices);
    };
  };
  check_exact(mesh, "torus, x y z records", 2000, 3, 5, 0, 2, nullptr, write_mesh, from_input(true));
  check_exact(mesh, "torus, 29-byte records", 2000, 3, 5, 0, 2, nullptr, write_wide_ply, from_input(true));
  check_exact(mesh, "torus, ascii", 2000, 3, 5, 0, 2, nullptr, write_ascii_ply, from_input(false));
}

// A sphere of 10k vertices with a second sphere of `vertices` beside it, scaled by `scale`
// about (0.3, 0.2, 0.1) (inside the first: cells there hold nothing else).
Mesh sphere_with_ball(std::uint32_t seed, std::uint32_t vertices, float scale) {
  testing::ShapeOptions o;
  o.vertices = 10000;
  o.seed = seed;
  Mesh mesh = testing::make_sphere(o);
  o.vertices = vertices;
  o.seed = seed + 1;
  const Mesh ball = testing::make_sphere(o);
  const std::uint32_t base = static_cast<std::uint32_t>(mesh.positions.size());
  for (const format::Vec3f& p : ball.positions) mesh.positions.push_back({0.3f + scale * p.x, 0.2f + scale * p.y, 0.1f + scale * p.z});
  for (const format::Triangle& t : ball.triangles) mesh.triangles.push_back({{t.v[0] + base, t.v[1] + base, t.v[2] + base}});
  return mesh;
}

// The partition of `mesh` into chunks of `chunk_faces`, checked to succeed.
Partition partition_of(const testing::ScratchDir& dir, const Mesh& mesh, std::uint64_t chunk_faces) {
  write_mesh(dir.file("in.ply"), mesh);
  PartitionOptions options;
  options.max_chunk_faces = chunk_faces;
  options.tmp_dir = dir.path().string();
  auto partition = partition_mesh(dir.file("in.ply"), {}, options);
  EXPECT_TRUE(partition.is_ok()) << partition.status().to_string();
  return partition.is_ok() ? std::move(*partition) : Partition{};
}

// The planner's share: 3/4 of a chunk's faces, in vertices.
double planner_share(const Mesh& mesh, std::uint64_t chunk_faces) {
  return 0.75 * double(chunk_faces) * double(mesh.positions.size()) / double(mesh.triangles.size());
}

std::uint64_t largest_owned(const Partition& partition) {
  std::uint64_t largest = 0;
  for (const ChunkInfo& info : partition.chunks) largest = std::max(largest, info.owned_vertices);
  return largest;
}

TEST(ChunkPartition, DenseCellsAreSplitAndChunksStayBounded) {
  // A sphere with a small, dense one beside it: 20k vertices in a ball of diameter 0.02, inside
  // one or a few of the grid's cells (about 0.03 across here), each cell holding many chunks'
  // worth. Split cells keep every chunk near its share, and the chunks stay exact.
  const Mesh mesh = sphere_with_ball(3, 20000, 0.01f);
  constexpr std::uint64_t kChunkFaces = 2000;
  check_exact(mesh, "sphere with a dense ball", kChunkFaces, 3, 10);
  testing::ScratchDir dir;
  const Partition partition = partition_of(dir, mesh, kChunkFaces);
  EXPECT_FALSE(partition.owner_map.splits.empty());
  const double share = planner_share(mesh, kChunkFaces);
  EXPECT_LE(double(largest_owned(partition)), std::ceil(share)) << "share " << share;
}

TEST(ChunkPartition, AClusteredCellIsSplitFinerUntilItsChunksAreBounded) {
  // A cell with between a quarter and a half of a chunk's vertices gets 8 sub-cells (k = 1);
  // here they all sit in a ball 2e-5 across, so one sub-cell holds them all and k is raised to
  // 3, then to 5 (the cap), the second time past the level the first count held (the plan counts
  // two levels finer than k and reads k's counts as sums; a raise beyond that scans again).
  const Mesh mesh = sphere_with_ball(5, 300, 1e-5f);
  constexpr std::uint64_t kChunkFaces = 2000;
  const double share = planner_share(mesh, kChunkFaces);
  ASSERT_GT(300, share / 4);
  ASSERT_LE(300, share / 2);
  check_exact(mesh, "sphere with a cluster", kChunkFaces, 3, 10);
  testing::ScratchDir dir;
  const Partition partition = partition_of(dir, mesh, kChunkFaces);
  ASSERT_EQ(partition.owner_map.splits.size(), 1u);
  EXPECT_EQ(partition.owner_map.splits[0].k, 5u);
  EXPECT_LE(double(largest_owned(partition)), std::ceil(share)) << "share " << share;
}

TEST(ChunkPartition, HighValenceVertexKeepsEveryChunk) {
  // A fan of 2000 triangles around one centre vertex, ringed by a strip: the centre touches
  // every chunk on the rim, so its chunk set and its neighbours' go far past the inline slots.
  Mesh mesh;
  const std::uint32_t n = 2000;
  mesh.positions.push_back({0, 0, 0});
  for (std::uint32_t ring = 1; ring <= 2; ++ring)
    for (std::uint32_t i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      mesh.positions.push_back({float(ring * std::cos(a)), float(ring * std::sin(a)), 0});
    }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    mesh.triangles.push_back({{0, 1 + i, 1 + j}});
    mesh.triangles.push_back({{1 + i, 1 + n + i, 1 + n + j}});
    mesh.triangles.push_back({{1 + i, 1 + n + j, 1 + j}});
  }
  for (std::uint32_t rings : {1u, 2u, 3u}) check_exact(mesh, "fan", 60, rings, 100);
  // The centre is in every chunk that owns a rim vertex next to it.
  testing::ScratchDir dir;
  write_mesh(dir.file("fan.ply"), mesh);
  PartitionOptions options;
  options.rings = 2;
  options.max_chunk_faces = 60;
  options.tmp_dir = dir.path().string();
  auto partition = partition_mesh(dir.file("fan.ply"), {}, options);
  ASSERT_TRUE(partition.is_ok());
  std::size_t holding_centre = 0;
  for (const ChunkInfo& info : partition->chunks) {
    auto chunk = load_chunk(info);
    ASSERT_TRUE(chunk.is_ok());
    holding_centre += !chunk->global_vertex.empty() && chunk->global_vertex[0] == 0;
  }
  EXPECT_GT(holding_centre, 50u);
}

TEST(ChunkPartition, PointCloudsAndEmptyInputs) {
  testing::ScratchDir dir;
  Mesh points = sphere_mesh();
  points.triangles.clear();
  write_mesh(dir.file("points.ply"), points);
  write_mesh(dir.file("empty.ply"), Mesh{});
  PartitionOptions options;
  options.max_chunk_faces = 100;
  options.tmp_dir = dir.path().string();
  auto cloud = partition_mesh(dir.file("points.ply"), {}, options);
  ASSERT_TRUE(cloud.is_ok()) << cloud.status().to_string();
  EXPECT_GT(cloud->chunks.size(), 10u);
  std::uint64_t owned = 0;
  for (const ChunkInfo& info : cloud->chunks) {
    owned += info.owned_vertices;
    EXPECT_GT(info.owned_vertices, 0u);
    EXPECT_EQ(info.faces, 0u);
    auto chunk = load_chunk(info);
    ASSERT_TRUE(chunk.is_ok()) << chunk.status().to_string();
    EXPECT_TRUE(chunk->positions.empty());
  }
  EXPECT_EQ(owned, points.positions.size());
  auto empty = partition_mesh(dir.file("empty.ply"), {}, options);
  ASSERT_TRUE(empty.is_ok()) << empty.status().to_string();
  EXPECT_EQ(empty->vertices, 0u);
  EXPECT_TRUE(empty->chunks.empty());
}

TEST(ChunkPartition, TempDirGoesWithThePartition) {
  testing::ScratchDir dir;
  write_mesh(dir.file("in.ply"), sphere_mesh());
  fs::create_directory(dir.file("tmp"));
  PartitionOptions options;
  options.max_chunk_faces = 2000;
  options.tmp_dir = dir.file("tmp");
  std::string run_dir;
  {
    auto partition = partition_mesh(dir.file("in.ply"), {}, options);
    ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
    run_dir = partition->dir;
    EXPECT_EQ(fs::path(run_dir).parent_path(), fs::path(dir.file("tmp")));
    // Only the chunk files and the vertex files are left once the pass is done.
    std::size_t files = 0;
    for (const auto& entry : fs::directory_iterator(run_dir)) {
      const std::string name = entry.path().filename().string();
      if (name == "positions-0.bin" || name == "positions-1.bin" || name == "owners.bin") continue;
      EXPECT_EQ(entry.path().extension(), ".gmr") << entry.path();
      ++files;
    }
    EXPECT_EQ(files, partition->chunks.size());
    ASSERT_FALSE(partition->chunks.empty());
    ASSERT_TRUE(partition->chunks[0].vertex_files);
    for (const std::string& path : partition->chunks[0].vertex_files->positions) EXPECT_TRUE(fs::exists(path));
    EXPECT_TRUE(fs::exists(partition->chunks[0].vertex_files->owners));
    Partition moved = std::move(*partition);
    EXPECT_TRUE(partition->dir.empty());
    EXPECT_TRUE(fs::exists(run_dir));  // the moved-from partition removed nothing
  }
  EXPECT_FALSE(fs::exists(run_dir));
  EXPECT_TRUE(is_empty_dir(dir.file("tmp")));
}

TEST(ChunkPartition, BadInputLeavesNothingBehind) {
  testing::ScratchDir dir;
  write_mesh(dir.file("in.ply"), sphere_mesh());
  const std::string bytes = testing::read_file(dir.file("in.ply"));
  testing::write_file(dir.file("cut.ply"), bytes.substr(0, bytes.size() - 1000));
  testing::write_file(dir.file("junk.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nend_header\n");
  fs::create_directory(dir.file("tmp"));
  PartitionOptions options;
  options.tmp_dir = dir.file("tmp");
  for (const char* name : {"cut.ply", "junk.ply", "missing.ply"}) {
    auto partition = partition_mesh(dir.file(name), {}, options);
    ASSERT_FALSE(partition.is_ok()) << name;
    EXPECT_EQ(partition.status().code(), Code::kBadInput) << partition.status().to_string();
    const std::string message = partition.status().to_string();
    EXPECT_NE(message.find(name), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_TRUE(is_empty_dir(dir.file("tmp"))) << name;
  }
  EXPECT_NE(partition_mesh(dir.file("cut.ply"), {}, options).status().to_string().find("byte"), std::string::npos);
}

TEST(ChunkPartition, OptionsOutOfRangeAreRefused) {
  testing::ScratchDir dir;
  write_mesh(dir.file("in.ply"), sphere_mesh());
  PartitionOptions options;
  options.tmp_dir = dir.path().string();
  options.rings = 0;
  EXPECT_EQ(partition_mesh(dir.file("in.ply"), {}, options).status().code(), Code::kUsage);
  options.rings = kMaxPartitionRings + 1;
  EXPECT_EQ(partition_mesh(dir.file("in.ply"), {}, options).status().code(), Code::kUsage);
  options.rings = 3;
  options.memory_bytes = 1 << 20;
  EXPECT_EQ(partition_mesh(dir.file("in.ply"), {}, options).status().code(), Code::kUsage);
  options.memory_bytes = 64ull << 20;
  options.tmp_dir = dir.file("no/such/dir");
  EXPECT_EQ(partition_mesh(dir.file("in.ply"), {}, options).status().code(), Code::kOutput);
}

// Runs a partition whose temporary files cannot all be written; expects one kOutput line and
// nothing left in tmp.
void expect_write_failure(const std::string& input, const std::string& tmp, const std::string& what,
                          std::uint32_t threads = 1) {
  PartitionOptions options;
  options.threads = threads;
  options.tmp_dir = tmp;
  options.max_chunk_faces = 500;
  options.compression_level = -5;
  auto partition = partition_mesh(input, {}, options);
  ASSERT_FALSE(partition.is_ok()) << what;
  EXPECT_EQ(partition.status().code(), Code::kOutput) << what << ": " << partition.status().to_string();
  EXPECT_EQ(partition.status().to_string().find('\n'), std::string::npos);
  EXPECT_NE(partition.status().to_string().find(tmp), std::string::npos) << partition.status().to_string();
  EXPECT_TRUE(is_empty_dir(tmp)) << what;
}

TEST(ChunkPartition, FullDiskIsAnOutputErrorAndLeavesNothing) {
  testing::ScratchDir dir;
  testing::ShapeOptions o;
  o.vertices = 40000;  // 80k faces: 1.4 MB of spills, ~5 MB of chunk records
  const Mesh mesh = testing::make_sphere(o);
  write_mesh(dir.file("in.ply"), mesh);
  // Every file limited to 256 KiB (RLIMIT_FSIZE: write fails with EFBIG): the spill breaks.
  {
    fs::create_directory(dir.file("tmp"));
    struct rlimit old {};
    ::getrlimit(RLIMIT_FSIZE, &old);
    struct rlimit low = old;
    low.rlim_cur = 256 << 10;
    auto* previous = ::signal(SIGXFSZ, SIG_IGN);
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &low), 0);
    expect_write_failure(dir.file("in.ply"), dir.file("tmp"), "file size limit");
    // With two threads the ingest's spills are written on a thread of their own: the run
    // still fails as kOutput with one line and leaves nothing.
    expect_write_failure(dir.file("in.ply"), dir.file("tmp"), "file size limit, spill thread", 2);
    ::setrlimit(RLIMIT_FSIZE, &old);
    ::signal(SIGXFSZ, previous);
  }
  // A real full file system (tmpfs of 3 MB: the spills fit, the chunk files do not).
  if (::geteuid() != 0) GTEST_SKIP() << "not root: cannot mount a small tmpfs for the ENOSPC case";
  const std::string mount_point = dir.file("small");
  fs::create_directory(mount_point);
  if (::mount("tmpfs", mount_point.c_str(), "tmpfs", 0, "size=3m") != 0) {
    GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno) << "): ENOSPC case skipped";
  }
  expect_write_failure(dir.file("in.ply"), mount_point, "3 MB tmpfs");
  expect_write_failure(dir.file("in.ply"), mount_point, "3 MB tmpfs, compression thread", 2);
  ::umount(mount_point.c_str());
}

TEST(ChunkPartition, DamagedChunkFilesAreBadInput) {
  testing::ScratchDir dir;
  write_mesh(dir.file("in.ply"), torus_mesh());
  PartitionOptions options;
  options.max_chunk_faces = 2000;
  options.tmp_dir = dir.path().string();
  auto partition = partition_mesh(dir.file("in.ply"), {}, options);
  ASSERT_TRUE(partition.is_ok());
  ASSERT_GE(partition->chunks.size(), 2u);
  const ChunkInfo info = partition->chunks[1];
  const std::string bytes = testing::read_file(info.path);
  auto expect_bad = [&](const ChunkInfo& damaged, const std::string& what) {
    auto chunk = load_chunk(damaged);
    ASSERT_FALSE(chunk.is_ok()) << what;
    EXPECT_EQ(chunk.status().code(), Code::kBadInput) << what;
    EXPECT_NE(chunk.status().to_string().find(damaged.path), std::string::npos) << chunk.status().to_string();
  };
  // Flipped byte, truncation, wrong counts.
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x20;
  testing::write_file(info.path, flipped);
  expect_bad(info, "flipped byte");
  testing::write_file(info.path, bytes.substr(0, bytes.size() - 10));
  expect_bad(info, "truncated");
  testing::write_file(info.path, bytes);
  ASSERT_TRUE(load_chunk(info).is_ok());
  ChunkInfo wrong = info;
  wrong.faces += 1;
  expect_bad(wrong, "record count");
  wrong = info;
  wrong.owned_faces += 1;
  expect_bad(wrong, "owned faces");
  // Well-formed files whose records contradict each other.
  auto read = testing::read_all_records(info.path, kChunkFaceRecordKind, kChunkFaceRecordBytes);
  ASSERT_TRUE(read.is_ok()) << read.status().to_string();
  const std::vector<std::byte> records = std::move(*read);
  auto rewrite = [&](const std::function<void(std::vector<std::byte>&)>& damage, const std::string& what) {
    std::vector<std::byte> copy = records;
    damage(copy);
    ASSERT_TRUE(testing::write_all_records(info.path, kChunkFaceRecordKind, kChunkFaceRecordBytes, copy).is_ok());
    expect_bad(info, what);
  };
  const std::size_t last = records.size() - kChunkFaceRecordBytes;
  constexpr std::size_t kFlags = 20;  // byte of the flags in a record
  rewrite([&](auto& r) { r[last + kFlags] |= std::byte{0x40}; }, "reserved flag");
  rewrite([&](auto& r) { r[last + kFlags] ^= std::byte{kOwnsFace}; }, "face owner");
  rewrite([&](auto& r) {
    // A corner that is not the face's lowest names a vertex past the end of the vertex file.
    std::uint32_t v[3];
    std::memcpy(v, r.data() + last + 8, 12);
    const int highest = static_cast<int>(std::max_element(v, v + 3) - v);
    v[highest] = 0xFFFFFFF0u;
    std::memcpy(r.data() + last + 8, v, 12);
  }, "vertex id beyond the vertex file");
  rewrite([&](auto& r) { std::memcpy(r.data() + last, r.data(), 8); }, "face order");
  rewrite([&](auto& r) {
    // One occurrence of a vertex claims ownership the others deny.
    for (std::size_t at = 0; at < r.size(); at += kChunkFaceRecordBytes) {
      if ((std::to_integer<unsigned>(r[at + kFlags]) & 7) != 7) {
        r[at + kFlags] ^= std::byte{7};
        break;
      }
    }
  }, "ownership");

  // The vertex files: positions missing or truncated; owners missing, or naming another owner
  // for a vertex the chunk file says is owned.
  testing::write_file(info.path, bytes);  // the undamaged chunk file
  ASSERT_TRUE(info.vertex_files);
  const std::string& owners_path = info.vertex_files->owners;
  const std::string owner_bytes = testing::read_file(owners_path);
  auto expect_bad_vertices = [&](const std::string& what) {
    auto chunk = load_chunk(info);
    ASSERT_FALSE(chunk.is_ok()) << what;
    EXPECT_EQ(chunk.status().code(), Code::kBadInput) << what;
    EXPECT_EQ(chunk.status().to_string().find('\n'), std::string::npos) << chunk.status().to_string();
  };
  auto loaded = load_chunk(info);
  ASSERT_TRUE(loaded.is_ok()) << loaded.status().to_string();
  // The positions come from the input (a binary PLY): missing, cut, or rewritten since the
  // ingest (the same bytes, a later modification time).
  ASSERT_TRUE(info.vertex_files->input);
  const std::string input = dir.file("in.ply");
  const std::string input_bytes = testing::read_file(input);
  const auto ingested = fs::last_write_time(input);
  fs::remove(input);
  expect_bad_vertices("missing input");
  testing::write_file(input, input_bytes.substr(0, input_bytes.size() - 5));
  expect_bad_vertices("truncated input");
  testing::write_file(input, input_bytes);
  fs::last_write_time(input, fs::last_write_time(input) + std::chrono::seconds(5));
  expect_bad_vertices("input rewritten");
  {
    // The same chunk of an ascii copy, whose positions are spilled: the position file of the
    // chunk's highest vertex missing, or cut inside that vertex.
    testing::ScratchDir ascii_dir;
    write_ascii_ply(ascii_dir.file("in.ply"), torus_mesh());
    PartitionOptions ascii_options = options;
    ascii_options.tmp_dir = ascii_dir.path().string();
    auto spilled = partition_mesh(ascii_dir.file("in.ply"), {}, ascii_options);
    ASSERT_TRUE(spilled.is_ok()) << spilled.status().to_string();
    const ChunkInfo& spilled_info = spilled->chunks[1];
    ASSERT_FALSE(spilled_info.vertex_files->input);
    auto spilled_chunk = load_chunk(spilled_info);
    ASSERT_TRUE(spilled_chunk.is_ok()) << spilled_chunk.status().to_string();
    const std::uint32_t highest = spilled_chunk->global_vertex.back();
    const std::string& positions_path = spilled_info.vertex_files->positions[position_file(highest)];
    const std::string position_bytes = testing::read_file(positions_path);
    auto expect_bad_spill = [&](const std::string& what) {
      auto chunk = load_chunk(spilled_info);
      ASSERT_FALSE(chunk.is_ok()) << what;
      EXPECT_EQ(chunk.status().code(), Code::kBadInput) << what;
    };
    fs::remove(positions_path);
    expect_bad_spill("missing positions file");
    testing::write_file(positions_path, position_bytes.substr(0, position_record(highest) * kPositionRecordBytes + 5));
    expect_bad_spill("truncated positions file");
  }
  // The input as the ingest saw it again: its bytes and its modification time.
  testing::write_file(input, input_bytes);
  fs::last_write_time(input, ingested);
  ASSERT_TRUE(load_chunk(info).is_ok());
  fs::remove(owners_path);
  expect_bad_vertices("missing owners file");
  const auto owned = std::find(loaded->owned_vertex.begin(), loaded->owned_vertex.end(), 1);
  ASSERT_NE(owned, loaded->owned_vertex.end());
  const std::uint32_t id = loaded->global_vertex[static_cast<std::size_t>(owned - loaded->owned_vertex.begin())];
  std::string other_owner = owner_bytes;
  const std::uint32_t elsewhere = info.id + 1;
  std::memcpy(other_owner.data() + std::size_t{id} * kOwnerRecordBytes, &elsewhere, 4);
  testing::write_file(owners_path, other_owner);
  expect_bad_vertices("owners file names another owner");
  testing::write_file(owners_path, owner_bytes);
  EXPECT_TRUE(load_chunk(info).is_ok());
}

}  // namespace
}  // namespace gaussmesh::stream
