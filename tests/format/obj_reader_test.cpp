// Tests for the streaming OBJ reader: cow round trips through every face syntax, negative
// indices with interleaved vertices, quads, ignored statements, errors, truncation, corruption.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;

ReadOutcome read_obj_text(const std::string& text, size_t batch = size_t{1} << 16) {
  return read_bytes(text, "t.obj", MeshFormat::kObj, batch);
}

const Mesh& cow() {
  static const Mesh mesh = load_fixture("real/cow.off");
  return mesh;
}

TEST(ObjReader, CowFixtureLoads) {
  ASSERT_EQ(cow().positions.size(), 2904u);
  ASSERT_EQ(cow().triangles.size(), 5804u);
}

TEST(ObjReader, CowRoundTripsThroughEveryCornerSyntax) {
  struct Syntax {
    const char* name;
    std::string (*corner)(uint64_t);
  };
  const Syntax syntaxes[] = {
      {"v", [](uint64_t i) { return std::to_string(i); }},
      {"v/vt", [](uint64_t i) { return std::to_string(i) + "/" + std::to_string(i); }},
      {"v//vn", [](uint64_t i) { return std::to_string(i) + "//" + std::to_string(i); }},
      {"v/vt/vn", [](uint64_t i) { return std::to_string(i) + "/" + std::to_string(i) + "/" + std::to_string(i); }},
  };
  for (const Syntax& s : syntaxes) {
    std::string text = to_obj(cow(), s.corner);
    ReadOutcome r = read_obj_text(text);
    ASSERT_TRUE(r.status.is_ok()) << s.name << ": " << r.status.to_string();
    EXPECT_EQ(r.contract_error, "") << s.name;
    EXPECT_TRUE(r.ended);
    EXPECT_EQ(r.header.format, MeshFormat::kObj);
    EXPECT_FALSE(r.header.declared_vertices.has_value());
    EXPECT_EQ(r.mesh.positions, cow().positions) << s.name;
    EXPECT_EQ(r.mesh.triangles, cow().triangles) << s.name;
  }
}

// Writes cow with vertices and faces interleaved (each face right after its last vertex),
// negative (relative) indices, and pairs of triangles sharing an edge merged into quads whose
// fan gives back the two triangles. Returns the text and counts the quads.
std::string interleaved_negative_quads(const Mesh& m, size_t& quads) {
  // Directed edge -> triangle, to find the partner across each edge.
  std::map<std::pair<uint32_t, uint32_t>, size_t> edge_owner;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& v = m.triangles[t].v;
    for (int k = 0; k < 3; ++k) edge_owner[{v[k], v[(k + 1) % 3]}] = t;
  }
  std::vector<bool> used(m.triangles.size(), false);
  std::vector<std::vector<uint32_t>> polygons;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    if (used[t]) continue;
    used[t] = true;
    const auto& v = m.triangles[t].v;
    bool merged = false;
    for (int r = 0; r < 3 && !merged; ++r) {
      uint32_t x = v[r], y = v[(r + 1) % 3], z = v[(r + 2) % 3];
      auto it = edge_owner.find({x, z});  // the neighbour across z->x holds x->z
      if (it == edge_owner.end() || used[it->second]) continue;
      const auto& u = m.triangles[it->second].v;
      uint32_t w = u[0] + u[1] + u[2] - x - z;  // its third corner
      if (w == y || w == x || w == z) continue;
      used[it->second] = true;
      polygons.push_back({x, y, z, w});  // fans into (x,y,z) and (x,z,w)
      merged = true;
    }
    if (!merged) polygons.push_back({v[0], v[1], v[2]});
  }
  quads = 0;
  for (const auto& p : polygons) quads += p.size() == 4;

  std::string s = "# interleaved\n";
  uint64_t written = 0;
  // Emit each polygon as soon as every vertex it uses has been written.
  std::vector<std::vector<size_t>> ready_after(m.positions.size());
  for (size_t i = 0; i < polygons.size(); ++i) {
    uint32_t top = *std::max_element(polygons[i].begin(), polygons[i].end());
    ready_after[top].push_back(i);
  }
  for (uint32_t v = 0; v < m.positions.size(); ++v) {
    append_obj_vertex(s, m.positions[v]);
    ++written;
    for (size_t i : ready_after[v]) {
      s += "f";
      for (uint32_t c : polygons[i]) s += " -" + std::to_string(written - c);
      s += "\n";
    }
  }
  return s;
}

TEST(ObjReader, CowWithNegativeIndicesInterleavingAndQuads) {
  size_t quads = 0;
  std::string text = interleaved_negative_quads(cow(), quads);
  EXPECT_GT(quads, 1000u) << "the test should exercise many quads";
  for (size_t batch : {size_t{1}, size_t{3}, size_t{1} << 16}) {
    ReadOutcome r = read_obj_text(text, batch);
    ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
    EXPECT_EQ(r.contract_error, "") << "batch " << batch;
    EXPECT_EQ(r.mesh.positions, cow().positions);
    // Face order changed; each triangle must come back with its orientation.
    EXPECT_EQ(canonical_sorted(r.mesh.triangles), canonical_sorted(cow().triangles)) << "batch " << batch;
    // Interleaving must not shrink the batches: triangle batches are full, and a vertex batch
    // is cut short only when a triangle batch needs its vertices delivered first.
    EXPECT_EQ(r.triangle_batches, (cow().triangles.size() + batch - 1) / batch) << "batch " << batch;
    EXPECT_LE(r.vertex_batches, (cow().positions.size() + batch - 1) / batch + r.triangle_batches);
    if (batch > cow().triangles.size()) {
      EXPECT_EQ(r.vertex_batches, 1u);
    }
  }
}

TEST(ObjReader, IgnoresOtherStatementsAndExtraValues) {
  ReadOutcome r = read_obj_text(
      "# comment\nmtllib a.mtl\no thing\ng group other\ns off\nusemtl red\n"
      "v 0 0 0 1.0\n"              // w
      "v 1 0 0 1 0 0\n"            // vertex colour
      "v 0 1 0 # inline comment\n"
      "vt 0 0\nvn 0 0 1\nvp 0.5\n"
      "l 1 2\np 3\n"
      "curv 0 1 1 2\ncstype bspline\n"
      "f 1 2 \\\n 3\n"             // continuation line
      "\tf\t3 2 1 # comment\n"
      "f 1/1 2/1 3/1\r\n"
      "f +1 +2 +3\n");
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(r.mesh.triangles,
            (std::vector<Triangle>{{{0, 1, 2}}, {{2, 1, 0}}, {{0, 1, 2}}, {{0, 1, 2}}}));
}

TEST(ObjReader, ErrorLinesPointAtTheStatementThatStartsAContinuation) {
  ReadOutcome r = read_obj_text("v 0 0 0\nv 1 0 0\nf 1 2 \\\n 9\n");
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "t.obj:3");
}

TEST(ObjReader, EndlessContinuationIsBounded) {
  // Memory must not grow with the input: a statement joined over 4 MiB is refused.
  std::string text = "v 0 0 0\nf 1";
  for (int i = 0; i < 1200000; ++i) text += " 1 \\\n";
  text += "1\n";
  ReadOutcome r = read_obj_text(text);
  ASSERT_FALSE(r.status.is_ok()) << text.size() << " bytes read as " << r.mesh.triangles.size() << " triangles";
  EXPECT_EQ(r.status.where(), "t.obj:2");
  EXPECT_NE(r.status.message().find("over more than 4 MiB"), std::string::npos) << r.status.to_string();
}

TEST(ObjReader, PolygonFanAndTrianglesOnlyAfterTheirVertices) {
  ReadOutcome r = read_obj_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\nf 1 2 3 4 5\n", 1);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.contract_error, "");
  EXPECT_EQ(r.mesh.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{0, 2, 3}}, {{0, 3, 4}}}));
}

TEST(ObjReader, ErrorsNameTheLineAndTheProblem) {
  struct BadCase {
    const char* text;
    const char* where;
    const char* message;
  };
  const BadCase cases[] = {
      {"", "t.obj", "empty"},
      {"# nothing\ng x\n", "t.obj", "no vertices"},
      {"v 1 2\n", "t.obj:1", "vertex z: missing"},
      {"v 1 2 x\n", "t.obj:1", "vertex z: 'x' is not a number"},
      {"v 1 2 inf\n", "t.obj:1", "not a finite number"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "t.obj:4", "face has 2 vertices"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", "t.obj:4", "face has 0 vertices"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "t.obj:4", "index 0 is invalid"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "t.obj:4", "refers to vertex 4 but only 3 vertices are defined so far"},
      {"v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", "t.obj:2", "refers to vertex 2 but only 1 vertices"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "t.obj:4", "relative vertex -4 but only 3"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "t.obj:4", "'x' is not a number"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n", "t.obj:4", "unexpected character"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", "t.obj:4", "out of range"},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n", "t.obj:4", "relative vertex"},
  };
  for (const BadCase& c : cases) {
    ReadOutcome r = read_obj_text(c.text);
    ASSERT_FALSE(r.status.is_ok()) << c.text;
    EXPECT_EQ(r.status.code(), Code::kBadInput) << c.text;
    EXPECT_EQ(r.status.where(), c.where) << c.text << "\n" << r.status.to_string();
    EXPECT_NE(r.status.message().find(c.message), std::string::npos) << c.text << "\n" << r.status.to_string();
    EXPECT_TRUE(single_line(r.status));
    EXPECT_FALSE(r.ended);
  }
}

const char kSmallObj[] =
    "# pyramid\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
    "f 4 3 2 1\nf 1/1 2/2 5/3\nf 2//1 3//1 5//1\nf -3 -2 -1\nf 4 1 5\n";

// OBJ declares no counts, so a prefix cut between statements is a valid smaller OBJ. What a
// prefix may give: an error naming the source and a line, or a mesh that is a prefix of the
// full one (the last vertex's last coordinate may have lost digits).
TEST(ObjReader, EveryPrefixGivesAPrefixMeshOrOneLocatedError) {
  const std::string full = kSmallObj;
  ReadOutcome complete = read_obj_text(full);
  ASSERT_TRUE(complete.status.is_ok()) << complete.status.to_string();
  ASSERT_EQ(complete.mesh.triangles.size(), 6u);
  size_t failures = 0;
  for (size_t n = 0; n <= full.size(); ++n) {
    ReadOutcome r = read_obj_text(full.substr(0, n));
    if (!r.status.is_ok()) {
      ++failures;
      EXPECT_EQ(r.status.code(), Code::kBadInput);
      EXPECT_EQ(r.status.where().rfind("t.obj", 0), 0u) << r.status.to_string();
      EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
      continue;
    }
    EXPECT_EQ(r.contract_error, "");
    ASSERT_LE(r.mesh.positions.size(), complete.mesh.positions.size());
    ASSERT_LE(r.mesh.triangles.size(), complete.mesh.triangles.size());
    for (size_t i = 0; i + 1 < r.mesh.positions.size(); ++i) {
      EXPECT_EQ(r.mesh.positions[i], complete.mesh.positions[i]) << "prefix " << n;
    }
    for (size_t i = 0; i < r.mesh.triangles.size(); ++i) {
      EXPECT_EQ(r.mesh.triangles[i], complete.mesh.triangles[i]) << "prefix " << n;
    }
    if (n == full.size()) {
      EXPECT_EQ(r.mesh.triangles, complete.mesh.triangles);
    }
  }
  EXPECT_GT(failures, 10u) << "cuts inside statements should fail";
}

TEST(ObjReader, CorruptedBytesNeverCrash) {
  const uint32_t seed = 7341;
  std::mt19937 rng(seed);
  const std::string full = kSmallObj;
  static const char kAlphabet[] = "0123456789 -+./eE#\\\n\r\tvfx\0\xff";
  const std::string alphabet(kAlphabet, sizeof kAlphabet - 1);
  int rejected = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bytes = full;
    int changes = 1 + static_cast<int>(rng() % 4);
    for (int c = 0; c < changes; ++c) bytes[rng() % bytes.size()] = alphabet[rng() % alphabet.size()];
    ReadOutcome r = read_obj_text(bytes, 1 + rng() % 4);
    EXPECT_EQ(r.contract_error, "") << "seed " << seed << " trial " << trial;
    if (!r.status.is_ok()) {
      ++rejected;
      EXPECT_EQ(r.status.code(), Code::kBadInput) << "seed " << seed << " trial " << trial;
      EXPECT_TRUE(single_line(r.status)) << "seed " << seed << " trial " << trial;
    }
  }
  // Both outcomes must occur, or the trials test nothing.
  EXPECT_GT(rejected, 300) << "seed " << seed;
  EXPECT_LT(rejected, 2900) << "seed " << seed;
}

}  // namespace
}  // namespace gaussmesh::testing
