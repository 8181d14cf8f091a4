// Vertex attributes in the text formats: OFF's [ST][C][N] vertex values (colours as bytes or as
// 0–1 numbers, three or four channels) and OBJ's vertex colours ("v x y z r g b"); OBJ's vt and
// vn, and colours that start late, are named as not kept.
#include <gtest/gtest.h>

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

Outcome read(const std::string& text, const std::string& name) {
  Outcome o;
  auto source = ByteSource::from_memory(text, name);
  ReadOptions options;
  options.batch_size = 2;  // attributes and positions across several batches
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
  EXPECT_EQ(o.sink.ignored, (std::vector<std::string>{"texture coordinates (vt)", "normals (vn)"}));
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

}  // namespace
}  // namespace gaussmesh::format
