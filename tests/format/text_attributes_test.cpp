// Vertex attributes in the text formats: OFF's [ST][C][N] vertex values (colours as bytes or as
// 0–1 numbers, three or four channels) and OBJ's vertex colours ("v x y z r g b"); OBJ's vt and
// vn, and colours that start late, are named as not kept when the file streams, and read per face
// corner, a vertex per distinct (v, vt, vn), when the caller asks for corner values.
#include <gtest/gtest.h>

#include <map>

#include <string>
#include <vector>

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "tests/format/attribute_sink.h"

namespace gaussmesh::format {
namespace {

using Collect = AttributeSink;

struct Outcome {
  Status status;
  Collect sink;
};

Outcome read(const std::string& text, const std::string& name, bool corner_values = false,
             std::uint64_t memory_limit = 0) {
  Outcome o;
  auto source = ByteSource::from_memory(text, name);
  ReadOptions options;
  options.batch_size = 2;  // attributes and positions across several batches
  options.corner_values = corner_values;
  options.memory_limit = memory_limit;
  o.status = read_mesh(*source, options, o.sink);
  return o;
}

const std::string kFace = "3 0 1 2\n";

TEST(OffAttributes, ColoursAsBytesOrNumbersWithThreeOrFourChannels) {
  Outcome bytes = read("COFF\n3 1 0\n0 0 0 255 0 51\n1 0 0 0 255 0\n0 1 0 0 0 255\n" + kFace, "c.off");
  ASSERT_TRUE(bytes.status.is_ok()) << bytes.status.to_string();
  EXPECT_EQ(bytes.sink.header.attributes, (AttributeKinds{false, true, false}));
  ASSERT_EQ(bytes.sink.attributes.size(), 3u);
  EXPECT_EQ(bytes.sink.attributes[0].color, (Color{1, 0, 0.2f, 1}));
  EXPECT_EQ(bytes.sink.attributes[2].color, (Color{0, 0, 1, 1}));
  Outcome numbers = read("COFF\n3 1 0\n0 0 0 1.0 0.5 0.25 0.75\n1 0 0 0 1 0 1.0\n0 1 0 0 0 1e0 1\n" + kFace, "c.off");
  ASSERT_TRUE(numbers.status.is_ok()) << numbers.status.to_string();
  EXPECT_EQ(numbers.sink.attributes[0].color, (Color{1, 0.5f, 0.25f, 0.75f}));
  EXPECT_EQ(numbers.sink.attributes[1].color, (Color{0, 1, 0, 1}));
  EXPECT_EQ(numbers.sink.attributes[2].color, (Color{0, 0, 1, 1}));
}

TEST(OffAttributes, NormalsColoursAndTextureCoordinatesInGeomviewsOrder) {
  Outcome o = read("STCNOFF\n3 1 0\n0 0 0  0 0 1  255 128 0  0.25 0.5\n1 0 0  0 1 0  0 0 0 255  1 0\n"
                   "0 1 0  1 0 0  0.5 0.5 0.5  0 1\n" + kFace, "a.off");
  ASSERT_TRUE(o.status.is_ok()) << o.status.to_string();
  EXPECT_EQ(o.sink.header.attributes, (AttributeKinds{true, true, true}));
  ASSERT_EQ(o.sink.attributes.size(), 3u);
  EXPECT_EQ(o.sink.attributes[0].normal, (Vec3f{0, 0, 1}));
  EXPECT_EQ(o.sink.attributes[0].color, (Color{1, 128.0f / 255, 0, 1}));
  EXPECT_EQ(o.sink.attributes[0].texcoord, (Vec2f{0.25f, 0.5f}));
  EXPECT_EQ(o.sink.attributes[1].color, (Color{0, 0, 0, 1}));
  EXPECT_EQ(o.sink.attributes[1].texcoord, (Vec2f{1, 0}));
  EXPECT_EQ(o.sink.attributes[2].color, (Color{0.5f, 0.5f, 0.5f, 1}));
  EXPECT_EQ(o.sink.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  Outcome st = read("STOFF\n3 1 0\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n" + kFace, "st.off");
  ASSERT_TRUE(st.status.is_ok()) << st.status.to_string();
  EXPECT_EQ(st.sink.header.attributes, (AttributeKinds{false, false, true}));
  EXPECT_EQ(st.sink.attributes[2].texcoord, (Vec2f{0, 1}));
}

TEST(OffAttributes, AMissingValueNamesTheLine) {
  Outcome o = read("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0\n0 1 0 0 0 1\n" + kFace, "n.off");
  ASSERT_FALSE(o.status.is_ok());
  EXPECT_EQ(o.status.code(), Code::kBadInput);
  EXPECT_EQ(o.status.where(), "n.off:4");
  EXPECT_NE(o.status.message().find("vertex 1 normal"), std::string::npos) << o.status.to_string();
}

TEST(ObjAttributes, ColoursWhenTheFirstVertexHasThem) {
  Outcome o = read("# coloured\nv 0 0 0 1 0.5 0.25\nv 1 0 0 0 1 0\nvt 0 0\nvn 0 0 1\nvt 1 1\nv 0 1 0 0 0 1\nf 1/1/1 2/2/1 3/1/1\n",
                   "c.obj");
  ASSERT_TRUE(o.status.is_ok()) << o.status.to_string();
  EXPECT_EQ(o.sink.header.attributes, (AttributeKinds{false, true, false}));
  ASSERT_EQ(o.sink.attributes.size(), 3u);
  EXPECT_EQ(o.sink.attributes[0].color, (Color{1, 0.5f, 0.25f, 1}));
  EXPECT_EQ(o.sink.attributes[2].color, (Color{0, 0, 1, 1}));
  EXPECT_EQ(o.sink.ignored, (std::vector<std::string>{"texture coordinates (vt; simplify keeps them in core: --engine in-core)", "normals (vn; simplify keeps them in core: --engine in-core)"}));
  Outcome missing = read("v 0 0 0 1 0.5 0.25\nv 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n", "m.obj");
  ASSERT_FALSE(missing.status.is_ok());
  EXPECT_EQ(missing.status.where(), "m.obj:2");
  EXPECT_NE(missing.status.message().find("vertex has no colour"), std::string::npos) << missing.status.to_string();
  Outcome late = read("v 0 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n", "l.obj");
  ASSERT_TRUE(late.status.is_ok()) << late.status.to_string();
  EXPECT_FALSE(late.sink.header.attributes.any());
  EXPECT_TRUE(late.sink.attributes.empty());
  EXPECT_EQ(late.sink.ignored, (std::vector<std::string>{"vertex colours that start after the first vertex (v x y z r g b)"}));
}

// Two triangles sharing edge 1-3; the shared edge is a texture seam (vertex 3 has two vt) and
// vertex 1 has one normal in both.
const std::string kSeamed =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
    "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvt 0.25 0.75\nvn 0 0 1\n"
    "f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/4/1 3/5/1\n";

TEST(ObjAttributes, CornerValuesSplitAVertexWhereItsValuesDiffer) {
  Outcome o = read(kSeamed, "s.obj", /*corner_values=*/true);
  ASSERT_TRUE(o.status.is_ok()) << o.status.to_string();
  EXPECT_EQ(o.sink.header.attributes, (AttributeKinds{true, false, true}));
  // 1/1/1 2/2/1 3/3/1 4/4/1 3/5/1: vertex 3 twice, at the same place.
  ASSERT_EQ(o.sink.positions.size(), 5u);
  EXPECT_EQ(o.sink.positions[2], o.sink.positions[4]);
  EXPECT_EQ(o.sink.attributes[2].texcoord, (Vec2f{0, 1}));
  EXPECT_EQ(o.sink.attributes[4].texcoord, (Vec2f{0.25f, 0.75f}));
  EXPECT_EQ(o.sink.attributes[3].normal, (Vec3f{0, 0, 1}));
  EXPECT_EQ(o.sink.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{1, 3, 4}}}));
  EXPECT_TRUE(o.sink.ignored.empty());
  // Streamed, the same file gives its four vertices and names what it does not keep.
  Outcome streamed = read(kSeamed, "s.obj");
  ASSERT_TRUE(streamed.status.is_ok()) << streamed.status.to_string();
  EXPECT_EQ(streamed.sink.positions.size(), 4u);
  EXPECT_EQ(streamed.sink.triangles, (std::vector<Triangle>{{{0, 1, 2}}, {{1, 3, 2}}}));
  EXPECT_EQ(streamed.sink.ignored, (std::vector<std::string>{"texture coordinates (vt; simplify keeps them in core: --engine in-core)", "normals (vn; simplify keeps them in core: --engine in-core)"}));
}

TEST(ObjAttributes, CornerValuesWithRelativeIndicesAndNoFaceUsingThem) {
  Outcome rel = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n", "r.obj", true);
  ASSERT_TRUE(rel.status.is_ok()) << rel.status.to_string();
  EXPECT_EQ(rel.sink.header.attributes, (AttributeKinds{false, false, true}));
  ASSERT_EQ(rel.sink.attributes.size(), 3u);
  EXPECT_EQ(rel.sink.attributes[1].texcoord, (Vec2f{1, 0}));
  Outcome unused = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1 2 3\n", "u.obj", true);
  ASSERT_TRUE(unused.status.is_ok()) << unused.status.to_string();
  EXPECT_FALSE(unused.sink.header.attributes.any());
  EXPECT_EQ(unused.sink.positions.size(), 3u);
  EXPECT_EQ(unused.sink.ignored, (std::vector<std::string>{"texture coordinates (vt) no face uses"}));
}

// A position with thousands of texture coordinates (past the first table, the second grows
// several times), corners that repeat earlier ones in any order: one vertex per distinct
// (v, vt), numbered where it first appears, each face over the right ones.
TEST(ObjAttributes, CornerValuesNumberManyValuesAtOnePositionInOrderOfAppearance) {
  constexpr int kFaces = 5000;
  std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < kFaces; ++i) text += "vt " + std::to_string(i) + " 0\n";
  // Face i: vertex 1 with vt i, vertex 2 with vt 0, vertex 3 with vt (i * 7) % kFaces.
  std::map<std::pair<int, int>, std::uint32_t> want_id;
  std::vector<Triangle> want;
  std::vector<std::pair<int, int>> order;
  for (int i = 0; i < kFaces; ++i) {
    const std::pair<int, int> corners[3] = {{1, i}, {2, 0}, {3, (i * 7) % kFaces}};
    Triangle t;
    for (int k = 0; k < 3; ++k) {
      auto [at, added] = want_id.try_emplace(corners[k], std::uint32_t(order.size()));
      if (added) order.push_back(corners[k]);
      t.v[k] = at->second;
    }
    want.push_back(t);
    text += "f 1/" + std::to_string(i + 1) + " 2/1 3/" + std::to_string((i * 7) % kFaces + 1) + "\n";
  }
  Outcome o = read(text, "m.obj", true);
  ASSERT_TRUE(o.status.is_ok()) << o.status.to_string();
  ASSERT_EQ(o.sink.positions.size(), order.size());
  EXPECT_EQ(o.sink.triangles, want);
  for (std::size_t id = 0; id < order.size(); ++id) {
    EXPECT_EQ(o.sink.positions[id], (Vec3f{order[id].first == 2 ? 1.0f : 0.0f, order[id].first == 3 ? 1.0f : 0.0f, 0}));
    EXPECT_EQ(o.sink.attributes[id].texcoord, (Vec2f{float(order[id].second), 0})) << id;
  }
}

TEST(ObjAttributes, CornerValuesRefuseABadIndexAndAFileOverTheBudget) {
  Outcome bad = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", "b.obj", true);
  ASSERT_FALSE(bad.status.is_ok());
  EXPECT_EQ(bad.status.code(), Code::kBadInput);
  EXPECT_EQ(bad.status.where(), "b.obj:5");
  EXPECT_NE(bad.status.message().find("texture coordinate 2 but only 1"), std::string::npos) << bad.status.to_string();
  Outcome junk = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1x 2//1 3//1\n", "j.obj", true);
  ASSERT_FALSE(junk.status.is_ok());
  EXPECT_EQ(junk.status.code(), Code::kBadInput);
  std::string big;
  for (int i = 0; i < 4000; ++i) big += "v 0 0 0\nvt 0 0\n";
  Outcome over = read(big + "f 1/1 2/2 3/3\n", "o.obj", true, /*memory_limit=*/16384);
  ASSERT_FALSE(over.status.is_ok());
  EXPECT_EQ(over.status.code(), Code::kResources);
  EXPECT_NE(over.status.message().find("--memory"), std::string::npos) << over.status.to_string();
}

}  // namespace
}  // namespace gaussmesh::format
