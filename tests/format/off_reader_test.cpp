// Tests for the streaming OFF reader: real fixtures, header variants, polygons, errors,
// hostile counts, truncation and corrupted bytes.
#include <gtest/gtest.h>

#include <random>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;

ReadOutcome read_off_text(const std::string& text, size_t batch = size_t{1} << 16) {
  return read_bytes(text, "t.off", MeshFormat::kOff, batch);
}

struct FixtureCounts {
  const char* file;
  size_t vertices, triangles;
};

class OffFixtureTest : public ::testing::TestWithParam<FixtureCounts> {};

TEST_P(OffFixtureTest, ReadsDeclaredCounts) {
  const FixtureCounts& f = GetParam();
  ReadOutcome r = read_path(fixture(std::string("real/") + f.file));
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.contract_error, "");
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.header.format, MeshFormat::kOff);
  EXPECT_EQ(r.mesh.positions.size(), f.vertices);
  EXPECT_EQ(r.mesh.triangles.size(), f.triangles);
  ASSERT_TRUE(r.header.declared_vertices.has_value());
  EXPECT_EQ(*r.header.declared_vertices, f.vertices);
}

INSTANTIATE_TEST_SUITE_P(Real, OffFixtureTest,
                         ::testing::Values(FixtureCounts{"cow.off", 2904, 5804},
                                           FixtureCounts{"fandisk.off", 6475, 12946},
                                           FixtureCounts{"homer.off", 4930, 9856},
                                           FixtureCounts{"knot1.off", 3200, 6400},
                                           FixtureCounts{"mech-holes-shark.off", 5246, 10192},
                                           FixtureCounts{"mushroom.off", 2337, 4608}));

TEST(OffReader, CowFirstVertexAndFaceMatchTheText) {
  // Checks values, not just counts, against what the file says on its lines 4 and 2908.
  ReadOutcome r = read_path(fixture("real/cow.off"));
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  std::string text = read_file(fixture("real/cow.off"));
  EXPECT_EQ(r.mesh.positions[0], (Vec3f{0.281526f, 0.266379f, -1.55991e-008f}));
  // The first face line follows the 2904 vertex lines.
  size_t pos = 0;
  int data_lines = 0;
  std::string first_face;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    if (line.find_first_not_of(" \r\t") == std::string::npos) continue;
    if (++data_lines == 2 + 2904 + 1) {
      first_face = line;
      break;
    }
  }
  unsigned n, a, b, c;
  ASSERT_EQ(std::sscanf(first_face.c_str(), "%u %u %u %u", &n, &a, &b, &c), 4);
  EXPECT_EQ(r.mesh.triangles[0], (Triangle{{a, b, c}}));
}

TEST(OffReader, SameMeshWhateverTheBatchSize) {
  ReadOutcome whole = read_path(fixture("real/mushroom.off"));
  ASSERT_TRUE(whole.status.is_ok());
  std::string text = read_file(fixture("real/mushroom.off"));
  for (size_t batch : {size_t{1}, size_t{7}, size_t{1000}}) {
    ReadOutcome r = read_off_text(text, batch);
    ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
    EXPECT_EQ(r.contract_error, "");
    EXPECT_EQ(r.mesh.positions, whole.mesh.positions) << "batch " << batch;
    EXPECT_EQ(r.mesh.triangles, whole.mesh.triangles) << "batch " << batch;
  }
}

TEST(OffReader, CountsOnHeaderLineCommentsBlankLinesAndNoEdgeCount) {
  ReadOutcome r = read_off_text(
      "# leading comment\n\nOFF 4 2   # counts on the header line, E omitted\n"
      "# a comment between\n0 0 0\n\n1 0 0 # trailing comment\n1 1 0\n0 1 0\n"
      "3 0 1 2\n   \n3 0 2 3\n# final comment\n");
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  ASSERT_EQ(r.mesh.positions.size(), 4u);
  EXPECT_EQ(r.mesh.positions[2], (Vec3f{1, 1, 0}));
  EXPECT_EQ(r.mesh.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{0, 2, 3}}}));
}

TEST(OffReader, VariantsSkipExtraVertexFieldsAndFaceColours) {
  const char* variants[] = {
      "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2 1 0 0\n",
      "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n",
      "CNOFF\n3 1 0\n0 0 0 0 0 1 .5 .5 .5 1\n1 0 0 0 0 1 .5 .5 .5 1\n0 1 0 0 0 1 .5 .5 .5 1\n3 0 1 2\n",
      "STOFF\n3 1 0\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2 0.1 0.2 0.3 1\n",
      "nOFF 3\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
      "nOFF\n3\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
      "4OFF\n3 1 0\n0 0 0 2\n2 0 0 2\n0 4 0 4\n3 0 1 2\n",
  };
  for (const char* text : variants) {
    ReadOutcome r = read_off_text(text);
    ASSERT_TRUE(r.status.is_ok()) << text << "\n" << r.status.to_string();
    EXPECT_EQ(r.mesh.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}})) << text;
    EXPECT_EQ(r.mesh.triangles, (std::vector<Triangle>{{{0, 1, 2}}})) << text;
  }
}

TEST(OffReader, PolygonsAreFanTriangulated) {
  ReadOutcome r = read_off_text("OFF\n6 2 0\n0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 1 0\n5 5 5\n"
                                "5 0 1 2 3 4\n3 5 4 3\n");
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.triangles,
            (std::vector<Triangle>{{{0, 1, 2}}, {{0, 2, 3}}, {{0, 3, 4}}, {{5, 4, 3}}}));
  ASSERT_TRUE(r.header.declared_faces.has_value());
  EXPECT_EQ(*r.header.declared_faces, 2u);
}

TEST(OffReader, EmptyMeshIsValid) {
  ReadOutcome r = read_off_text("OFF\n0 0 0\n");
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_TRUE(r.ended);
  EXPECT_TRUE(r.mesh.positions.empty());
}

// Texts whose error lies past the header carry enough bytes (a trailing comment) to pass
// the header's size plausibility check.
struct BadCase {
  const char* text;
  const char* where;     // expected Status::where()
  const char* message;   // a substring of the message
};

TEST(OffReader, ErrorsNameTheLineAndTheProblem) {
  const BadCase cases[] = {
      {"", "t.off", "empty"},
      {"# only a comment\n", "t.off", "empty"},
      {"PLY\n", "t.off:1", "expected an OFF header"},
      {"OFF BINARY\n3 1 0\n", "t.off:1", "binary OFF is not supported"},
      {"OFF\n", "t.off:1", "file ends before the vertex and face counts"},
      {"OFF\n3\n0 0 0\n", "t.off:2", "face count: missing"},
      {"OFF\n-3 1 0\n", "t.off:2", "vertex count: '-3' is not a number"},
      {"OFF\n3 1 0 7\n", "t.off:2", "after the counts"},
      {"nOFF 4\n3 1 0\n", "t.off:1", "nOFF dimension 4 is not supported"},
      {"OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n# pad\n", "t.off:4", "vertex 1 coordinate 3: missing"},
      {"OFF\n3 1 0\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n", "t.off:4", "'zero' is not a number"},
      {"OFF\n3 1 0\n0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n", "t.off:4", "not a finite number"},
      {"OFF\n3 1 0\n0 0 0\n1 0 1e39\n0 1 0\n3 0 1 2\n", "t.off:4", "out of range"},
      {"4OFF\n3 1 0\n0 0 0 0\n1 0 0 1\n0 1 0 1\n3 0 1 2\n", "t.off:3", "w = 0"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n# pad\n", "t.off:6", "face 0 has 2 vertices"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n0\n# padding\n", "t.off:6", "face 0 has 0 vertices"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "t.off:6", "declares 4 vertices but lists 3"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "t.off:6", "refers to vertex 3 but the file has 3"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "t.off:6", "'-1' is not a number"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", "t.off:7", "unexpected data after the 1 declared faces"},
      {"OFF\n5000000000 0 0\n", "t.off:2", "need at least"},
  };
  for (const BadCase& c : cases) {
    ReadOutcome r = read_off_text(c.text);
    ASSERT_FALSE(r.status.is_ok()) << c.text;
    EXPECT_EQ(r.status.code(), Code::kBadInput) << c.text;
    EXPECT_EQ(r.status.where(), c.where) << c.text << "\n" << r.status.to_string();
    EXPECT_NE(r.status.message().find(c.message), std::string::npos)
        << c.text << "\n" << r.status.to_string();
    EXPECT_TRUE(single_line(r.status));
    EXPECT_FALSE(r.ended) << "on_end after an error: " << c.text;
  }
}

TEST(OffReader, HostileCountFailsAtTheHeaderWhenTheSizeIsKnown) {
  ReadOutcome r = read_path(fixture("bad/OutOfMemory.off"));
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), fixture("bad/OutOfMemory.off") + ":2");
  EXPECT_NE(r.status.message().find("353535235358 vertices"), std::string::npos) << r.status.to_string();
  EXPECT_TRUE(r.mesh.positions.empty()) << "nothing should be delivered for a hopeless header";
}

TEST(OffReader, HostileCountFailsWhenThePipeEndsOrAtTheVertexLimit) {
  // Through a pipe nothing tells the size up front.
  std::string text = read_file(fixture("bad/OutOfMemory.off"));
  ReadOutcome r = read_stdin(text, /*via_pipe=*/true);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.code(), Code::kBadInput);
  EXPECT_EQ(r.status.where(), "<stdin>:2");
  EXPECT_NE(r.status.message().find("at most 4294967295"), std::string::npos) << r.status.to_string();

  // Within the vertex limit but still far more than the input holds: fails where it ends.
  std::string small = "OFF\n4000000000 6 0\n";
  for (size_t i = 0; i < 14; ++i) small += "0.5 -0.5 0.5\n";
  r = read_stdin(small, /*via_pipe=*/true);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "<stdin>:16");
  EXPECT_NE(r.status.message().find("file ends after 14 of 4000000000 vertices"), std::string::npos)
      << r.status.to_string();
}

// A small complete file whose last token is one character, so that no proper prefix can be a
// different valid file.
const char kSmallOff[] =
    "OFF\n# a square pyramid\n5 5 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n"
    "4 3 2 1 0\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4\n";

TEST(OffReader, EveryProperPrefixFailsWithOneLocatedError) {
  const std::string full = kSmallOff;
  ReadOutcome complete = read_off_text(full);
  ASSERT_TRUE(complete.status.is_ok()) << complete.status.to_string();
  ASSERT_EQ(complete.mesh.triangles.size(), 6u);
  size_t content_end = full.find_last_not_of("\n") + 1;
  for (size_t n = 0; n <= full.size(); ++n) {
    ReadOutcome r = read_off_text(full.substr(0, n));
    if (n >= content_end) {
      EXPECT_TRUE(r.status.is_ok()) << "prefix " << n << ": " << r.status.to_string();
      continue;
    }
    ASSERT_FALSE(r.status.is_ok()) << "prefix of " << n << " bytes was accepted";
    EXPECT_EQ(r.status.code(), Code::kBadInput);
    EXPECT_EQ(r.status.where().rfind("t.off", 0), 0u) << r.status.to_string();
    EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
    EXPECT_EQ(r.contract_error, "");
  }
}

TEST(OffReader, CorruptedBytesNeverCrash) {
  const uint32_t seed = 20240611;
  std::mt19937 rng(seed);
  const std::string full = kSmallOff;
  static const char kAlphabet[] = "0123456789 -+.eE#\n\r\tOFFx\0\xff";
  const std::string alphabet(kAlphabet, sizeof kAlphabet - 1);
  int rejected = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bytes = full;
    int changes = 1 + static_cast<int>(rng() % 4);
    for (int c = 0; c < changes; ++c) {
      bytes[rng() % bytes.size()] = alphabet[rng() % alphabet.size()];
    }
    ReadOutcome r = read_off_text(bytes, 1 + rng() % 4);
    EXPECT_EQ(r.contract_error, "") << "seed " << seed << " trial " << trial;
    if (!r.status.is_ok()) {
      ++rejected;
      EXPECT_EQ(r.status.code(), Code::kBadInput) << "seed " << seed << " trial " << trial;
      EXPECT_TRUE(single_line(r.status)) << "seed " << seed << " trial " << trial;
    } else {
      for (const Triangle& t : r.mesh.triangles) {
        for (auto v : t.v) ASSERT_LT(v, r.mesh.positions.size()) << "seed " << seed << " trial " << trial;
      }
    }
  }
  // Both outcomes must occur, or the trials test nothing.
  EXPECT_GT(rejected, 300) << "seed " << seed;
  EXPECT_LT(rejected, 2900) << "seed " << seed;
}

}  // namespace
}  // namespace gaussmesh::testing
