// Tests for the STL reader: cow through binary and ascii STL (welded back to the same mesh),
// welding rules, "solid" binary headers, counts against sizes, errors, truncation, corruption.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;

ReadOutcome read_stl_bytes(const std::string& bytes, size_t batch = size_t{1} << 16) {
  return read_bytes(bytes, "t.stl", MeshFormat::kStl, batch);
}

const Mesh& cow() {
  static const Mesh mesh = load_fixture("real/cow.off");
  return mesh;
}

// Triangles as position triples: what must survive STL, whose vertex numbering is its own.
std::vector<std::array<float, 9>> triangle_positions(const Mesh& m) {
  std::vector<std::array<float, 9>> out;
  for (const Triangle& t : m.triangles) {
    std::array<float, 9> a;
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = m.positions[t.v[k]];
      a[3 * k] = p.x;
      a[3 * k + 1] = p.y;
      a[3 * k + 2] = p.z;
    }
    out.push_back(a);
  }
  return out;
}

// Distinct positions, sorted: what welding by exact position keeps.
std::vector<std::array<float, 3>> distinct_positions(const Mesh& m) {
  std::vector<std::array<float, 3>> out;
  for (const Vec3f& p : m.positions) out.push_back({p.x + 0.0f, p.y + 0.0f, p.z + 0.0f});
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void expect_same_as_cow(const ReadOutcome& r, const char* what) {
  ASSERT_TRUE(r.status.is_ok()) << what << ": " << r.status.to_string();
  EXPECT_EQ(r.contract_error, "") << what;
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.header.format, MeshFormat::kStl);
  // cow.off holds 2904 vertices, two of them at the same position (-0.410173 0.204796
  // -1.55991e-08): STL cannot tell them apart, so welding gives one fewer.
  EXPECT_EQ(r.mesh.positions.size(), distinct_positions(cow()).size()) << what;
  EXPECT_EQ(r.mesh.positions.size(), 2903u) << what;
  EXPECT_EQ(r.mesh.triangles.size(), 5804u) << what;
  EXPECT_EQ(distinct_positions(r.mesh), distinct_positions(cow())) << what;
  EXPECT_EQ(triangle_positions(r.mesh), triangle_positions(cow())) << what;
}

TEST(StlReader, CowThroughBinaryAndAsciiWeldsBackToTheSameMesh) {
  ASSERT_EQ(cow().positions.size(), 2904u);
  ReadOutcome binary = read_stl_bytes(to_binary_stl(cow()));
  expect_same_as_cow(binary, "binary");
  ASSERT_TRUE(binary.header.declared_faces.has_value());
  EXPECT_EQ(*binary.header.declared_faces, 5804u);
  expect_same_as_cow(read_stl_bytes(to_ascii_stl(cow())), "ascii");
  // A binary header that starts with "solid", as many exporters write it.
  expect_same_as_cow(read_stl_bytes(to_binary_stl(cow(), "solid cow exported as binary")), "solid-binary");
  // Small batches keep the sink contract.
  ReadOutcome small = read_stl_bytes(to_binary_stl(cow()), 5);
  expect_same_as_cow(small, "binary, batch 5");
  // New vertices appear between triangles; batches stay full all the same (a vertex batch is
  // cut short only when a triangle batch needs its vertices delivered first).
  EXPECT_EQ(small.triangle_batches, (5804u + 4) / 5);
  EXPECT_LE(small.vertex_batches, (2903u + 4) / 5 + small.triangle_batches);
  EXPECT_EQ(binary.vertex_batches, 1u);
  EXPECT_EQ(binary.triangle_batches, 1u);
}

TEST(StlReader, WeldsExactPositionsAndTreatsNegativeZeroAsZero) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-0.0f, 0, -0.0f}, {1, 0, 0}, {1, 1, 0},
                 {std::nextafter(1.0f, 2.0f), 0, 0}};
  m.triangles = {{{0, 1, 2}}, {{3, 4, 5}}, {{0, 6, 2}}};
  for (const std::string& bytes : {to_binary_stl(m), to_ascii_stl(m)}) {
    ReadOutcome r = read_stl_bytes(bytes);
    ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
    // 0 and -0 are one vertex; 1 and its float successor are two.
    ASSERT_EQ(r.mesh.positions.size(), 5u);
    EXPECT_EQ(r.mesh.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{0, 1, 3}}, {{0, 4, 2}}}));
  }
}

TEST(StlReader, AsciiKeywordsAnyCaseSeveralSolidsAndPolygonLoops) {
  std::string text =
      "solid first\n"
      "FACET NORMAL 0 0 1\n OUTER LOOP\n  VERTEX 0 0 0\n  Vertex 1 0 0\n  vertex 0 1 0\n ENDLOOP\nENDFACET\n"
      "EndSolid first\n\n"
      "solid\n"
      "  facet normal 0 0 1\n    outer loop\n      vertex 1 0 0\n      vertex 1 1 0\n"
      "      vertex 0 1 0\n      vertex -1 1 0\n    endloop\n  endfacet\nendsolid\n";
  ReadOutcome r = read_stl_bytes(text);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {-1, 1, 0}}));
  // Welded across solids; the 4-corner loop is fanned.
  EXPECT_EQ(r.mesh.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{1, 3, 2}}, {{1, 2, 4}}}));
  EXPECT_FALSE(r.header.declared_faces.has_value());
}

TEST(StlReader, BinaryCountIsCheckedAgainstTheSize) {
  std::string bytes = to_binary_stl(cow());
  // Count says one more than the file holds.
  std::string wrong = bytes;
  uint32_t more = 5805;
  std::memcpy(wrong.data() + 80, &more, 4);
  ReadOutcome r = read_stl_bytes(wrong);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.code(), Code::kBadInput);
  EXPECT_EQ(r.status.where(), "t.stl: byte 80");
  EXPECT_NE(r.status.message().find("declares 5805 triangles"), std::string::npos) << r.status.to_string();
  EXPECT_TRUE(r.mesh.positions.empty());

  // A count of 0 with whole records after it: writers that could not seek back.
  std::string zero = bytes;
  uint32_t none = 0;
  std::memcpy(zero.data() + 80, &none, 4);
  expect_same_as_cow(read_stl_bytes(zero), "count 0");

  // Without a size (a pipe), the count is trusted until the data runs out.
  r = read_stdin(bytes.substr(0, 84 + 50 * 100 + 17), /*via_pipe=*/true, MeshFormat::kStl);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "<stdin>: byte " + std::to_string(84 + 50 * 100 + 17));
  EXPECT_NE(r.status.message().find("file ends after 100 of 5804 triangles"), std::string::npos)
      << r.status.to_string();
}

TEST(StlReader, NonFiniteCoordinatesAreRejected) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, std::nanf(""), 0}};
  m.triangles = {{{0, 1, 2}}};
  ReadOutcome r = read_stl_bytes(to_binary_stl(m));
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "t.stl: byte " + std::to_string(84 + 12 + 24));
  EXPECT_NE(r.status.message().find("not a finite number"), std::string::npos);
}

TEST(StlReader, AsciiErrorsNameTheLineAndTheProblem) {
  struct BadCase {
    const char* text;
    const char* where;
    const char* message;
  };
  const BadCase cases[] = {
      {"", "t.stl", "empty"},
      {"solid x\n", "t.stl:1", "file ends inside a solid"},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n", "t.stl:6",
       "loop has 2 vertices"},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n", "t.stl:4", "vertex z: missing"},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 q\n", "t.stl:4", "'q' is not a number"},
      {"solid x\nfacet normal 0 0 1\nvertex 0 0 0\n", "t.stl:3", "expected 'outer loop'"},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendfacet\n",
       "t.stl:7", "expected 'vertex' or 'endloop'"},
      {"solid x\nendsolid x\nvertex 0 0 0\n", "t.stl:3", "expected 'solid'"},
  };
  for (const BadCase& c : cases) {
    ReadOutcome r = read_stl_bytes(c.text);
    ASSERT_FALSE(r.status.is_ok()) << c.text;
    EXPECT_EQ(r.status.code(), Code::kBadInput) << c.text;
    EXPECT_EQ(r.status.where(), c.where) << c.text << "\n" << r.status.to_string();
    EXPECT_NE(r.status.message().find(c.message), std::string::npos) << c.text << "\n" << r.status.to_string();
    EXPECT_TRUE(single_line(r.status));
    EXPECT_FALSE(r.ended);
  }
}

Mesh small_pyramid() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  m.triangles = {{{3, 2, 1}}, {{3, 1, 0}}, {{0, 1, 4}}, {{1, 2, 4}}, {{2, 3, 4}}, {{3, 0, 4}}};
  return m;
}

// STL has an end marker (ascii) or a size (binary): no proper prefix is a complete file, except
// an ascii prefix that only loses the solid's trailing name.
void sweep_prefixes(const std::string& full, size_t complete_from, const char* what) {
  ReadOutcome complete = read_stl_bytes(full);
  ASSERT_TRUE(complete.status.is_ok()) << what << ": " << complete.status.to_string();
  for (size_t n = 0; n <= full.size(); ++n) {
    // Through detection, as a user would feed it, and forced.
    for (MeshFormat f : {MeshFormat::kStl, MeshFormat::kUnknown}) {
      ReadOutcome r = read_bytes(full.substr(0, n), "t.stl", f);
      if (n >= complete_from) {
        EXPECT_TRUE(r.status.is_ok()) << what << " prefix " << n << ": " << r.status.to_string();
        EXPECT_EQ(r.mesh.triangles, complete.mesh.triangles);
        continue;
      }
      ASSERT_FALSE(r.status.is_ok()) << what << ": prefix of " << n << " bytes was accepted";
      EXPECT_EQ(r.status.code(), Code::kBadInput);
      EXPECT_EQ(r.status.where().rfind("t.stl", 0), 0u) << r.status.to_string();
      EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
      EXPECT_EQ(r.contract_error, "");
    }
  }
}

TEST(StlReader, EveryProperPrefixFailsWithOneLocatedError) {
  std::string ascii = to_ascii_stl(small_pyramid());
  sweep_prefixes(ascii, ascii.rfind("endsolid") + std::string("endsolid").size(), "ascii");
  std::string binary = to_binary_stl(small_pyramid());
  sweep_prefixes(binary, binary.size(), "binary");
  std::string solid_binary = to_binary_stl(small_pyramid(), "solid but binary");
  sweep_prefixes(solid_binary, solid_binary.size(), "solid binary");
}

TEST(StlReader, CorruptedBytesNeverCrash) {
  const uint32_t seed = 99173;
  std::mt19937 rng(seed);
  int rejected = 0;
  const std::string inputs[] = {to_ascii_stl(small_pyramid()), to_binary_stl(small_pyramid())};
  for (const std::string& full : inputs) {
    for (int trial = 0; trial < 3000; ++trial) {
      std::string bytes = full;
      int changes = 1 + static_cast<int>(rng() % 4);
      for (int c = 0; c < changes; ++c) bytes[rng() % bytes.size()] = static_cast<char>(rng() & 0xFF);
      ReadOutcome r = read_bytes(bytes, "t.stl", trial % 2 ? MeshFormat::kStl : MeshFormat::kUnknown,
                                 1 + rng() % 4);
      EXPECT_EQ(r.contract_error, "") << "seed " << seed << " trial " << trial;
      if (!r.status.is_ok()) {
        ++rejected;
        EXPECT_TRUE(single_line(r.status)) << "seed " << seed << " trial " << trial;
      }
    }
  }
  // Both outcomes must occur, or the trials test nothing.
  EXPECT_GT(rejected, 300) << "seed " << seed;
  EXPECT_LT(rejected, 5900) << "seed " << seed;
}

}  // namespace
}  // namespace gaussmesh::testing
