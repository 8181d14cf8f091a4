// Tests for format detection and dispatch: content sniffing without consuming, names and
// extensions, forced formats, unknown input, and every format through standard input.
#include <gtest/gtest.h>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;

MeshFormat detect(const std::string& bytes, const std::string& name = "x") {
  auto source = format::ByteSource::from_memory(bytes, name);
  format::Result<MeshFormat> f = format::detect_format(*source);
  EXPECT_TRUE(f.is_ok()) << f.status().to_string();
  EXPECT_EQ(source->offset(), 0u) << "detection consumed input";
  return f.is_ok() ? *f : MeshFormat::kUnknown;
}

Mesh tetrahedron() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  // Corners first appear in index order, so STL's welded numbering is the same.
  m.triangles = {{{0, 1, 2}}, {{0, 3, 1}}, {{1, 3, 2}}, {{2, 3, 0}}};
  return m;
}

std::string tetra_ply() {
  const Mesh m = tetrahedron();
  std::string s = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3f& p : m.positions) {
    s += std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
  }
  for (const Triangle& t : m.triangles) {
    s += "3 " + std::to_string(t.v[0]) + " " + std::to_string(t.v[1]) + " " + std::to_string(t.v[2]) + "\n";
  }
  return s;
}

std::string tetra_obj() {
  return to_obj(tetrahedron(), [](uint64_t i) { return std::to_string(i); });
}

TEST(DetectFormat, RecognisesEachFormatFromContent) {
  const Mesh m = tetrahedron();
  EXPECT_EQ(detect(tetra_ply()), MeshFormat::kPly);
  EXPECT_EQ(detect("ply\r\nformat ascii 1.0\r\n"), MeshFormat::kPly);
  EXPECT_EQ(detect(to_off(m)), MeshFormat::kOff);
  EXPECT_EQ(detect("# comment first\n\nCOFF 3 1 0\n"), MeshFormat::kOff);
  EXPECT_EQ(detect("STCNOFF\n"), MeshFormat::kOff);
  EXPECT_EQ(detect("OFF BINARY\n"), MeshFormat::kOff);  // so that the OFF reader explains
  EXPECT_EQ(detect(tetra_obj()), MeshFormat::kObj);
  EXPECT_EQ(detect("# Blender\n# more\nv 1 2 3\n"), MeshFormat::kObj);
  EXPECT_EQ(detect("g cube\nusemtl x\n"), MeshFormat::kObj);
  EXPECT_EQ(detect(to_ascii_stl(m)), MeshFormat::kStl);
  EXPECT_EQ(detect("  SOLID upper case\n FACET NORMAL 0 0 1\n"), MeshFormat::kStl);
  EXPECT_EQ(detect(to_binary_stl(m)), MeshFormat::kStl);
  EXPECT_EQ(detect(to_binary_stl(m, "solid but binary")), MeshFormat::kStl);
  EXPECT_EQ(detect("DRACO\x02\x02\x01"), MeshFormat::kDraco);
  EXPECT_EQ(detect(""), MeshFormat::kUnknown);
  EXPECT_EQ(detect("hello world\n"), MeshFormat::kUnknown);
  EXPECT_EQ(detect("plyx\n"), MeshFormat::kUnknown);
  EXPECT_EQ(detect(std::string("\x01\x02", 2)), MeshFormat::kUnknown);
}

TEST(DetectFormat, SolidHeaderIsBinaryOrAsciiByContent) {
  const Mesh m = tetrahedron();
  // "solid" binary files decode as binary whatever the first bytes say ...
  ReadOutcome r = read_bytes(to_binary_stl(m, "solid tetra"), "x");
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.triangles, m.triangles);
  // ... and ascii files as ascii, from a pipe too where no size is known.
  r = read_stdin(to_ascii_stl(m), /*via_pipe=*/true);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.triangles, m.triangles);
  r = read_stdin(to_binary_stl(m, "solid tetra"), /*via_pipe=*/true);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.triangles, m.triangles);
}

TEST(FormatNames, ParseNamesAndExtensions) {
  EXPECT_EQ(format::parse_format_name("ply"), MeshFormat::kPly);
  EXPECT_EQ(format::parse_format_name("OFF"), MeshFormat::kOff);
  EXPECT_EQ(format::parse_format_name("Obj"), MeshFormat::kObj);
  EXPECT_EQ(format::parse_format_name("stl"), MeshFormat::kStl);
  EXPECT_EQ(format::parse_format_name("drc"), MeshFormat::kDraco);
  EXPECT_EQ(format::parse_format_name("draco"), MeshFormat::kDraco);
  EXPECT_EQ(format::parse_format_name("gltf"), MeshFormat::kUnknown);
  EXPECT_EQ(format::parse_format_name(""), MeshFormat::kUnknown);
  EXPECT_EQ(format::format_from_extension("a/b/cow.OFF"), MeshFormat::kOff);
  EXPECT_EQ(format::format_from_extension("model.tar.stl"), MeshFormat::kStl);
  EXPECT_EQ(format::format_from_extension("x.drc"), MeshFormat::kDraco);
  EXPECT_EQ(format::format_from_extension("dir.obj/file"), MeshFormat::kUnknown);
  EXPECT_EQ(format::format_from_extension(".obj"), MeshFormat::kUnknown);
  EXPECT_EQ(format::format_from_extension("-"), MeshFormat::kUnknown);
}

TEST(ReadMesh, ForcedFormatOverridesDetection) {
  // OBJ content read as OFF fails in the OFF reader, which names what it found.
  ReadOutcome r = read_bytes(tetra_obj(), "t.dat", MeshFormat::kOff);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_NE(r.status.message().find("expected an OFF header"), std::string::npos) << r.status.to_string();
  r = read_bytes(tetra_obj(), "t.dat", MeshFormat::kObj);
  ASSERT_TRUE(r.status.is_ok());
  EXPECT_EQ(r.mesh.triangles, tetrahedron().triangles);
}

TEST(ReadMesh, UnknownAndUnsupportedInputsGiveOneClearError) {
  ReadOutcome r = read_bytes("hello world\n", "notes.txt");
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.code(), Code::kBadInput);
  EXPECT_EQ(r.status.where(), "notes.txt");
  EXPECT_NE(r.status.message().find("unrecognised mesh format"), std::string::npos);

  r = read_bytes("DRACO\x02\x02", "m.drc");
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "m.drc: byte 7");  // the header's reader names where it ends
  EXPECT_EQ(r.status.code(), Code::kBadInput);
  EXPECT_EQ(r.status.message().rfind("Draco: ", 0), 0u) << r.status.message();  // a truncated Draco file

  r = read_path("/nonexistent/dir/cow.off");
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.code(), Code::kBadInput);
  EXPECT_EQ(r.status.where(), "/nonexistent/dir/cow.off");
}

// Each byte of text as a UTF-16 code unit, in either byte order.
std::string utf16(const std::string& text, bool big_endian) {
  std::string out;
  for (char c : text) {
    out += big_endian ? std::string{'\0', c} : std::string{c, '\0'};
  }
  return out;
}

TEST(ReadMesh, TextInUtf16OrUtf32IsRefusedByName) {
  const std::string off = to_off(tetrahedron());
  struct Case {
    std::string bytes, encoding;
  };
  const Case cases[] = {
      {"\xFE\xFF" + utf16(off, true), "UTF-16 (big-endian byte-order mark)"},
      {"\xFF\xFE" + utf16(off, false), "UTF-16 (little-endian byte-order mark)"},
      {utf16(off, true), "UTF-16 (big-endian, no byte-order mark)"},
      {utf16(tetra_obj(), false), "UTF-16 (little-endian, no byte-order mark)"},
      {std::string("\xFF\xFE\0\0", 4) + "O\0\0\0F\0\0\0F\0\0\0", "UTF-32 (little-endian byte-order mark)"},
  };
  for (const Case& c : cases) {
    for (MeshFormat forced : {MeshFormat::kUnknown, MeshFormat::kOff, MeshFormat::kObj, MeshFormat::kPly}) {
      ReadOutcome r = read_bytes(c.bytes, "u.off", forced);
      ASSERT_FALSE(r.status.is_ok()) << c.encoding;
      EXPECT_EQ(r.status.code(), Code::kBadInput);
      EXPECT_EQ(r.status.where(), "u.off: byte 0");
      EXPECT_EQ(r.status.message().rfind("text encoded as " + c.encoding + ", which gaussmesh does not read", 0), 0u)
          << r.status.message();
      EXPECT_TRUE(single_line(r.status));
    }
  }
  // A binary STL whose 80-byte header is zeros is not UTF-16.
  EXPECT_TRUE(read_bytes(to_binary_stl(tetrahedron(), std::string(80, '\0')), "z.stl").status.is_ok());
}

TEST(ReadMesh, AUtf8ByteOrderMarkBeforeTextIsSkipped) {
  const std::string mark = "\xEF\xBB\xBF";
  for (const std::string& text : {to_off(tetrahedron()), tetra_obj(), tetra_ply(), to_ascii_stl(tetrahedron())}) {
    ReadOutcome plain = read_bytes(text, "m");
    ASSERT_TRUE(plain.status.is_ok()) << plain.status.to_string();
    ReadOutcome marked = read_bytes(mark + text, "m");
    ASSERT_TRUE(marked.status.is_ok()) << marked.status.to_string();
    EXPECT_EQ(marked.mesh.positions, plain.mesh.positions);
    EXPECT_EQ(marked.mesh.triangles, plain.mesh.triangles);
  }
}

TEST(ReadMesh, ExtensionDecidesWhenContentCannot) {
  // An OBJ that opens with more comment than detection looks at.
  std::string text(70000, ' ');
  for (size_t i = 0; i + 1 < text.size(); i += 70) {
    text[i] = '#';
    text[i + 69] = '\n';
  }
  text += tetra_obj();
  ScratchDir dir;
  write_file(dir.file("long.obj"), text);
  ReadOutcome r = read_path(dir.file("long.obj"));
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.triangles, tetrahedron().triangles);
  write_file(dir.file("long.txt"), text);
  r = read_path(dir.file("long.txt"));
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), dir.file("long.txt"));
}

// Every format through standard input without a format flag: from a pipe (no size, small
// pieces) and from a regular file (size known).
TEST(ReadMesh, StdinDetectsEveryFormat) {
  const Mesh m = tetrahedron();
  struct Input {
    const char* name;
    std::string bytes;
    MeshFormat format;
  };
  const Input inputs[] = {
      {"ply", tetra_ply(), MeshFormat::kPly},
      {"off", to_off(m), MeshFormat::kOff},
      {"obj", tetra_obj(), MeshFormat::kObj},
      {"ascii stl", to_ascii_stl(m), MeshFormat::kStl},
      {"binary stl", to_binary_stl(m), MeshFormat::kStl},
      {"solid binary stl", to_binary_stl(m, "solid x"), MeshFormat::kStl},
  };
  for (const Input& in : inputs) {
    for (bool pipe : {true, false}) {
      ReadOutcome r = read_stdin(in.bytes, pipe);
      ASSERT_TRUE(r.status.is_ok()) << in.name << (pipe ? " (pipe): " : " (file): ") << r.status.to_string();
      EXPECT_EQ(r.header.format, in.format) << in.name;
      EXPECT_EQ(r.mesh.positions, m.positions) << in.name;
      EXPECT_EQ(r.mesh.triangles, m.triangles) << in.name;
      EXPECT_EQ(r.contract_error, "") << in.name;
    }
  }
}

TEST(ReadMesh, StdinLargeInputCrossesManyWindows) {
  // cow as OFF and binary STL is larger than a pipe's buffer and the 64 KiB detection window.
  Mesh cow = load_fixture("real/cow.off");
  ASSERT_EQ(cow.triangles.size(), 5804u);
  ReadOutcome r = read_stdin(to_off(cow), true);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.positions, cow.positions);
  EXPECT_EQ(r.mesh.triangles, cow.triangles);
  r = read_stdin(to_binary_stl(cow), true);
  ASSERT_TRUE(r.status.is_ok()) << r.status.to_string();
  EXPECT_EQ(r.mesh.positions.size(), 2903u);  // two cow vertices share a position: welded
  EXPECT_EQ(r.mesh.triangles.size(), 5804u);
}

TEST(ReadMesh, StdinErrorsNameStdin) {
  ReadOutcome r = read_stdin("", true);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "<stdin>");
  EXPECT_NE(r.status.message().find("empty"), std::string::npos);
  r = read_stdin("OFF\n3 1 0\n0 0 0\n", true);
  ASSERT_FALSE(r.status.is_ok());
  EXPECT_EQ(r.status.where(), "<stdin>:3");
  EXPECT_NE(r.status.message().find("file ends after 1 of 3 vertices"), std::string::npos);
}

}  // namespace
}  // namespace gaussmesh::testing
