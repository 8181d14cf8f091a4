// Tests for `gaussmesh segment`: the knot and the cow from files and stdin, the PLY's per-face
// segment and colour against the --report JSON, refusals (open mesh, not PLY, bad options).
// Runs the built binary.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string gm(const std::string& args) { return gaussmesh_binary() + " " + args; }

struct FaceColumns {
  std::vector<std::uint32_t> segment;
  std::set<std::uint32_t> colours;  // 0xRRGGBB
  bool ok = false;
};

// Reads the binary PLY that segment writes: header as documented, then vertices (3 floats) and
// faces (uchar 3, 3 int, red green blue uchar, uint segment, uint label, uchar pole).
FaceColumns read_segment_ply(const std::string& path) {
  FaceColumns out;
  const std::string bytes = read_file(path);
  const std::size_t end = bytes.find("end_header\n");
  if (end == std::string::npos) return out;
  const std::string header = bytes.substr(0, end);
  std::size_t nv = 0, nf = 0;
  if (std::sscanf(header.c_str() + header.find("element vertex"), "element vertex %zu", &nv) != 1) return out;
  if (std::sscanf(header.c_str() + header.find("element face"), "element face %zu", &nf) != 1) return out;
  const char* expected =
      "property list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property uint segment\nproperty uint label\nproperty uchar pole\n";
  if (header.find(expected) == std::string::npos) return out;
  std::size_t at = end + std::strlen("end_header\n") + 12 * nv;
  constexpr std::size_t kFace = 1 + 12 + 3 + 4 + 4 + 1;
  if (bytes.size() != at + kFace * nf) return out;
  for (std::size_t f = 0; f < nf; ++f, at += kFace) {
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + at);
    if (p[0] != 3) return out;
    out.colours.insert(std::uint32_t{p[13]} << 16 | std::uint32_t{p[14]} << 8 | p[15]);
    std::uint32_t s;
    std::memcpy(&s, p + 16, 4);
    out.segment.push_back(s);
  }
  out.ok = true;
  return out;
}

TEST(SegmentCli, KnotGivesTwoSegmentsMatchingTheReport) {
  ScratchDir dir;
  const auto r = run_command(gm("segment " + fixture("real/knot1.off") + " -o " + dir.file("k.ply") + " --report " +
                                dir.file("k.json")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_file(dir.file("k.json")));
  EXPECT_EQ(j["genus"], 1);
  EXPECT_EQ(j["segments"], 2);
  EXPECT_EQ(j["input_faces"], 6400);
  EXPECT_EQ(j["input_vertices"], 3200);
  EXPECT_EQ(j["frequency"], 1);
  EXPECT_EQ(j["gauss_triangles"], 20);
  EXPECT_EQ(j["gauss_vertices"], 12);
  for (const char* key : {"smooth_iterations", "poles", "patches", "peak_rss_bytes", "greedy_aggregates", "merges"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_TRUE(j["seconds"].is_object());
  const FaceColumns ply = read_segment_ply(dir.file("k.ply"));
  ASSERT_TRUE(ply.ok);
  ASSERT_EQ(ply.segment.size(), 6400u);
  std::vector<std::size_t> counts(2, 0);
  for (std::uint32_t s : ply.segment) {
    ASSERT_LT(s, 2u);
    ++counts[s];
  }
  EXPECT_EQ(j["segment_faces"][0], counts[0]);
  EXPECT_EQ(j["segment_faces"][1], counts[1]);
  EXPECT_EQ(ply.colours.size(), 2u);  // one colour per segment
}

TEST(SegmentCli, CowFromStdinIsOneSegment) {
  ScratchDir dir;
  const auto r = run_command("cat " + fixture("real/cow.off") + " | " + gm("segment - -o " + dir.file("c.ply") +
                                                                           " --report - -q"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;  // -q
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_EQ(j["segments"], 1);
  EXPECT_EQ(j["input"], "<stdin>");
  const FaceColumns ply = read_segment_ply(dir.file("c.ply"));
  ASSERT_TRUE(ply.ok);
  EXPECT_EQ(ply.segment.size(), 5804u);
  EXPECT_EQ(ply.colours.size(), 1u);
}

TEST(SegmentCli, OpenMeshIsRefusedWithNoOutput) {
  ScratchDir dir;
  const auto r = run_command(gm("segment " + fixture("real/mech-holes-shark.off") + " -o " + dir.file("s.ply")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("mech-holes-shark.off"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not closed"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("s.ply")));
}

TEST(SegmentCli, UsageErrors) {
  ScratchDir dir;
  const std::string cow = fixture("real/cow.off");
  EXPECT_EQ(run_command(gm("segment " + cow + " -o " + dir.file("c.drc"))).exit_code, 1);
  EXPECT_EQ(run_command(gm("segment " + cow)).exit_code, 1);  // -o is required
  EXPECT_EQ(run_command(gm("segment " + cow + " -o " + dir.file("c.ply") + " --orientations 3")).exit_code, 1);
  EXPECT_EQ(run_command(gm("segment " + cow + " -o " + dir.file("c.ply") + " --smooth 9 --max-smooth 4")).exit_code, 1);
  EXPECT_EQ(run_command(gm("segment " + cow + " -o " + dir.file("c.ply") + " --base cube")).exit_code, 1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("c.ply")));
  EXPECT_EQ(run_command(gm("segment " + dir.file("missing.off") + " -o " + dir.file("c.ply"))).exit_code, 2);
}

}  // namespace
}  // namespace gaussmesh::testing
