// Tests for the OBJ writer: exact round trips through our reader, the text it writes, and
// the validation errors that keep a bad mesh from being written.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "format/mesh_writer.h"
#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;
using format::MeshView;
using format::OutputFile;

// Writes mesh to a file in dir and returns the status of write + commit.
format::Status write_to(const std::string& path, const Mesh& m) {
  auto out = OutputFile::create(path, /*binary=*/false);
  if (!out.is_ok()) return out.status();
  MeshView view{m.positions, m.triangles};
  format::Status s = format::write_obj(**out, view);
  if (!s.is_ok()) return s;
  return (*out)->commit();
}

TEST(ObjWriter, CowRoundTripsBitExactly) {
  Mesh cow = load_fixture("real/cow.off");
  ASSERT_EQ(cow.triangles.size(), 5804u);
  ScratchDir dir;
  std::string path = dir.file("cow.obj");
  format::Status s = write_to(path, cow);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ReadOutcome r = read_path(path);  // detected as OBJ from the content
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.header.format, MeshFormat::kObj);
  EXPECT_EQ(r.mesh.positions, cow.positions);
  EXPECT_EQ(r.mesh.triangles, cow.triangles);
}

TEST(ObjWriter, AwkwardFloatsRoundTripBitExactly) {
  const uint32_t seed = 4242;
  std::mt19937 rng(seed);
  Mesh m;
  const float specials[] = {0.0f, -0.0f, 1e-45f, -1e-45f, std::numeric_limits<float>::min(),
                            std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                            0.1f, 1.0f / 3.0f, 16777217.0f, 123456789.0f};
  for (float f : specials) m.positions.push_back({f, -f, f * 0.5f});
  // Random bit patterns: every finite float must survive.
  while (m.positions.size() < 20000) {
    float c[3];
    for (float& v : c) {
      do {
        v = std::bit_cast<float>(static_cast<uint32_t>(rng()));
      } while (!std::isfinite(v));
    }
    m.positions.push_back({c[0], c[1], c[2]});
  }
  for (uint32_t i = 0; i + 2 < m.positions.size(); i += 3) m.triangles.push_back({{i, i + 1, i + 2}});
  ScratchDir dir;
  format::Status s = write_to(dir.file("f.obj"), m);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ReadOutcome r = read_path(dir.file("f.obj"));
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  ASSERT_EQ(r.mesh.positions.size(), m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      float a = (&m.positions[i].x)[k], b = (&r.mesh.positions[i].x)[k];
      ASSERT_EQ(std::bit_cast<uint32_t>(a), std::bit_cast<uint32_t>(b)) << "seed " << seed << " vertex " << i;
    }
  }
  EXPECT_EQ(r.mesh.triangles, m.triangles);
}

TEST(ObjWriter, WritesPlainVAndOneBasedFLines) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1.5f, -2, 0.25f}, {0, 1, 0}};
  m.triangles = {{{0, 1, 2}}};
  ScratchDir dir;
  ASSERT_TRUE(write_to(dir.file("t.obj"), m).is_ok());
  std::string text = read_file(dir.file("t.obj"));
  EXPECT_NE(text.find("\nv 0 0 0\nv 1.5 -2 0.25\nv 0 1 0\nf 1 2 3\n"), std::string::npos) << text;
}

TEST(ObjWriter, EmptyMeshWritesAHeaderOnly) {
  ScratchDir dir;
  ASSERT_TRUE(write_to(dir.file("e.obj"), Mesh{}).is_ok());
  std::string text = read_file(dir.file("e.obj"));
  EXPECT_EQ(text.find("\nv"), std::string::npos);
  EXPECT_EQ(text.front(), '#');
}

TEST(ObjWriter, InvalidMeshesAreProcessingErrorsAndLeaveNoFile) {
  Mesh bad_index;
  bad_index.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  bad_index.triangles = {{{0, 1, 2}}, {{0, 1, 3}}};
  Mesh bad_value;
  bad_value.positions = {{0, 0, 0}, {1, std::numeric_limits<float>::infinity(), 0}, {0, 1, 0}};
  bad_value.triangles = {{{0, 1, 2}}};
  ScratchDir dir;
  format::Status s = write_to(dir.file("a.obj"), bad_index);
  ASSERT_FALSE(s.is_ok());
  EXPECT_EQ(s.code(), Code::kProcessing);
  EXPECT_EQ(s.where(), dir.file("a.obj"));
  EXPECT_NE(s.message().find("triangle 1 refers to vertex 3 but the mesh has 3 vertices"), std::string::npos)
      << s.to_string();
  s = write_to(dir.file("b.obj"), bad_value);
  ASSERT_FALSE(s.is_ok());
  EXPECT_EQ(s.code(), Code::kProcessing);
  EXPECT_NE(s.message().find("vertex 1 is not finite"), std::string::npos) << s.to_string();
  // Nothing was committed: the directory holds no file at all, temporary or final.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace gaussmesh::testing
