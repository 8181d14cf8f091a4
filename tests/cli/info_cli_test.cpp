// Tests for `gaussmesh info`: the cow in every input format from files and stdin, bad
// fixtures, usage errors and the --report JSON. Runs the built binary.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

// The cow as plain arrays, read with a minimal OFF parse (the fixture is clean), so that
// these files do not depend on our own readers or writers.
struct PlainMesh {
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

PlainMesh read_cow() {
  std::ifstream in(fixture("real/cow.off"));
  std::string magic;
  std::size_t nv = 0, nf = 0, ne = 0;
  in >> magic >> nv >> nf >> ne;
  PlainMesh m;
  m.positions.resize(nv);
  for (auto& p : m.positions) in >> p[0] >> p[1] >> p[2];
  m.triangles.resize(nf);
  for (auto& t : m.triangles) {
    int k = 0;
    in >> k >> t[0] >> t[1] >> t[2];
    EXPECT_EQ(k, 3);
  }
  EXPECT_TRUE(in);
  return m;
}

std::string number(float v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", v);  // round-trips a float exactly
  return buffer;
}

template <class T>
void put(std::string& out, T value, bool big_endian) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) {
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  }
  out.append(bytes, sizeof(T));
}

std::string ply_ascii(const PlainMesh& m) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.positions.size()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                  std::to_string(m.triangles.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (auto& p : m.positions) s += number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
  for (auto& t : m.triangles) {
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  }
  return s;
}

// Binary PLY with an extra uchar property before x and another after z.
std::string ply_binary(const PlainMesh& m, bool big_endian) {
  std::string s = std::string("ply\nformat ") +
                  (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment written by info_cli_test\nelement vertex " +
                  std::to_string(m.positions.size()) +
                  "\nproperty uchar quality\nproperty float x\nproperty float y\nproperty float z"
                  "\nproperty uchar flags\nelement face " +
                  std::to_string(m.triangles.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    put<std::uint8_t>(s, static_cast<std::uint8_t>(i), big_endian);
    for (float c : m.positions[i]) put<float>(s, c, big_endian);
    put<std::uint8_t>(s, 7, big_endian);
  }
  for (auto& t : m.triangles) {
    put<std::uint8_t>(s, 3, big_endian);
    for (std::uint32_t v : t) put<std::int32_t>(s, static_cast<std::int32_t>(v), big_endian);
  }
  return s;
}

std::string off_text(const PlainMesh& m) {
  std::string s = "OFF\n" + std::to_string(m.positions.size()) + " " +
                  std::to_string(m.triangles.size()) + " 0\n";
  for (auto& p : m.positions) s += number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
  for (auto& t : m.triangles) {
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  }
  return s;
}

// OBJ with texture coordinates and normals; faces as v/vt/vn or v//vn (1-based).
std::string obj_text(const PlainMesh& m, bool with_texture) {
  std::string s = "# written by info_cli_test\no cow\n";
  for (auto& p : m.positions) s += "v " + number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    s += "vn 0 0 1\n";
    if (with_texture) s += "vt " + number(float(i % 7) / 7) + " 0.5\n";
  }
  for (auto& t : m.triangles) {
    s += "f";
    for (std::uint32_t v : t) {
      std::string i = std::to_string(v + 1);
      s += " " + i + (with_texture ? "/" + i + "/" : "//") + i;
    }
    s += "\n";
  }
  return s;
}

std::string stl_binary(const PlainMesh& m) {
  std::string s(80, ' ');
  s.replace(0, 22, "binary STL of the cow.");
  put<std::uint32_t>(s, static_cast<std::uint32_t>(m.triangles.size()), false);
  for (auto& t : m.triangles) {
    for (int i = 0; i < 3; ++i) put<float>(s, 0.0f, false);  // normal: readers recompute
    for (std::uint32_t v : t) {
      for (float c : m.positions[v]) put<float>(s, c, false);
    }
    put<std::uint16_t>(s, 0, false);
  }
  return s;
}

std::string stl_ascii(const PlainMesh& m) {
  std::string s = "solid cow\n";
  for (auto& t : m.triangles) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (std::uint32_t v : t) {
      auto& p = m.positions[v];
      s += "      vertex " + number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid cow\n";
}

// "vertices   2,904 (...)" -> 2904; -1 when the line is missing.
long long summary_count(const std::string& out, const std::string& label) {
  std::smatch match;
  std::regex line("(^|\\n)" + label + "\\s+([0-9,]+)");
  if (!std::regex_search(out, match, line)) return -1;
  std::string digits;
  for (char c : match[2].str()) {
    if (c != ',') digits.push_back(c);
  }
  return std::stoll(digits);
}

std::string shell_quoted(const std::string& path) { return "'" + path + "'"; }
std::string info_command() { return shell_quoted(gaussmesh_binary()) + " info"; }

std::size_t line_count(const std::string& text) {
  std::size_t lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

class InfoCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { cow_ = new PlainMesh(read_cow()); }
  static void TearDownTestSuite() { delete cow_; }

  // Runs info on path from the file and from stdin and checks the counts.
  void expect_counts(const std::string& path, long long vertices, long long faces) {
    for (bool from_stdin : {false, true}) {
      SCOPED_TRACE(path + (from_stdin ? " via stdin" : " as a file"));
      std::string command = from_stdin ? "cat " + shell_quoted(path) + " | " + info_command() + " -"
                                       : info_command() + " " + shell_quoted(path);
      CommandResult r = run_command(command);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      EXPECT_EQ(summary_count(r.out, "vertices"), vertices) << r.out;
      EXPECT_EQ(summary_count(r.out, "faces"), faces) << r.out;
      EXPECT_EQ(r.err, "");
    }
  }

  static PlainMesh* cow_;
  ScratchDir dir_;
};
PlainMesh* InfoCli::cow_ = nullptr;

TEST_F(InfoCli, CowOff) {
  expect_counts(fixture("real/cow.off"), 2904, 5804);
  CommandResult r = run_command(info_command() + " " + shell_quoted(fixture("real/cow.off")));
  EXPECT_EQ(summary_count(r.out, "genus"), 0) << r.out;
  EXPECT_EQ(summary_count(r.out, "components"), 1) << r.out;
  EXPECT_EQ(summary_count(r.out, "non-manifold edges"), 0) << r.out;
}

TEST_F(InfoCli, CowRewrittenOff) {
  std::string path = dir_.file("cow.off");
  write_file(path, off_text(*cow_));
  expect_counts(path, 2904, 5804);
}

TEST_F(InfoCli, CowPlyAscii) {
  std::string path = dir_.file("cow.ply");
  write_file(path, ply_ascii(*cow_));
  expect_counts(path, 2904, 5804);
}

TEST_F(InfoCli, CowPlyBinaryLittleEndianWithExtraProperties) {
  std::string path = dir_.file("cow-le.ply");
  write_file(path, ply_binary(*cow_, false));
  expect_counts(path, 2904, 5804);
}

TEST_F(InfoCli, CowPlyBinaryBigEndianWithExtraProperties) {
  std::string path = dir_.file("cow-be.ply");
  write_file(path, ply_binary(*cow_, true));
  expect_counts(path, 2904, 5804);
  // The properties it does not read are named; the cow has no attributes.
  CommandResult r = run_command(info_command() + " " + shell_quoted(path));
  EXPECT_NE(r.out.find("vertex attributes      none\nnot read               quality, flags\n"), std::string::npos) << r.out;
}

TEST_F(InfoCli, ColoursAndNormalsAreListed) {
  std::string path = dir_.file("coloured.off");
  std::string text = "CNOFF\n3 1 0\n0 0 0 0 0 1 255 0 0\n1 0 0 0 0 1 0 255 0\n0 1 0 0 0 1 0 0 255\n3 0 1 2\n";
  write_file(path, text);
  CommandResult r = run_command(info_command() + " " + shell_quoted(path));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("vertex attributes      normals, colours\n"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("not read"), std::string::npos) << r.out;
}

TEST_F(InfoCli, CowObjWithTextureAndNormalIndices) {
  std::string path = dir_.file("cow-vtn.obj");
  write_file(path, obj_text(*cow_, true));
  expect_counts(path, 2904, 5804);
}

TEST_F(InfoCli, CowObjWithNormalIndices) {
  std::string path = dir_.file("cow-vn.obj");
  write_file(path, obj_text(*cow_, false));
  expect_counts(path, 2904, 5804);
}

// STL stores corner positions, not indices: readers weld equal positions, so the vertex
// count is the number of distinct positions. The cow has two vertices at one position
// (44 and 2903), so welding gives 2,903 vertices, not 2,904.
long long distinct_positions(const PlainMesh& m) {
  std::set<std::array<float, 3>> seen(m.positions.begin(), m.positions.end());
  return static_cast<long long>(seen.size());
}

TEST_F(InfoCli, CowStlBinary) {
  std::string path = dir_.file("cow.stl");
  write_file(path, stl_binary(*cow_));
  expect_counts(path, distinct_positions(*cow_), 5804);
}

TEST_F(InfoCli, CowStlAscii) {
  std::string path = dir_.file("cow-ascii.stl");
  write_file(path, stl_ascii(*cow_));
  expect_counts(path, distinct_positions(*cow_), 5804);
}

TEST_F(InfoCli, ForcedInputFormat) {
  CommandResult ok = run_command(info_command() + " --input-format off " + shell_quoted(fixture("real/cow.off")));
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(summary_count(ok.out, "faces"), 5804);
  CommandResult bad = run_command(info_command() + " --input-format xyz " + shell_quoted(fixture("real/cow.off")));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_EQ(bad.out, "");
}

TEST_F(InfoCli, BadFixturesExitTwoWithOneLine) {
  for (const char* name : {"OutOfMemory.off", "empty.obj", "empty.off", "empty.ply", "invalid.off",
                           "malformed.obj", "malformed2.obj", "nan-vertex.ply", "inf-vertex.ply"}) {
    SCOPED_TRACE(name);
    std::string path = fixture(std::string("bad/") + name);
    CommandResult r = run_command(info_command() + " " + shell_quoted(path));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(line_count(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;

    CommandResult piped = run_command("cat " + shell_quoted(path) + " | " + info_command() + " -");
    EXPECT_EQ(piped.exit_code, 2) << piped.err;
    EXPECT_EQ(piped.out, "");
    EXPECT_EQ(line_count(piped.err), 1u) << piped.err;
    EXPECT_NE(piped.err.find("<stdin>"), std::string::npos) << piped.err;
  }
}

TEST_F(InfoCli, MissingFileExitsTwo) {
  std::string path = dir_.file("no-such-mesh.off");
  CommandResult r = run_command(info_command() + " " + shell_quoted(path));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(line_count(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("no-such-mesh.off"), std::string::npos) << r.err;
}

TEST_F(InfoCli, UnknownFlagExitsOne) {
  CommandResult r = run_command(info_command() + " --no-such-flag " + shell_quoted(fixture("real/cow.off")));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err, "");
}

TEST_F(InfoCli, ReportJson) {
  std::string report = dir_.file("info.json");
  CommandResult r = run_command(info_command() + " --report " + shell_quoted(report) + " " +
                                shell_quoted(fixture("real/mech-holes-shark.off")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(read_file(report), nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  for (const char* field : {"input_vertices", "input_faces", "unreferenced_vertices",
                            "degenerate_faces", "zero_area_faces", "duplicate_faces", "edges",
                            "boundary_edges", "boundary_loops", "non_manifold_edges",
                            "non_manifold_vertices", "components", "euler_characteristic",
                            "orientable", "genus", "bounds", "peak_rss_bytes", "seconds"}) {
    EXPECT_TRUE(j.contains(field)) << field;
  }
  EXPECT_EQ(j["input_vertices"], 5246);
  EXPECT_EQ(j["input_faces"], 10192);
  EXPECT_EQ(j["boundary_edges"], 304);
  EXPECT_EQ(j["euler_characteristic"].get<long long>(),
            2 * j["components"].get<long long>() - 2 * j["genus"].get<long long>() -
                j["boundary_loops"].get<long long>());
  EXPECT_GT(j["peak_rss_bytes"].get<long long>(), 0);
  EXPECT_TRUE(j["seconds"].contains("read"));
  EXPECT_TRUE(j["seconds"].contains("analyse"));
  EXPECT_GT(j["bounds"]["diagonal"].get<double>(), 0);
  EXPECT_EQ(summary_count(r.out, "vertices"), 5246);  // the summary still goes to stdout

  // --report - puts only the JSON on stdout.
  CommandResult piped = run_command("cat " + shell_quoted(fixture("real/cow.off")) + " | " +
                                    info_command() + " - --report -");
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  nlohmann::json k = nlohmann::json::parse(piped.out, nullptr, false);
  ASSERT_FALSE(k.is_discarded()) << piped.out;
  EXPECT_EQ(k["input_faces"], 5804);
  EXPECT_EQ(k["genus"], 0);
}

TEST_F(InfoCli, NonManifoldGenusIsNull) {
  // Two triangles sharing only a vertex: a bow tie.
  std::string path = dir_.file("bowtie.off");
  write_file(path, "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n-1 0 0\n-1 -1 0\n3 0 1 2\n3 0 3 4\n");
  std::string report = dir_.file("bowtie.json");
  CommandResult r = run_command(info_command() + " --report " + shell_quoted(report) + " " + shell_quoted(path));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(read_file(report), nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_TRUE(j["genus"].is_null());
  EXPECT_EQ(j["non_manifold_vertices"], 1);
  EXPECT_EQ(j["boundary_loops"], 2);
}

}  // namespace
}  // namespace gaussmesh::testing
