// The spatial renumbering of scattered input (stream/partition/spatial_order.h): the probe tells
// shuffled ids from ordered ones; the in-core renumbering keeps the surface and its orientation
// and sorts as the rules say; a welded soup is the mesh it came from; and the partition's
// out-of-core renumbering and welding, over one range or many, reach exactly the in-core
// result (chunk files hold the renumbered ids).
#include "stream/partition/spatial_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "stream/core/mesh.h"
#include "stream/partition/cell_grid.h"
#include "stream/partition/chunk_partition.h"
#include "tests/support/scattered_copy.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

// A wavy sheet with more vertices than the probe's window, and beside it a fan of kFan faces
// whose apex lies alone in the lowest cell: after renumbering the apex is vertex 0 and the
// lowest corner of every fan face, more faces than order_face_group orders (they keep input
// order) and than a small table's run holds.
constexpr std::uint32_t kFan = kMaxFaceGroup + 4000;
Mesh sheet_and_fan() {
  Mesh mesh = testing::make_wavy_sheet(540);
  const auto apex = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.push_back({-1, -1, -1});
  for (std::uint32_t i = 0; i <= kFan; ++i) {
    const double a = 0.5 * M_PI * i / kFan;
    mesh.positions.push_back({float(-1 + 0.8 * std::cos(a)), float(-1 + 0.8 * std::sin(a)), -1});
  }
  for (std::uint32_t i = 0; i < kFan; ++i) mesh.triangles.push_back({{apex, apex + 1 + i, apex + 2 + i}});
  return mesh;
}

// The faces in a fixed order, to compare meshes whose faces tie on their lowest corner.
std::vector<std::array<std::uint32_t, 3>> sorted_faces(const Mesh& mesh) {
  std::vector<std::array<std::uint32_t, 3>> faces;
  for (const Triangle& t : mesh.triangles) faces.push_back({t.v[0], t.v[1], t.v[2]});
  std::sort(faces.begin(), faces.end());
  return faces;
}

bool scattered(const Mesh& mesh) {
  OrderProbe probe;
  probe.add(mesh.triangles);
  return probe.scattered(mesh.positions.size());
}

// Every face as its corners' coordinates, rotated to start at the least corner: the surface
// with its orientation, whatever the numbering.
using Corners = std::array<std::array<float, 3>, 3>;
std::vector<Corners> surface(const Mesh& mesh) {
  std::vector<Corners> faces;
  for (const Triangle& t : mesh.triangles) {
    Corners c;
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = mesh.positions[t.v[k]];
      c[k] = {p.x, p.y, p.z};
    }
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    faces.push_back(c);
  }
  std::sort(faces.begin(), faces.end());
  return faces;
}

void write_ply_file(const std::string& path, const Mesh& mesh) { ASSERT_TRUE(testing::write_binary_ply(path, mesh)); }

// partition_mesh of `path` renumbered (reorder_scattered) over a table of `table` bytes (0: the
// budget's), with rings 1, chunks of 100k faces and `threads` threads.
format::Result<Partition> renumbered_partition(const testing::ScratchDir& dir, const std::string& path,
                                               std::uint64_t table, Weld weld = Weld::kAuto, std::uint32_t threads = 2) {
  PartitionOptions options;
  options.rings = 1;
  options.memory_bytes = std::uint64_t{64} << 20;
  options.max_chunk_faces = 100000;
  options.threads = threads;
  options.reorder_scattered = true;
  options.weld = weld;
  options.reorder_table_bytes = table;
  options.tmp_dir = dir.path().string();
  return partition_mesh(path, {}, options);
}

// Every chunk file holds `expected`'s ids and positions (the in-core renumbering), and the
// chunks own every face once.
void expect_chunks_hold(const Partition& partition, const Mesh& expected) {
  std::uint64_t owned = 0;
  for (const ChunkInfo& info : partition.chunks) {
    auto chunk = load_chunk(info);
    ASSERT_TRUE(chunk.is_ok()) << chunk.status().to_string();
    for (std::size_t v = 0; v < chunk->positions.size(); ++v) {
      const Vec3f& want = expected.positions[chunk->global_vertex[v]];
      ASSERT_EQ(std::memcmp(&chunk->positions[v], &want, sizeof(Vec3f)), 0) << "vertex " << chunk->global_vertex[v];
    }
    for (std::size_t f = 0; f < chunk->triangles.size(); ++f) {
      if (!chunk->owned_face[f]) continue;
      ++owned;
      const Triangle& want = expected.triangles[chunk->global_face[f]];
      for (int k = 0; k < 3; ++k) ASSERT_EQ(chunk->global_vertex[chunk->triangles[f].v[k]], want.v[k]) << "face " << chunk->global_face[f];
    }
  }
  EXPECT_EQ(owned, expected.triangles.size());
}

TEST(SpatialOrder, TheProbeTellsShuffledIdsFromOrderedOnes) {
  const Mesh mesh = sheet_and_fan();
  ASSERT_GT(mesh.positions.size(), std::size_t{OrderProbe::kSlots} << OrderProbe::kBlockBits);
  EXPECT_FALSE(scattered(mesh));
  EXPECT_TRUE(scattered(testing::scattered_mesh(mesh, 7)));
  // Within the window, any order is cheap: a small shuffled mesh is not scattered.
  EXPECT_FALSE(scattered(testing::scattered_mesh(testing::make_wavy_sheet(200), 7)));
}

TEST(SpatialOrder, FineCodesInterleaveTheSubCellsBitsTopLevelFirst) {
  // The fine code, bit by bit: at each level from the top, x's bit, then y's, then z's.
  const detail::Grid grid = detail::Grid::make({0, 0, 0}, {1, 2, 4});
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int i = 0; i < 20000; ++i) {
    const Vec3f p{unit(rng), 2 * unit(rng), 4 * unit(rng)};
    const float c[3] = {p.x, p.y, p.z};
    for (const std::uint32_t k : {1u, 7u, kReorderFineBits}) {
      std::uint32_t local[3], want = 0;
      for (int a = 0; a < 3; ++a) {
        const double t = (static_cast<double>(c[a]) - grid.lo[a]) * grid.scale[a];
        const auto fine = std::min<std::uint64_t>(static_cast<std::uint64_t>(t * double(1u << k)), (std::uint64_t{grid.n[a]} << k) - 1);
        local[a] = static_cast<std::uint32_t>(fine - (std::uint64_t{grid.axis(a, c[a])} << k));
      }
      for (std::uint32_t level = k; level-- > 0;)
        for (int a = 0; a < 3; ++a) want = want << 1 | ((local[a] >> level) & 1u);
      ASSERT_EQ(grid.sub_code(p, k), want) << i << " k " << k;
    }
  }
}

TEST(SpatialOrder, SortingRunsByRadixGivesTheComparisonSortsOrder) {
  // sort_run with room for the radix copy against sort_run without it (std::sort on the same
  // 8-byte keys), on runs with many equal fine codes, equal positions and codes clustered in one
  // corner of the cell (digits that are the same for every key), at sizes around the cut-over.
  std::mt19937 rng(43);
  for (const std::size_t n : {2u, 63u, 64u, 65u, 1000u, 5000u}) {
    for (const std::uint32_t spread : {1u, 64u, 1u << 12, 1u << 30}) {
      std::uniform_int_distribution<std::uint32_t> code(0, spread - 1), coordinate(0, 3);
      std::vector<OrderedVertex> run(n);
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3f p{float(coordinate(rng)), float(coordinate(rng)), float(coordinate(rng))};
        run[i] = {VertexKey::of(code(rng), p, static_cast<std::uint32_t>(rng())), p};
      }
      std::vector<OrderedVertex> by_radix = run, by_compare = run;
      std::vector<std::uint64_t> two(2 * n), one(n);
      sort_run(by_radix, two);
      sort_run(by_compare, one);
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(by_radix[i].key.fine, by_compare[i].key.fine) << n << " " << spread << " " << i;
        ASSERT_EQ(by_radix[i].key.id, by_compare[i].key.id) << n << " " << spread << " " << i;
        if (i > 0) {
          ASSERT_FALSE(by_radix[i].key < by_radix[i - 1].key) << n << " " << spread << " " << i;
        }
      }
    }
  }
}

TEST(SpatialOrder, RenumberingKeepsTheSurfaceAndSortsByCellThenLowestCorner) {
  const Mesh input = testing::scattered_mesh(sheet_and_fan(), 11);
  Mesh mesh = input;
  EXPECT_EQ(reorder_spatially(mesh.positions, mesh.triangles, true), 0u);  // no two vertices share a position
  ASSERT_EQ(mesh.positions.size(), input.positions.size());
  ASSERT_EQ(mesh.triangles.size(), input.triangles.size());
  EXPECT_TRUE(surface(mesh) == surface(input));
  Vec3f lo = mesh.positions[0], hi = mesh.positions[0];
  for (const Vec3f& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const detail::Grid grid = detail::Grid::make(lo, hi);
  for (std::size_t v = 1; v < mesh.positions.size(); ++v)
    ASSERT_LE(grid.morton(grid.cell(mesh.positions[v - 1])), grid.morton(grid.cell(mesh.positions[v]))) << v;
  for (std::size_t f = 1; f < mesh.triangles.size(); ++f)
    ASSERT_LE(lowest_corner(mesh.triangles[f - 1]), lowest_corner(mesh.triangles[f])) << f;
  EXPECT_EQ(mesh.positions[0].x, -1.0f);  // the fan's apex, alone in the lowest cell
  EXPECT_FALSE(scattered(mesh));
  // Ties keep the input's order: renumbering the same mesh again changes nothing.
  Mesh again = mesh;
  reorder_spatially(again.positions, again.triangles, false);
  EXPECT_EQ(std::memcmp(again.triangles.data(), mesh.triangles.data(), mesh.triangles.size() * sizeof(Triangle)), 0);
}

TEST(SpatialOrder, AnyFaceOrderGivesTheSameRenumberedMesh) {
  const Mesh mesh = testing::make_wavy_sheet(540);
  std::vector<Triangle> first_order, second_order;
  for (const std::uint32_t seed : {31u, 37u}) {
    std::vector<Triangle> faces = mesh.triangles;
    std::mt19937 rng(seed);
    std::shuffle(faces.begin(), faces.end(), rng);
    std::vector<Vec3f> positions = mesh.positions;
    reorder_spatially(positions, faces, false);
    (seed == 31u ? first_order : second_order) = faces;
  }
  ASSERT_EQ(first_order.size(), second_order.size());
  EXPECT_EQ(std::memcmp(first_order.data(), second_order.data(), first_order.size() * sizeof(Triangle)), 0);
  for (std::size_t f = 1; f < first_order.size(); ++f) {
    if (lowest_corner(first_order[f - 1]) == lowest_corner(first_order[f])) {
      ASSERT_LE(face_tail(first_order[f - 1]), face_tail(first_order[f])) << f;
    }
  }
}

TEST(SpatialOrder, AWeldedSoupIsTheMeshItCameFrom) {
  // (The sheet alone: the fan's apex would have more copies in the soup than are welded.)
  const Mesh mesh = testing::scattered_mesh(testing::make_wavy_sheet(540), 17);
  Mesh soup = testing::soup_mesh(mesh, 19);
  EXPECT_TRUE(should_weld(Weld::kAuto, soup.positions.size(), soup.triangles.size()));
  EXPECT_FALSE(should_weld(Weld::kAuto, mesh.positions.size(), mesh.triangles.size()));
  EXPECT_FALSE(should_weld(Weld::kOff, soup.positions.size(), soup.triangles.size()));
  const std::uint64_t welded = reorder_spatially(soup.positions, soup.triangles, true);
  EXPECT_EQ(welded, 3 * mesh.triangles.size() - mesh.positions.size());
  Mesh expected = mesh;
  reorder_spatially(expected.positions, expected.triangles, false);
  ASSERT_EQ(soup.positions.size(), expected.positions.size());
  EXPECT_EQ(std::memcmp(soup.positions.data(), expected.positions.data(), soup.positions.size() * sizeof(Vec3f)), 0);
  EXPECT_TRUE(sorted_faces(soup) == sorted_faces(expected));
  // Unwelded, it stays a soup of the same surface.
  Mesh unwelded = testing::soup_mesh(mesh, 19);
  EXPECT_EQ(reorder_spatially(unwelded.positions, unwelded.triangles, false), 0u);
  EXPECT_EQ(unwelded.positions.size(), 3 * mesh.triangles.size());
  EXPECT_TRUE(surface(unwelded) == surface(mesh));
}

TEST(SpatialOrder, OutOfCoreRenumberingIsTheInCoreOneOverOneRangeOrMany) {
  const Mesh input = testing::scattered_mesh(sheet_and_fan(), 13);
  Mesh expected = input;
  reorder_spatially(expected.positions, expected.triangles, false);
  testing::ScratchDir dir;
  write_ply_file(dir.file("in.ply"), input);
  // 0: the budget's table (one range of the map); 64 KiB: dozens of ranges, and the fan's apex
  // is the lowest corner of more faces than a run holds (streamed). Over many ranges the faces
  // are put together in one part per thread: one, two, or three uneven ones.
  for (const std::uint64_t table : {std::uint64_t{0}, std::uint64_t{64} << 10}) {
    for (const std::uint32_t threads : {1u, 2u, 3u}) {
      SCOPED_TRACE("table " + std::to_string(table) + ", threads " + std::to_string(threads));
      auto partition = renumbered_partition(dir, dir.file("in.ply"), table, Weld::kAuto, threads);
      ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
      EXPECT_TRUE(partition->reordered);
      expect_chunks_hold(*partition, expected);
    }
  }
  // A soup, welded out of core to exactly the in-core result.
  const Mesh soup = testing::soup_mesh(sheet_and_fan(), 23);
  Mesh welded = soup;
  const std::uint64_t joined = reorder_spatially(welded.positions, welded.triangles, true);
  write_ply_file(dir.file("soup.ply"), soup);
  for (const std::uint64_t table : {std::uint64_t{0}, std::uint64_t{64} << 10}) {
    SCOPED_TRACE("soup, table " + std::to_string(table));
    auto partition = renumbered_partition(dir, dir.file("soup.ply"), table);
    ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
    EXPECT_TRUE(partition->reordered);
    EXPECT_EQ(partition->welded_vertices, joined);
    EXPECT_EQ(partition->vertices, welded.positions.size());
    expect_chunks_hold(*partition, welded);
  }
  // Without the option (sample, whose output names input ids), the ids stay the input's.
  PartitionOptions options;
  options.rings = 1;
  options.tmp_dir = dir.path().string();
  auto partition = partition_mesh(dir.file("in.ply"), {}, options);
  ASSERT_TRUE(partition.is_ok());
  EXPECT_FALSE(partition->reordered);
}

TEST(SpatialOrder, MoreThan256SlicesOfOldIdsAreRenamedOutOfCore) {
  // A 4 KiB table cuts the map into slices of 1,024 old ids: over 270k vertices that is more
  // than 256 slices, whose corners take two-byte slice tags. (So few ids past the probe's window
  // do not make the input scattered: --weld renumbers it.) Its face spill holds several frames,
  // which two or three threads split into parts.
  const Mesh input = testing::scattered_mesh(testing::make_wavy_sheet(521), 31);
  ASSERT_GT(input.positions.size(), 256u * 1024u);
  Mesh expected = input;
  EXPECT_EQ(reorder_spatially(expected.positions, expected.triangles, true), 0u);
  testing::ScratchDir dir;
  write_ply_file(dir.file("in.ply"), input);
  for (const std::uint32_t threads : {2u, 3u}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    auto partition = renumbered_partition(dir, dir.file("in.ply"), 4096, Weld::kOn, threads);
    ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
    EXPECT_TRUE(partition->reordered);
    expect_chunks_hold(*partition, expected);
  }
}

TEST(SpatialOrder, ACellLargerThanTheTableIsOrderedInPiecesOutOfCore) {
  // A far triangle stretches the bounds so that the whole sheet falls in one cell, and beside
  // it more than kMaxWeldGroup unreferenced copies of one of its vertices: one fine code that
  // keeps id order and is not welded. Out of core, that cell is ordered in pieces of fine codes
  // (and the large group streamed); the numbering is still the in-core one.
  Mesh mesh = testing::make_wavy_sheet(540);
  const Vec3f copied = mesh.positions[1000];
  for (std::uint32_t i = 0; i < kMaxWeldGroup + 5000; ++i) mesh.positions.push_back(copied);
  const auto far = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.push_back({1000, 1000, 1000});
  mesh.positions.push_back({1001, 1000, 1000});
  mesh.positions.push_back({1000, 1001, 1000});
  mesh.triangles.push_back({{far, far + 1, far + 2}});
  const Mesh input = testing::scattered_mesh(mesh, 29);
  Mesh expected = input;
  EXPECT_EQ(reorder_spatially(expected.positions, expected.triangles, true), 0u);  // the copies are too many to weld
  testing::ScratchDir dir;
  write_ply_file(dir.file("in.ply"), input);
  for (const std::uint64_t table : {std::uint64_t{0}, std::uint64_t{64} << 10}) {
    SCOPED_TRACE("table " + std::to_string(table));
    auto partition = renumbered_partition(dir, dir.file("in.ply"), table, Weld::kOn);
    ASSERT_TRUE(partition.is_ok()) << partition.status().to_string();
    EXPECT_TRUE(partition->reordered);
    EXPECT_EQ(partition->welded_vertices, 0u);
    expect_chunks_hold(*partition, expected);
  }
}

}  // namespace
}  // namespace gaussmesh::stream
