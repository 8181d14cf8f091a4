// Tests for the OBJ census (format/obj_census.h): it counts the triangles the reader makes of the
// faces (polygons, continued statements, comments, CRLF, no final newline), says whether a corner
// names a vt or vn, stops once past what the caller asked, and agrees with the reader on whole
// meshes written in every corner syntax.
#include <gtest/gtest.h>

#include "format/obj_census.h"
#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

format::ObjCensus census_of(const std::string& text, std::uint64_t enough = UINT64_MAX) {
  auto source = format::ByteSource::from_memory(text, "t.obj");
  auto census = format::census_obj(*source, enough);
  EXPECT_TRUE(census) << census.status().to_string();
  return census ? *census : format::ObjCensus{};
}

TEST(ObjCensus, CountsTheTrianglesOfEveryPolygon) {
  const auto c = census_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\n"
                           "f 1 2 3\nf 1 2 4 3\n  f\t1 2 4 5 3\nf 1 2\n");
  EXPECT_EQ(c.triangles, 1u + 2u + 3u);
  EXPECT_FALSE(c.corner_values);
  EXPECT_TRUE(c.complete);
  EXPECT_EQ(c.vertices, 5u);
}

TEST(ObjCensus, CountsTheListsAReaderHolds) {
  const auto c = census_of("v 0 0 0\n\tv 1 0 0 1 1 1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvp 0.5\nvtx 1\n# v 1 1 1\nf 1/1/1 2/2/1 1/3/1\n");
  EXPECT_EQ(c.vertices, 2u);
  EXPECT_EQ(c.texcoords, 3u);
  EXPECT_EQ(c.normals, 1u);
  EXPECT_EQ(c.triangles, 1u);
}

TEST(ObjCensus, FollowsContinuationsCommentsAndLineEnds) {
  EXPECT_EQ(census_of("f 1 2 \\\n 3 4\n").triangles, 2u);  // a lone '\' is no corner
  EXPECT_EQ(census_of("f 1 2\\\n3\n").triangles, 1u);      // "2\" then "3": one more corner
  EXPECT_EQ(census_of("v 1 2 \\\n 3\nf 1 1 1\n").triangles, 1u);
  EXPECT_EQ(census_of("f 1 2 3 # a comment of four words\n").triangles, 1u);
  EXPECT_EQ(census_of("# f 1 2 3\nf 1 2 3\r\nf 1 2 3 4\r\n").triangles, 3u);
  EXPECT_EQ(census_of("f 1 2 3").triangles, 1u);  // no final newline
  EXPECT_EQ(census_of("fo 1 2 3\nvf 1 2 3\n").triangles, 0u);
  // A '\' alone, or closing a keyword, is a blank that continues the statement.
  EXPECT_EQ(census_of("\\\nf 1 2 3\n").triangles, 1u);
  EXPECT_EQ(census_of("f\\\n1 2 3 4\n").triangles, 2u);
  EXPECT_EQ(census_of("v\\\n0 0 0\nvt\\\n0 0\n").vertices, 1u);
  EXPECT_EQ(census_of("v\\\n0 0 0\nvt\\\n0 0\n").texcoords, 1u);
  // One '\r' before the '\n' belongs to the line end; a second one ends the statement.
  EXPECT_EQ(census_of("f 1 2 3 \\\r\n4\n").triangles, 2u);
  EXPECT_EQ(census_of("f 1 2 3\\\r\r\nf 4 5 6\n").triangles, 2u);
  EXPECT_EQ(census_of("f 1 2 \\\r\r\nf\\\n1 2 3\n").triangles, 2u);
}

TEST(ObjCensus, SaysWhenACornerNamesATextureCoordinateOrANormal) {
  EXPECT_TRUE(census_of("f 1/1 2/2 3/3\n").corner_values);
  EXPECT_TRUE(census_of("f 1//1 2//2 3//3\n").corner_values);
  EXPECT_TRUE(census_of("f 1 2 3\nf 1/1/1 2/2/2 3/3/3\n").corner_values);
  // vt and vn that no corner names are not kept by any reader.
  EXPECT_FALSE(census_of("vt 0 0\nvn 0 0 1\nf 1 2 3\n").corner_values);
}

TEST(ObjCensus, AnySlashLooksAtEveryByte) {
  const auto slash = [](const std::string& text) {
    auto source = format::ByteSource::from_memory(text, "t.obj");
    auto found = format::any_slash(*source);
    EXPECT_TRUE(found) << found.status().to_string();
    return found && *found;
  };
  EXPECT_FALSE(slash("v 0 0 0\nf 1 1 1\n"));
  EXPECT_TRUE(slash("v 0 0 0\nf 1/1 1/1 1/1\n"));
  // Past the first window (4 MiB).
  std::string text(std::size_t{9} << 20, ' ');
  EXPECT_FALSE(slash(text));
  text.back() = '/';
  EXPECT_TRUE(slash(text));
}

TEST(ObjCensus, StopsOncePastEnough) {
  std::string text;
  for (int i = 0; i < 100000; ++i) text += "f 1 2 3 4\n";
  const auto all = census_of(text);
  EXPECT_EQ(all.triangles, 200000u);
  EXPECT_TRUE(all.complete);
  EXPECT_TRUE(census_of(text, 200000).complete);
  const auto part = census_of(text, 1000);
  EXPECT_FALSE(part.complete);
  EXPECT_GT(part.triangles, 1000u);
}

TEST(ObjCensus, AgreesWithTheReaderOnTheCowInEveryCornerSyntax) {
  const Mesh cow = load_fixture("real/cow.off");
  const std::vector<std::pair<bool, std::string (*)(uint64_t)>> syntaxes = {
      {false, [](uint64_t i) { return std::to_string(i); }},
      {true, [](uint64_t i) { return std::to_string(i) + "/" + std::to_string(i); }},
      {true, [](uint64_t i) { return std::to_string(i) + "//" + std::to_string(i); }},
      {true, [](uint64_t i) { return std::to_string(i) + "/" + std::to_string(i) + "/" + std::to_string(i); }},
  };
  for (const auto& [values, corner] : syntaxes) {
    const std::string text = to_obj(cow, corner);
    const ReadOutcome read = read_bytes(text, "t.obj", MeshFormat::kObj);
    ASSERT_TRUE(read.status.is_ok()) << read.status.to_string();
    const auto c = census_of(text);
    EXPECT_EQ(c.triangles, read.mesh.triangles.size());
    EXPECT_EQ(c.corner_values, values);
  }
}

}  // namespace
}  // namespace gaussmesh::testing
