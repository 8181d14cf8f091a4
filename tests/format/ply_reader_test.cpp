// Tests of the streaming PLY reader: encodings, layouts, real fixtures, and hostile input
// (truncation sweep, corrupted bytes, lying headers).
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <limits>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

using testing::ScratchDir;

// Keeps everything delivered and checks the MeshSink contract as it goes.
class CollectSink final : public MeshSink {
 public:
  Status on_header(const MeshHeader& header) override {
    if (header_calls++ > 0 || !positions.empty() || !triangles.empty()) contract_broken = true;
    this->header = header;
    return {};
  }
  Status on_ignored(const std::string& what) override {
    if (header_calls != 1 || !positions.empty()) contract_broken = true;
    ignored.push_back(what);
    return {};
  }
  Status on_warning(const std::string& message) override {
    if (header_calls != 1 || end_calls != 0) contract_broken = true;
    warnings.push_back(message);
    return {};
  }
  Status on_vertex_attributes(std::span<const VertexAttributes> batch) override {
    if (header_calls != 1 || batch.empty() || !header.attributes.any()) contract_broken = true;
    pending_attributes = batch.size();
    attributes.insert(attributes.end(), batch.begin(), batch.end());
    return {};
  }
  Status on_vertices(std::span<const Vec3f> batch) override {
    if (header_calls != 1 || batch.empty()) contract_broken = true;
    if (header.attributes.any() && pending_attributes != batch.size()) contract_broken = true;
    pending_attributes = 0;
    largest_batch = std::max(largest_batch, batch.size());
    positions.insert(positions.end(), batch.begin(), batch.end());
    return {};
  }
  Status on_triangles(std::span<const Triangle> batch) override {
    if (header_calls != 1 || batch.empty()) contract_broken = true;
    largest_batch = std::max(largest_batch, batch.size());
    for (const Triangle& t : batch) {
      for (VertexIndex v : t.v) {
        if (v >= positions.size()) contract_broken = true;  // must refer to delivered vertices
      }
    }
    triangles.insert(triangles.end(), batch.begin(), batch.end());
    return {};
  }
  Status on_end() override {
    ++end_calls;
    return {};
  }

  MeshHeader header;
  std::vector<std::string> ignored, warnings;
  std::vector<VertexAttributes> attributes;
  size_t pending_attributes = 0;
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  int header_calls = 0, end_calls = 0;
  size_t largest_batch = 0;
  bool contract_broken = false;
};

struct ReadOutcome {
  Status status;
  CollectSink sink;
};

ReadOutcome read_bytes(const std::string& bytes, size_t batch_size = size_t{1} << 16,
                       const std::string& name = "test.ply") {
  auto source = ByteSource::from_memory(bytes, name);
  ReadOptions options;
  options.batch_size = batch_size;
  ReadOutcome outcome;
  outcome.status = read_ply(*source, options, outcome.sink);
  return outcome;
}

ReadOutcome read_path(const std::string& path) {
  ReadOutcome outcome;
  auto source = ByteSource::open(path);
  if (!source) {
    outcome.status = source.status();
    return outcome;
  }
  outcome.status = read_ply(**source, ReadOptions{}, outcome.sink);
  return outcome;
}

// ---- a test-side PLY encoder, independent of write_ply --------------------------------------

enum class Enc { kAscii, kLittle, kBig };
const char* enc_name(Enc enc) {
  return enc == Enc::kAscii ? "ascii" : enc == Enc::kLittle ? "binary_little_endian" : "binary_big_endian";
}

struct TestProperty {
  std::string type;        // "float", "uchar", ...
  std::string name;
  std::string count_type;  // non-empty: a list property
};

struct TestElement {
  std::string name;
  std::vector<TestProperty> properties;
  // records[i][p] = values of property p in record i (one value for a scalar).
  std::vector<std::vector<std::vector<double>>> records;
};

template <class T>
void put(std::string& out, double value, Enc enc) {
  T v = static_cast<T>(value);
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  if ((enc == Enc::kBig) == (std::endian::native == std::endian::little)) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

void put_value(std::string& out, const std::string& type, double value, Enc enc) {
  if (enc == Enc::kAscii) {
    char text[64];
    const bool is_real = type == "float" || type == "float32" || type == "double" || type == "float64";
    auto [end, ec] = (type == "float" || type == "float32") ? std::to_chars(text, text + sizeof text, static_cast<float>(value))
                     : is_real ? std::to_chars(text, text + sizeof text, value)
                               : std::to_chars(text, text + sizeof text, static_cast<int64_t>(value));
    out.append(text, end);
    out += ' ';
    return;
  }
  if (type == "char" || type == "int8") put<int8_t>(out, value, enc);
  else if (type == "uchar" || type == "uint8") put<uint8_t>(out, value, enc);
  else if (type == "short" || type == "int16") put<int16_t>(out, value, enc);
  else if (type == "ushort" || type == "uint16") put<uint16_t>(out, value, enc);
  else if (type == "int" || type == "int32") put<int32_t>(out, value, enc);
  else if (type == "uint" || type == "uint32") put<uint32_t>(out, value, enc);
  else if (type == "float" || type == "float32") put<float>(out, value, enc);
  else if (type == "double" || type == "float64") put<double>(out, value, enc);
  else ADD_FAILURE() << "test encoder: unknown type " << type;
}

std::string encode_header(const std::vector<TestElement>& elements, Enc enc) {
  std::string out = "ply\nformat " + std::string(enc_name(enc)) + " 1.0\ncomment made by ply_reader_test\n";
  out += "obj_info nothing to see\n";
  for (const TestElement& e : elements) {
    out += "element " + e.name + " " + std::to_string(e.records.size()) + "\n";
    for (const TestProperty& p : e.properties) {
      out += p.count_type.empty() ? "property " + p.type + " " + p.name + "\n"
                                  : "property list " + p.count_type + " " + p.type + " " + p.name + "\n";
    }
  }
  return out + "end_header\n";
}

std::string encode(const std::vector<TestElement>& elements, Enc enc) {
  std::string out = encode_header(elements, enc);
  for (const TestElement& e : elements) {
    for (const auto& record : e.records) {
      for (size_t p = 0; p < e.properties.size(); ++p) {
        const TestProperty& property = e.properties[p];
        if (!property.count_type.empty()) put_value(out, property.count_type, double(record[p].size()), enc);
        for (double v : record[p]) put_value(out, property.type, v, enc);
      }
      if (enc == Enc::kAscii) out.back() = '\n';
    }
  }
  return out;
}

// A plain mesh as test elements: float xyz vertices, "list <count> <index> vertex_indices" faces.
struct Polygons {
  std::vector<Vec3f> positions;
  std::vector<std::vector<uint32_t>> faces;
};

TestElement vertex_element(const std::vector<Vec3f>& positions) {
  TestElement e{"vertex", {{"float", "x", ""}, {"float", "y", ""}, {"float", "z", ""}}, {}};
  for (const Vec3f& p : positions) e.records.push_back({{p.x}, {p.y}, {p.z}});
  return e;
}

TestElement face_element(const std::vector<std::vector<uint32_t>>& faces, const std::string& count_type = "uchar",
                         const std::string& index_type = "int") {
  TestElement e{"face", {{index_type, "vertex_indices", count_type}}, {}};
  for (const auto& f : faces) e.records.push_back({std::vector<double>(f.begin(), f.end())});
  return e;
}

std::vector<Triangle> fan(const std::vector<std::vector<uint32_t>>& faces) {
  std::vector<Triangle> out;
  for (const auto& f : faces) {
    for (size_t k = 2; k < f.size(); ++k) out.push_back(Triangle{{f[0], f[k - 1], f[k]}});
  }
  return out;
}

Polygons random_polygons(uint32_t seed, size_t vertices, size_t faces, size_t max_sides) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-100.f, 100.f);
  std::uniform_int_distribution<uint32_t> index(0, static_cast<uint32_t>(vertices - 1));
  std::uniform_int_distribution<size_t> sides(3, max_sides);
  Polygons mesh;
  for (size_t i = 0; i < vertices; ++i) mesh.positions.push_back({coord(rng), coord(rng), coord(rng)});
  for (size_t f = 0; f < faces; ++f) {
    std::vector<uint32_t> face(sides(rng));
    for (uint32_t& v : face) v = index(rng);
    mesh.faces.push_back(face);
  }
  return mesh;
}

constexpr Enc kAllEncodings[] = {Enc::kAscii, Enc::kLittle, Enc::kBig};

// ---- round trips and layouts ----------------------------------------------------------------

TEST(PlyReader, RoundTripThroughWritePly) {
  const uint32_t seed = 7;
  Polygons mesh = random_polygons(seed, 300, 500, 3);
  std::vector<Triangle> triangles = fan(mesh.faces);
  std::vector<uint8_t> red(mesh.positions.size(), 200);
  std::vector<int32_t> segment(triangles.size(), -4);
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    ScratchDir dir;
    std::string path = dir.file("mesh.ply");
    {
      auto out = OutputFile::create(path, binary);
      ASSERT_TRUE(out) << out.status().to_string();
      PlyWriteOptions options;
      options.binary = binary;
      options.comments = {"round trip"};
      options.vertex_attributes.push_back({"red", std::span<const uint8_t>(red)});
      options.face_attributes.push_back({"segment", std::span<const int32_t>(segment)});
      ASSERT_TRUE(write_ply(**out, MeshView{mesh.positions, triangles}, options));
      ASSERT_TRUE((*out)->commit());
    }
    ReadOutcome r = read_path(path);
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_EQ(r.sink.positions, mesh.positions) << "seed " << seed;
    EXPECT_EQ(r.sink.triangles, triangles) << "seed " << seed;
    EXPECT_EQ(r.sink.header.format, MeshFormat::kPly);
    EXPECT_EQ(r.sink.header.declared_vertices, mesh.positions.size());
    EXPECT_EQ(r.sink.header.declared_faces, triangles.size());
    EXPECT_EQ(r.sink.end_calls, 1);
    EXPECT_FALSE(r.sink.contract_broken);
  }
}

TEST(PlyReader, HandBuiltBigEndianWithExtraPropertiesAndIntCounts) {
  // double and uchar before x, y after z; "list int int" face indices; a quad and a pentagon.
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 2, -3}, {-1.25f, 0.5f, 8}};
  std::vector<std::vector<uint32_t>> faces = {{0, 1, 2, 3}, {1, 4, 2}, {0, 1, 4, 5, 3}};
  std::string bytes = "ply\nformat binary_big_endian 1.0\nelement vertex 6\nproperty double quality\n"
                      "property uchar flags\nproperty float x\nproperty float z\nproperty float y\n"
                      "element face 3\nproperty list int int vertex_indices\nend_header\n";
  auto be = [&](auto value) {
    char b[sizeof value];
    std::memcpy(b, &value, sizeof value);
    if (std::endian::native == std::endian::little) std::reverse(b, b + sizeof value);
    bytes.append(b, sizeof value);
  };
  for (size_t i = 0; i < positions.size(); ++i) {
    be(double(i) * 1.5);
    be(uint8_t(i + 100));
    be(positions[i].x);
    be(positions[i].z);  // declared order: x z y
    be(positions[i].y);
  }
  for (const auto& f : faces) {
    be(int32_t(f.size()));
    for (uint32_t v : f) be(int32_t(v));
  }
  ReadOutcome r = read_bytes(bytes);
  ASSERT_TRUE(r.status) << r.status.to_string();
  EXPECT_EQ(r.sink.positions, positions);
  EXPECT_EQ(r.sink.triangles, fan(faces));
  EXPECT_EQ(r.sink.triangles.size(), 2u + 1u + 3u);
  EXPECT_EQ(r.sink.header.declared_faces, 3u);
}

TEST(PlyReader, RawVerticesSayWhereEachPositionLies) {
  // Little-endian float x, z, y among other scalars, vertex element first: raw_vertices names
  // offsets whose bytes are, bit for bit, what on_vertices delivered (negative zero, the largest
  // float and a subnormal among them). Big-endian, ascii, a double coordinate or another element first: none.
  std::vector<Vec3f> positions = {{0, -0.0f, 1}, {1.5f, 2, 3}, {std::numeric_limits<float>::max(), 4, -5}, {1e-40f, 7, 8}};
  auto body = [&](bool double_y) {
    std::string b;
    for (size_t i = 0; i < positions.size(); ++i) {
      const double quality = double(i) * 1.5;
      const uint8_t flags = uint8_t(i);
      b.append(reinterpret_cast<const char*>(&quality), 8);
      b.append(reinterpret_cast<const char*>(&flags), 1);
      b.append(reinterpret_cast<const char*>(&positions[i].x), 4);
      b.append(reinterpret_cast<const char*>(&positions[i].z), 4);
      if (double_y) {
        const double y = positions[i].y;
        b.append(reinterpret_cast<const char*>(&y), 8);
      } else {
        b.append(reinterpret_cast<const char*>(&positions[i].y), 4);
      }
    }
    const uint8_t three = 3;
    const int32_t v[3] = {0, 1, 2};
    b.append(reinterpret_cast<const char*>(&three), 1);
    b.append(reinterpret_cast<const char*>(v), 12);
    return b;
  };
  const std::string vertex = "element vertex 4\nproperty double quality\nproperty uchar flags\nproperty float x\n"
                             "property float z\nproperty float y\n";
  const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
  const std::string header = "ply\nformat binary_little_endian 1.0\ncomment raw\n" + vertex + face + "end_header\n";
  const std::string bytes = header + body(false);
  ReadOutcome r = read_bytes(bytes);
  ASSERT_TRUE(r.status) << r.status.to_string();
  // A big-endian machine would have to swap every value: no raw positions there.
  ASSERT_EQ(r.sink.header.raw_vertices.has_value(), std::endian::native == std::endian::little);
  if (!r.sink.header.raw_vertices) return;
  const MeshHeader::RawVertices& raw = *r.sink.header.raw_vertices;
  EXPECT_EQ(raw.first_byte, header.size());
  EXPECT_EQ(raw.stride, 8u + 1u + 4u + 4u + 4u);
  EXPECT_EQ(raw.xyz[0], 9u);
  EXPECT_EQ(raw.xyz[1], 17u);
  EXPECT_EQ(raw.xyz[2], 13u);
  ASSERT_EQ(r.sink.positions.size(), positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    const Vec3f& got = r.sink.positions[v];
    const float delivered[3] = {got.x, got.y, got.z};
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_EQ(std::memcmp(bytes.data() + raw.first_byte + v * raw.stride + raw.xyz[axis], &delivered[axis], 4), 0)
          << "vertex " << v << " axis " << axis;
    }
  }
  auto without = [&](const std::string& other, const std::string& what) {
    ReadOutcome o = read_bytes(other);
    ASSERT_TRUE(o.status) << what << ": " << o.status.to_string();
    EXPECT_FALSE(o.sink.header.raw_vertices.has_value()) << what;
  };
  // Big-endian: vertex records of zero bytes (their values do not matter here), no face.
  const std::string vertices_only(positions.size() * raw.stride, '\0');
  without("ply\nformat binary_big_endian 1.0\n" + vertex + "element face 0\nproperty list uchar int vertex_indices\nend_header\n" +
              vertices_only,
          "big-endian");
  std::string wide_y = vertex;
  wide_y.replace(wide_y.find("float y"), 7, "double y");
  without("ply\nformat binary_little_endian 1.0\n" + wide_y + face + "end_header\n" + body(true), "double y");
  without("ply\nformat binary_little_endian 1.0\nelement note 1\nproperty uchar n\n" + vertex + face + "end_header\n" +
              std::string(1, '\x07') + body(false),
          "another element first");
  without("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 0\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n",
          "ascii");
}

TEST(PlyReader, PolygonsAreFanTriangulatedInEveryEncoding) {
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 1, 0}, {5, 5, 5}};
  std::vector<std::vector<uint32_t>> faces = {{0, 1, 2, 3}, {0, 1, 2, 3, 4}, {5, 4, 3}, {0, 1, 2, 3, 4, 5}};
  std::vector<Triangle> expected = {{{0, 1, 2}}, {{0, 2, 3}},                           // quad
                                    {{0, 1, 2}}, {{0, 2, 3}}, {{0, 3, 4}},              // pentagon
                                    {{5, 4, 3}},                                        // triangle
                                    {{0, 1, 2}}, {{0, 2, 3}}, {{0, 3, 4}}, {{0, 4, 5}}};  // hexagon
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    ReadOutcome r = read_bytes(encode({vertex_element(positions), face_element(faces)}, enc));
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_EQ(r.sink.positions, positions);
    EXPECT_EQ(r.sink.triangles, expected);
  }
}

TEST(PlyReader, SkipsOtherElementsAndPropertiesIncludingLists) {
  std::vector<Vec3f> positions = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {-1, -2, -3}};
  std::vector<std::vector<uint32_t>> faces = {{0, 1, 2}, {3, 2, 1, 0}};
  TestElement material{"material", {{"uchar", "ambient_red", ""}, {"float", "names", "ushort"}, {"double", "k", ""}}, {}};
  material.records = {{{1}, {1.5, 2.5, 3.5}, {0.25}}, {{2}, {}, {0.5}}};
  TestElement vertex{"vertex",
                     {{"short", "s", ""}, {"float", "nx", ""}, {"double", "z", ""}, {"uint16", "tag", "uchar"},
                      {"float", "x", ""}, {"int8", "c", ""}, {"float64", "y", ""}, {"uint", "u", ""}},
                     {}};
  for (const Vec3f& p : positions) {
    vertex.records.push_back({{-7}, {0.5}, {p.z}, {1, 2, 3}, {p.x}, {-1}, {p.y}, {4000000000.0}});
  }
  TestElement edge{"edge", {{"int", "vertex1", ""}, {"int", "vertex2", ""}, {"uchar", "red", ""}}, {}};
  edge.records = {{{0}, {1}, {255}}, {{1}, {2}, {0}}, {{2}, {3}, {7}}};
  TestElement face{"face",
                   {{"uchar", "red", ""}, {"float", "texcoord", "uchar"}, {"uint", "vertex_index", "ushort"},
                    {"int", "segment", ""}},
                   {}};
  for (const auto& f : faces) {
    face.records.push_back({{9}, {0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, std::vector<double>(f.begin(), f.end()), {-5}});
  }
  TestElement trailer{"camera", {{"float", "view", "int"}, {"uchar", "id", ""}}, {}};
  trailer.records = {{{1, 2, 3, 4}, {1}}};
  TestElement empty{"nothing", {}, {}};
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    ReadOutcome r = read_bytes(encode({material, vertex, edge, face, trailer}, enc));
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_EQ(r.sink.positions, positions);
    EXPECT_EQ(r.sink.triangles, fan(faces));
    EXPECT_EQ(r.sink.end_calls, 1);
  }
}

TEST(PlyReader, AcceptsEveryIntegerTypeForCountsAndIndices) {
  Polygons mesh = random_polygons(11, 100, 60, 6);
  const char* count_types[] = {"char", "uchar", "short", "ushort", "int", "uint", "int8", "uint8", "int16", "uint16", "int32", "uint32"};
  const char* index_types[] = {"uchar", "char", "short", "ushort", "int", "uint", "int32", "uint32"};
  for (Enc enc : kAllEncodings) {
    for (const char* count_type : count_types) {
      for (const char* index_type : index_types) {
        SCOPED_TRACE(std::string(enc_name(enc)) + " " + count_type + " " + index_type);
        ReadOutcome r = read_bytes(encode({vertex_element(mesh.positions), face_element(mesh.faces, count_type, index_type)}, enc));
        ASSERT_TRUE(r.status) << r.status.to_string();
        EXPECT_EQ(r.sink.triangles, fan(mesh.faces));
      }
    }
  }
}

TEST(PlyReader, ConvertsEveryScalarTypeOfPositionsToFloat) {
  const char* types[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double", "float64"};
  std::vector<Vec3f> positions = {{1, 2, 3}, {100, 0, 7}, {4, 5, 6}};
  for (Enc enc : kAllEncodings) {
    for (const char* type : types) {
      SCOPED_TRACE(std::string(enc_name(enc)) + " " + type);
      TestElement v{"vertex", {{type, "x", ""}, {type, "y", ""}, {type, "z", ""}}, {}};
      for (const Vec3f& p : positions) v.records.push_back({{p.x}, {p.y}, {p.z}});
      ReadOutcome r = read_bytes(encode({v, face_element({{0, 1, 2}})}, enc));
      ASSERT_TRUE(r.status) << r.status.to_string();
      EXPECT_EQ(r.sink.positions, positions);
    }
  }
  // Doubles are rounded to the nearest float.
  TestElement v{"vertex", {{"double", "x", ""}, {"double", "y", ""}, {"double", "z", ""}}, {{{0.1}, {1e-3}, {123456.789}}}};
  for (Enc enc : kAllEncodings) {
    ReadOutcome r = read_bytes(encode({v}, enc));
    ASSERT_TRUE(r.status) << r.status.to_string();
    ASSERT_EQ(r.sink.positions.size(), 1u);
    EXPECT_EQ(r.sink.positions[0], (Vec3f{0.1f, 1e-3f, 123456.789f})) << enc_name(enc);
  }
}

// Colours (uchar with alpha, ushort, or float), normals and texture coordinates under the
// names exporters use, in every encoding, in fixed records and beside a list property (the
// general path); other vertex properties are named as ignored.
TEST(PlyReader, DeliversColoursNormalsAndTextureCoordinates) {
  const std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (Enc enc : kAllEncodings) {
    for (const std::string colour_type : {"uchar", "ushort", "float"}) {
      for (bool with_list : {false, true}) {
        SCOPED_TRACE(std::string(enc_name(enc)) + " " + colour_type + (with_list ? " list" : ""));
        const double full = colour_type == "uchar" ? 255 : colour_type == "ushort" ? 65535 : 1;
        TestElement vertices{"vertex",
                             {{"float", "x", ""}, {"float", "quality", ""}, {"float", "y", ""}, {"float", "z", ""},
                              {"float", "nx", ""}, {"float", "ny", ""}, {"float", "nz", ""},
                              {colour_type, "red", ""}, {colour_type, "green", ""}, {colour_type, "blue", ""},
                              {colour_type, "alpha", ""}, {"float", "s", ""}, {"float", "t", ""}},
                             {}};
        if (with_list) vertices.properties.push_back({"int", "ids", "uchar"});
        for (size_t i = 0; i < positions.size(); ++i) {
          const double k = double(i);
          vertices.records.push_back({{positions[i].x}, {0.5}, {positions[i].y}, {positions[i].z},
                                      {k}, {-k}, {0.25}, {full}, {k * 51 * full / 255}, {0}, {full},
                                      {0.125 * k}, {1 - 0.125 * k}});
          if (with_list) vertices.records.back().push_back({1, 2});
        }
        ReadOutcome r = read_bytes(encode({vertices, face_element({{0, 1, 2}, {0, 2, 3}})}, enc), 3);
        ASSERT_TRUE(r.status) << r.status.to_string();
        EXPECT_FALSE(r.sink.contract_broken);
        EXPECT_EQ(r.sink.header.attributes, (AttributeKinds{true, true, true}));
        const std::vector<std::string> ignored = with_list ? std::vector<std::string>{"quality", "ids"}
                                                           : std::vector<std::string>{"quality"};
        EXPECT_EQ(r.sink.ignored, ignored);
        EXPECT_EQ(r.sink.positions, positions);
        ASSERT_EQ(r.sink.attributes.size(), positions.size());
        for (size_t i = 0; i < positions.size(); ++i) {
          const VertexAttributes& a = r.sink.attributes[i];
          const float k = float(i);
          EXPECT_EQ(a.normal, (Vec3f{k, -k, 0.25f})) << i;
          EXPECT_FLOAT_EQ(a.color.r, 1) << i;
          EXPECT_NEAR(a.color.g, k * 51 / 255, 1e-6) << i;
          EXPECT_FLOAT_EQ(a.color.b, 0) << i;
          EXPECT_FLOAT_EQ(a.color.a, 1) << i;
          EXPECT_EQ(a.texcoord, (Vec2f{0.125f * k, 1 - 0.125f * k})) << i;
        }
      }
    }
  }
  // A kind counts only whole: red and green without blue, or nx without ny and nz, are ignored;
  // alpha is optional (opaque).
  TestElement partial{"vertex",
                      {{"float", "x", ""}, {"float", "y", ""}, {"float", "z", ""}, {"uchar", "red", ""},
                       {"uchar", "green", ""}, {"float", "nx", ""}},
                      {{{0}, {0}, {0}, {1}, {2}, {3}}}};
  ReadOutcome r = read_bytes(encode({partial}, Enc::kLittle));
  ASSERT_TRUE(r.status) << r.status.to_string();
  EXPECT_FALSE(r.sink.header.attributes.any());
  EXPECT_EQ(r.sink.ignored, (std::vector<std::string>{"red", "green", "nx"}));
  EXPECT_TRUE(r.sink.attributes.empty());
  TestElement rgb{"vertex",
                  {{"float", "x", ""}, {"float", "y", ""}, {"float", "z", ""}, {"uchar", "red", ""},
                   {"uchar", "green", ""}, {"uchar", "blue", ""}},
                  {{{0}, {0}, {0}, {255}, {0}, {51}}}};
  r = read_bytes(encode({rgb}, Enc::kAscii));
  ASSERT_TRUE(r.status) << r.status.to_string();
  EXPECT_EQ(r.sink.header.attributes, (AttributeKinds{false, true, false}));
  ASSERT_EQ(r.sink.attributes.size(), 1u);
  EXPECT_EQ(r.sink.attributes[0].color, (Color{1, 0, 0.2f, 1}));
  // A normal that is not a finite number is refused like a position.
  for (Enc enc : kAllEncodings) {
    TestElement bad{"vertex",
                    {{"float", "x", ""}, {"float", "y", ""}, {"float", "z", ""}, {"float", "nx", ""},
                     {"float", "ny", ""}, {"float", "nz", ""}},
                    {{{0}, {0}, {0}, {0}, {0}, {1}}, {{1}, {0}, {0}, {std::nan("")}, {0}, {1}}}};
    ReadOutcome refused = read_bytes(encode({bad}, enc));
    ASSERT_FALSE(refused.status) << enc_name(enc);
    EXPECT_EQ(refused.status.code(), Code::kBadInput);
    EXPECT_NE(refused.status.message().find("vertex 1 has a normal, colour or texture coordinate that is not a finite number"),
              std::string::npos)
        << refused.status.to_string();
  }
}

TEST(PlyReader, PointCloudWithoutFacesDeclaresZeroFaces) {
  std::vector<Vec3f> positions = {{1, 2, 3}, {4, 5, 6}};
  for (Enc enc : kAllEncodings) {
    ReadOutcome r = read_bytes(encode({vertex_element(positions)}, enc));
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_EQ(r.sink.positions, positions);
    EXPECT_TRUE(r.sink.triangles.empty());
    EXPECT_EQ(r.sink.header.declared_faces, 0u);
  }
}

TEST(PlyReader, DeliversBoundedBatches) {
  Polygons mesh = random_polygons(3, 1000, 700, 5);
  for (Enc enc : kAllEncodings) {
    for (size_t batch : {size_t{1}, size_t{7}, size_t{1000}}) {
      SCOPED_TRACE(std::string(enc_name(enc)) + " batch " + std::to_string(batch));
      ReadOutcome r = read_bytes(encode({vertex_element(mesh.positions), face_element(mesh.faces)}, enc), batch);
      ASSERT_TRUE(r.status) << r.status.to_string();
      EXPECT_LE(r.sink.largest_batch, batch);
      EXPECT_EQ(r.sink.positions, mesh.positions);
      EXPECT_EQ(r.sink.triangles, fan(mesh.faces));
      EXPECT_FALSE(r.sink.contract_broken);
    }
  }
}

// Bigger than ByteSource's window, read from a file: records split across refills, a fast-path
// layout interrupted by polygons, compared with the same content in other layouts.
TEST(PlyReader, LargeFileAcrossWindowRefillsMatchesAllLayouts) {
  const uint32_t seed = 2024;
  Polygons mesh = random_polygons(seed, 200000, 600000, 3);
  std::mt19937 rng(seed);
  for (size_t f = 0; f < mesh.faces.size(); f += 1 + rng() % 5000) mesh.faces[f].push_back(mesh.faces[f][0] ^ 1);  // quads
  std::vector<Triangle> expected = fan(mesh.faces);
  ScratchDir dir;
  struct Layout {
    Enc enc;
    const char* count_type;
    const char* index_type;
  } layouts[] = {{Enc::kLittle, "uchar", "int"}, {Enc::kLittle, "uchar", "uint"}, {Enc::kLittle, "ushort", "int"},
                 {Enc::kBig, "uchar", "int"}, {Enc::kAscii, "uchar", "int"}};
  for (const Layout& layout : layouts) {
    SCOPED_TRACE(std::string(enc_name(layout.enc)) + " " + layout.count_type + " " + layout.index_type + " seed " +
                 std::to_string(seed));
    std::string path = dir.file("big.ply");
    testing::write_file(path, encode({vertex_element(mesh.positions), face_element(mesh.faces, layout.count_type, layout.index_type)}, layout.enc));
    ASSERT_GT(std::filesystem::file_size(path), 2 * ByteSource::kMaxWindow);
    ReadOutcome r = read_path(path);
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_TRUE(r.sink.positions == mesh.positions);
    EXPECT_TRUE(r.sink.triangles == expected);
    EXPECT_FALSE(r.sink.contract_broken);
  }
}

// ---- real fixtures --------------------------------------------------------------------------

TEST(PlyReader, ReadsTheBunnyFixture) {
  ReadOutcome r = read_path(testing::fixture("real/bunny-lowres.ply"));
  ASSERT_TRUE(r.status) << r.status.to_string();
  EXPECT_EQ(r.sink.header.declared_vertices, 1839u);
  EXPECT_EQ(r.sink.header.declared_faces, 3674u);
  EXPECT_EQ(r.sink.positions.size(), 1839u);
  EXPECT_EQ(r.sink.triangles.size(), 3674u);  // all triangles
  EXPECT_EQ(r.sink.positions[0], (Vec3f{1.301895f, 0.122622f, 2.550061f}));
  EXPECT_FALSE(r.sink.contract_broken);
}

// A tiny OFF parse of the cow, written out as PLY in three encodings: all read identically.
TEST(PlyReader, CowFixtureReadsIdenticallyInAllEncodings) {
  std::string text = testing::read_file(testing::fixture("real/cow.off"));
  std::vector<std::string_view> tokens;
  for (size_t i = 0; i < text.size();) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    size_t j = i;
    while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j]))) ++j;
    if (j > i) tokens.emplace_back(text.data() + i, j - i);
    i = j;
  }
  ASSERT_GE(tokens.size(), 4u);
  ASSERT_EQ(tokens[0], "OFF");
  auto number = [](std::string_view t, auto& value) { std::from_chars(t.data(), t.data() + t.size(), value); };
  size_t nv = 0, nf = 0, at = 4;
  number(tokens[1], nv);
  number(tokens[2], nf);
  ASSERT_EQ(nv, 2904u);
  ASSERT_EQ(nf, 5804u);
  Polygons mesh;
  for (size_t i = 0; i < nv; ++i, at += 3) {
    Vec3f p;
    number(tokens[at], p.x);
    number(tokens[at + 1], p.y);
    number(tokens[at + 2], p.z);
    mesh.positions.push_back(p);
  }
  for (size_t f = 0; f < nf; ++f) {
    size_t n = 0;
    number(tokens[at++], n);
    std::vector<uint32_t> face(n);
    for (uint32_t& v : face) number(tokens[at++], v);
    mesh.faces.push_back(face);
  }
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    ReadOutcome r = read_bytes(encode({vertex_element(mesh.positions), face_element(mesh.faces)}, enc));
    ASSERT_TRUE(r.status) << r.status.to_string();
    EXPECT_EQ(r.sink.positions, mesh.positions);
    EXPECT_EQ(r.sink.triangles, fan(mesh.faces));
    EXPECT_EQ(r.sink.triangles.size(), 5804u);
  }
}

// ---- errors ---------------------------------------------------------------------------------

// Expects one kBadInput Status on one line, whose where is "test.ply: byte N" or "test.ply:N",
// and whose message contains fragment.
void expect_bad(const ReadOutcome& r, const std::string& fragment, const std::string& where = "") {
  ASSERT_FALSE(r.status);
  EXPECT_EQ(r.status.code(), Code::kBadInput) << r.status.to_string();
  EXPECT_EQ(r.status.to_string().find('\n'), std::string::npos) << r.status.to_string();
  EXPECT_NE(r.status.message().find(fragment), std::string::npos) << r.status.to_string();
  if (!where.empty()) {
    EXPECT_EQ(r.status.where(), where) << r.status.to_string();
  }
  EXPECT_EQ(r.sink.end_calls, 0);
}

std::string with_header(const std::string& header_lines, const std::string& body = "") {
  return "ply\nformat ascii 1.0\n" + header_lines + "end_header\n" + body;
}

TEST(PlyReader, FreeTextHeaderLinesAreSkippedWithOneWarning) {
  // Blender 2.4's exporter writes a line with no "comment" keyword.
  const std::string xyz = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                          "element face 1\nproperty list uchar int vertex_indices\n";
  const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  ReadOutcome clean = read_bytes(with_header(xyz, body));
  ASSERT_TRUE(clean.status.is_ok()) << clean.status.to_string();
  EXPECT_TRUE(clean.sink.warnings.empty());

  ReadOutcome blender = read_bytes(with_header("Created by Blender3D 247 - www.blender.org, source file: \n" + xyz, body));
  ASSERT_TRUE(blender.status.is_ok()) << blender.status.to_string();
  EXPECT_FALSE(blender.sink.contract_broken);
  EXPECT_EQ(blender.sink.positions, clean.sink.positions);
  EXPECT_EQ(blender.sink.triangles, clean.sink.triangles);
  ASSERT_EQ(blender.sink.warnings.size(), 1u);
  EXPECT_EQ(blender.sink.warnings[0],
            "line 3: header line with no PLY keyword skipped: 'Created by Blender3D 247 - www.blender.org, source file: '");

  // Several such lines: still one warning, which counts the rest.
  ReadOutcome several = read_bytes(with_header("exported by hand\n" + xyz + "bogus line\nanother one here\n", body));
  ASSERT_TRUE(several.status.is_ok()) << several.status.to_string();
  EXPECT_EQ(several.sink.triangles, clean.sink.triangles);
  ASSERT_EQ(several.sink.warnings.size(), 1u);
  EXPECT_EQ(several.sink.warnings[0], "line 3: header line with no PLY keyword skipped: 'exported by hand' (and 2 more such lines)");
}

TEST(PlyReaderErrors, HeaderProblemsNameTheLine) {
  expect_bad(read_bytes(""), "not a PLY file", "test.ply: byte 0");
  expect_bad(read_bytes("OFF\n3 1 0\n"), "not a PLY file");
  expect_bad(read_bytes("ply\nformat binary_little_endian 2.0\nend_header\n"), "unsupported format line", "test.ply:2");
  expect_bad(read_bytes("ply\nformat binary_middle_endian 1.0\nend_header\n"), "unsupported format line");
  expect_bad(read_bytes("ply\nelement vertex 1\nproperty float x\nend_header\n"), "no format line");
  expect_bad(read_bytes("ply\nformat ascii 1.0\nelement vertex 0\n"), "file ends before end_header", "test.ply:3");
  expect_bad(read_bytes(with_header("element vertex 1\nproperty float x\nproperty float y\n", "1 2\n")),
             "has no property z");
  expect_bad(read_bytes(with_header("element vertex 1\nproperty float x\nproperty float y\nproperty list uchar float z\n")),
             "z is a list");
  expect_bad(read_bytes(with_header("element vertex 1\nproperty float128 x\n")), "unknown property type", "test.ply:4");
  expect_bad(read_bytes(with_header("element vertex 1\nproperty list float int x\n")), "count type must be an integer");
  expect_bad(read_bytes(with_header("property float x\n")), "before any element");
  expect_bad(read_bytes(with_header("element vertex -3\n")), "is not a number");
  expect_bad(read_bytes(with_header("element vertex 99999999999999999999999\n")), "is not a number");
  // A misspelled keyword on a line shaped like an element or a property changes the body.
  expect_bad(read_bytes(with_header("elemnt vertex 8\n")), "unknown header line 'elemnt vertex 8'", "test.ply:3");
  expect_bad(read_bytes(with_header("element vertex 1\npropery float x\n")), "unknown header line", "test.ply:4");
  expect_bad(read_bytes(with_header("element face 1\npropery list uchar int vertex_indices\n")), "unknown header line");
  expect_bad(read_bytes(with_header("element face 1\nproperty list uchar int vertex_indices\n")), "no element vertex");
  expect_bad(read_bytes(with_header("element face 0\nproperty list uchar int vertex_indices\nelement vertex 0\n"
                                    "property float x\nproperty float y\nproperty float z\n")),
             "element face comes before element vertex", "test.ply:3");
  const std::string xyz = "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n";
  expect_bad(read_bytes(with_header(xyz + "element face 0\nproperty uchar red\n")), "no property vertex_indices");
  expect_bad(read_bytes(with_header(xyz + "element face 0\nproperty list uchar float vertex_indices\n")),
             "must be a list of integers");
  expect_bad(read_bytes(with_header(xyz + xyz)), "declared twice");
  std::string many;
  for (int i = 0; i < 5000; ++i) many += "property float p" + std::to_string(i) + "\n";
  expect_bad(read_bytes(with_header(xyz + many)), "more than 4096");
}

TEST(PlyReaderErrors, BodyProblemsInEveryEncoding) {
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    expect_bad(read_bytes(encode({vertex_element(positions), face_element({{0, 1, 3}})}, enc)),
               "face #0: vertex index 3 out of range (3 vertices)");
    TestElement negative = face_element({{0, 1, 2}});
    negative.records.push_back({{2, 1, -1}});
    expect_bad(read_bytes(encode({vertex_element(positions), negative}, enc)), "face #1: vertex index -1 out of range");
    expect_bad(read_bytes(encode({vertex_element(positions), face_element({{0, 1, 2}, {0, 1}})}, enc)),
               "face #1 has 2 vertices; a face needs at least 3");
    expect_bad(read_bytes(encode({vertex_element(positions), face_element({{}})}, enc)), "has 0 vertices");
  }
  // Binary: a negative list length in a signed count type.
  std::string bytes = encode({vertex_element(positions), face_element({{0, 1, 2}}, "char")}, Enc::kLittle);
  bytes[bytes.size() - 13] = static_cast<char>(-3);
  expect_bad(read_bytes(bytes), "negative length -3");
}

TEST(PlyReaderErrors, AsciiNumbersAndLines) {
  const std::string xyz = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string faces = "element face 1\nproperty list uchar int vertex_indices\n";
  expect_bad(read_bytes(with_header(xyz, "1 2 3\n1 2 zz\n")), "element vertex #1: bad number 'zz' for z",
             "test.ply:9");
  expect_bad(read_bytes(with_header(xyz, "1 2 3\n1 2\n")), "line ends before property z");
  expect_bad(read_bytes(with_header(xyz, "1 2 3\n1 2 3 4\n")), "extra values");
  expect_bad(read_bytes(with_header(xyz, "1 2 3\n1 2 1e999\n")), "bad number");
  expect_bad(read_bytes(with_header(xyz + faces, "1 2 3\n1 2 3\n3 0 1\n")), "line ends inside list vertex_indices");
  expect_bad(read_bytes(with_header(xyz + faces, "1 2 3\n1 2 3\n3 0 1 1.5\n")), "bad vertex index '1.5'");
  expect_bad(read_bytes(with_header(xyz + faces, "1 2 3\n1 2 3\nx 0 1 1\n")), "bad list length 'x'");
  expect_bad(read_bytes(with_header(xyz, "1 2 3\n")), "file ends inside element vertex #1 (2 declared)",
             "test.ply:9");
  // Blank lines, CRLF, tabs and '+' signs are accepted.
  ReadOutcome ok = read_bytes("ply\r\nformat ascii 1.0\r\n" + xyz + "end_header\r\n\r\n+1\t2 3 \r\n\n4 -5 +6e1\r\n");
  ASSERT_TRUE(ok.status) << ok.status.to_string();
  EXPECT_EQ(ok.sink.positions, (std::vector<Vec3f>{{1, 2, 3}, {4, -5, 60}}));
}

// Decision (docs/formats.md): a vertex with a NaN or infinite coordinate (or a double beyond
// float's range) is refused, naming the vertex and its byte or line, in every layout the reader
// has: fixed float records, fixed records of other types, general records, ascii.
TEST(PlyReaderErrors, NonFiniteCoordinatesAreRefusedInEveryLayout) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (Enc enc : kAllEncodings) {
    for (double bad : {nan, inf, -inf, 1e300}) {
      for (const std::string type : {"float", "double"}) {
        for (bool with_list : {false, true}) {
          SCOPED_TRACE(std::string(enc_name(enc)) + " " + type + " " + std::to_string(bad) + (with_list ? " list" : ""));
          if (type == "float" && bad == 1e300) continue;  // not representable in the file
          if (enc == Enc::kAscii && bad == 1e300) continue;  // ascii: refused as out of range
          TestElement vertices{"vertex", {{type, "x", ""}, {type, "y", ""}, {type, "z", ""}}, {}};
          if (with_list) vertices.properties.push_back({"uchar", "extra", "uchar"});
          for (int i = 0; i < 4; ++i) {
            vertices.records.push_back({{double(i)}, {i == 2 ? bad : 0.0}, {1.0}});
            if (with_list) vertices.records.back().push_back({7});
          }
          std::string bytes = encode({vertices, face_element({{0, 1, 2}, {0, 2, 3}})}, enc);
          if (enc == Enc::kAscii) {
            // to_chars writes "nan" / "inf"; from_chars reads them back, as users' files say them.
            ASSERT_NE(bytes.find(std::isnan(bad) ? "nan" : "inf"), std::string::npos);
          }
          ReadOutcome r = read_bytes(bytes);
          expect_bad(r, "vertex 2 has a coordinate that is not a finite number");
          if (enc != Enc::kAscii) {
            const size_t record = 3 * (type == "float" ? 4 : 8) + (with_list ? 2 : 0);
            const size_t body = encode_header({vertices, face_element({{0, 1, 2}, {0, 2, 3}})}, enc).size();
            EXPECT_EQ(r.status.where(), "test.ply: byte " + std::to_string(body + 2 * record));
          } else {
            EXPECT_NE(r.status.where().find("test.ply:"), std::string::npos) << r.status.where();
          }
          EXPECT_TRUE(r.sink.triangles.empty());
        }
      }
    }
  }
}

// Decision (docs/formats.md): whitespace after the last element is ignored, anything else
// is an error, in all encodings.
TEST(PlyReaderErrors, TrailingWhitespaceIsIgnoredTrailingDataIsAnError) {
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    std::string bytes = encode({vertex_element(positions), face_element({{0, 1, 2}})}, enc);
    ReadOutcome ok = read_bytes(bytes + "\n \r\n\t\n");
    ASSERT_TRUE(ok.status) << ok.status.to_string();
    EXPECT_EQ(ok.sink.triangles.size(), 1u);
    ReadOutcome bad = read_bytes(bytes + "\n\nJUNK");
    expect_bad(bad, "unexpected data after the last element",
               enc == Enc::kAscii ? "test.ply:18" : "test.ply: byte " + std::to_string(bytes.size() + 2));
  }
}

TEST(PlyReaderErrors, HostileCountsFailWithoutAllocating) {
  // More vertices than 32-bit indices can address: refused in the header.
  expect_bad(read_bytes(with_header("element vertex 353535235358\nproperty float x\nproperty float y\nproperty float z\n")),
             "element vertex count 353535235358 is too large", "test.ply:3");
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (Enc enc : kAllEncodings) {
    SCOPED_TRACE(enc_name(enc));
    // A face count of 353535235358 with one face present: the reader runs out of data.
    TestElement faces = face_element({{0, 1, 2}});
    std::string bytes = encode({vertex_element(positions), faces}, enc);
    size_t at = bytes.find("element face 1");
    ASSERT_NE(at, std::string::npos);
    bytes.replace(at, 14, "element face 353535235358");
    ReadOutcome r = read_bytes(bytes);
    expect_bad(r, "file ends inside element face #1 (353535235358 declared)",
               enc == Enc::kAscii ? "test.ply:16" : "test.ply: byte " + std::to_string(bytes.size()));
    EXPECT_EQ(r.sink.header.declared_faces, 353535235358u);
    // A vertex count just below the limit: the error names the first missing vertex.
    bytes = encode({vertex_element(positions)}, enc);
    at = bytes.find("element vertex 3");
    bytes.replace(at, 16, "element vertex 4294967295");
    expect_bad(read_bytes(bytes), "file ends inside element vertex #3 (4294967295 declared)");
    // A skipped element whose count x record size overflows 64 bits, and a huge one that is merely absent.
    TestElement junk{"junk", {{"double", "a", ""}, {"double", "b", ""}}, {{{1}, {2}}}};
    bytes = encode({junk, vertex_element(positions)}, enc);
    at = bytes.find("element junk 1");
    bytes.replace(at, 14, "element junk 18446744073709551615");
    if (enc == Enc::kAscii) {
      expect_bad(read_bytes(bytes), "element junk #1: extra values");
    } else {
      expect_bad(read_bytes(bytes), "overflows", "test.ply: byte " + std::to_string(bytes.find("end_header\n") + 11));
    }
    bytes.replace(bytes.find("element junk 18446744073709551615"), 33, "element junk 353535235358");
    expect_bad(read_bytes(bytes), enc == Enc::kAscii ? "element junk #1" : "file ends inside element junk #");
    // An element without properties takes no bytes, whatever its count.
    bytes = encode({vertex_element(positions), face_element({{0, 1, 2}})}, enc);
    bytes.insert(bytes.find("end_header"), "element nothing 353535235358\n");
    ReadOutcome empty = read_bytes(bytes);
    ASSERT_TRUE(empty.status) << empty.status.to_string();
  }
  expect_bad(read_path(testing::fixture("bad/empty.ply")), "not a PLY file");
}

// ---- hostile bytes --------------------------------------------------------------------------

std::string small_valid_file(Enc enc) {
  std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  TestElement vertex{"vertex", {{"float", "x", ""}, {"uchar", "red", ""}, {"float", "y", ""}, {"float", "z", ""}}, {}};
  for (const Vec3f& p : positions) vertex.records.push_back({{p.x}, {17}, {p.y}, {p.z}});
  TestElement faces = face_element({{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {0, 3, 2, 1}});
  TestElement extra{"edge", {{"int", "v", "uchar"}, {"float", "w", ""}}, {{{0, 1}, {0.5}}, {{1, 2, 3}, {1}}}};
  return encode({vertex, faces, extra}, enc);
}

// A failed read must be one kBadInput line naming the source and a position.
void expect_clean_failure(const Status& status, const std::string& context) {
  ASSERT_EQ(status.code(), Code::kBadInput) << context << ": " << status.to_string();
  const std::string line = status.to_string();
  EXPECT_EQ(line.find('\n'), std::string::npos) << context << ": " << line;
  const std::string& where = status.where();
  bool located = where.starts_with("test.ply: byte ") || (where.starts_with("test.ply:") && where.size() > 9 &&
                                                           std::isdigit(static_cast<unsigned char>(where[9])));
  EXPECT_TRUE(located) << context << ": " << line;
}

TEST(PlyReaderHostile, EveryPrefixFailsCleanlyUnlessComplete) {
  for (Enc enc : kAllEncodings) {
    const std::string full = small_valid_file(enc);
    ReadOutcome whole = read_bytes(full);
    ASSERT_TRUE(whole.status) << whole.status.to_string();
    for (size_t n = 0; n < full.size(); ++n) {
      const std::string context = std::string(enc_name(enc)) + " prefix " + std::to_string(n) + " of " + std::to_string(full.size());
      ReadOutcome r = read_bytes(full.substr(0, n));
      if (r.status) {
        // Only the ascii file without its final newline is complete.
        EXPECT_TRUE(enc == Enc::kAscii && n + 1 == full.size()) << context;
        EXPECT_EQ(r.sink.positions, whole.sink.positions) << context;
        EXPECT_EQ(r.sink.triangles, whole.sink.triangles) << context;
      } else {
        expect_clean_failure(r.status, context);
        EXPECT_EQ(r.sink.end_calls, 0) << context;
      }
      EXPECT_FALSE(r.sink.contract_broken) << context;
    }
  }
}

TEST(PlyReaderHostile, CorruptedBytesNeverCrash) {
  const uint32_t seed = 1234567;
  std::mt19937 rng(seed);
  int failures = 0, successes = 0;
  for (Enc enc : kAllEncodings) {
    const std::string full = small_valid_file(enc);
    for (int trial = 0; trial < 3000; ++trial) {
      std::string bytes = full;
      int edits = 1 + static_cast<int>(rng() % 4);
      for (int k = 0; k < edits; ++k) {
        size_t at = rng() % bytes.size();
        switch (rng() % 3) {
          case 0: bytes[at] = static_cast<char>(bytes[at] ^ (1u << (rng() % 8))); break;
          case 1: bytes[at] = static_cast<char>(rng()); break;
          default: bytes[at] = "0123456789 \n-.e+"[rng() % 16]; break;
        }
      }
      const std::string context = std::string(enc_name(enc)) + " trial " + std::to_string(trial) + " seed " + std::to_string(seed);
      ReadOutcome r = read_bytes(bytes, 3);
      if (r.status) {
        ++successes;
        EXPECT_EQ(r.sink.end_calls, 1) << context;
      } else {
        ++failures;
        expect_clean_failure(r.status, context);
      }
      EXPECT_FALSE(r.sink.contract_broken) << context;
    }
  }
  EXPECT_GT(failures, 0);
  EXPECT_GT(successes, 0);  // flips inside float payloads still read
}

}  // namespace
}  // namespace gaussmesh::format
