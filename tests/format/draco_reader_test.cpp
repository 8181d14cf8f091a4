// Tests of Draco input: round trip through write_draco, detection from content and stdin-like
// sources, and that truncated or corrupted files are one clean kBadInput error, never a crash;
// the counts read from the header without decoding (both methods, every bitstream version, with
// metadata), and the refusal of a decode that cannot fit ReadOptions::memory_limit.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>

#include "format/draco_header.h"
#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

struct Collect final : MeshSink {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  bool ended = false;
  Status on_vertices(std::span<const Vec3f> b) override {
    positions.insert(positions.end(), b.begin(), b.end());
    return {};
  }
  Status on_triangles(std::span<const Triangle> b) override {
    for (const auto& t : b) {
      for (auto v : t.v) {
        if (v >= positions.size()) return Status::error(Code::kProcessing, "sink", "triangle before its vertex");
      }
    }
    triangles.insert(triangles.end(), b.begin(), b.end());
    return {};
  }
  Status on_end() override {
    ended = true;
    return {};
  }
};

// A torus grid, written as Draco bytes.
std::string torus_drc(int nu, int nv, std::vector<Vec3f>* positions = nullptr) {
  std::vector<Vec3f> p;
  std::vector<Triangle> t;
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      p.push_back({float((1 + 0.3 * std::cos(v)) * std::cos(u)), float((1 + 0.3 * std::cos(v)) * std::sin(u)),
                   float(0.3 * std::sin(v))});
    }
  }
  auto id = [&](int i, int j) { return VertexIndex(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      t.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      t.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  testing::ScratchDir dir;
  auto out = OutputFile::create(dir.file("t.drc"), true);
  EXPECT_TRUE(out.is_ok());
  EXPECT_TRUE(write_draco(**out, {p, t}, {}).is_ok());
  EXPECT_TRUE((*out)->commit().is_ok());
  if (positions) *positions = p;
  return testing::read_file(dir.file("t.drc"));
}

Status read(const std::string& bytes, Collect& sink, size_t batch = 1 << 16, std::uint64_t memory_limit = 0) {
  auto source = ByteSource::from_memory(bytes, "t.drc");
  ReadOptions options;
  options.batch_size = batch;
  options.memory_limit = memory_limit;
  return read_mesh(*source, options, sink);
}

// A grid of nu x nv vertices, closed into a torus or left an open sheet (a boundary).
void grid(int nu, int nv, bool closed, std::vector<Vec3f>& p, std::vector<Triangle>& t) {
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      p.push_back({float((1 + 0.3 * std::cos(v)) * std::cos(u)), float((1 + 0.3 * std::cos(v)) * std::sin(u)),
                   float(0.3 * std::sin(v))});
    }
  }
  const int iu = closed ? nu : nu - 1, iv = closed ? nv : nv - 1;
  auto id = [&](int i, int j) { return VertexIndex((i % nu) * nv + j % nv); };
  for (int i = 0; i < iu; ++i) {
    for (int j = 0; j < iv; ++j) {
      t.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      t.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
}

// Encodes with Draco directly, choosing the method and optionally adding metadata (the mesh's,
// with nested sub-metadata, and the position attribute's).
std::string encode(const std::vector<Vec3f>& p, const std::vector<Triangle>& t, draco::MeshEncoderMethod method,
                   bool metadata, bool quantize = true) {
  draco::Mesh mesh;
  mesh.set_num_points(static_cast<uint32_t>(p.size()));
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(Vec3f), 0);
  const int id = mesh.AddAttribute(position, true, static_cast<uint32_t>(p.size()));
  mesh.attribute(id)->buffer()->Write(0, p.data(), p.size() * sizeof(Vec3f));
  for (const Triangle& f : t) mesh.AddFace({draco::PointIndex(f.v[0]), draco::PointIndex(f.v[1]), draco::PointIndex(f.v[2])});
  if (metadata) {
    auto geometry = std::make_unique<draco::GeometryMetadata>();
    geometry->AddEntryString("name", "a grid");
    auto inner = std::make_unique<draco::Metadata>();
    inner->AddEntryIntArray("sizes", {1, 2, 3});
    auto innermost = std::make_unique<draco::Metadata>();
    innermost->AddEntryDouble("scale", 0.5);
    inner->AddSubMetadata("deeper", std::move(innermost));
    geometry->AddSubMetadata("inner", std::move(inner));
    mesh.AddMetadata(std::move(geometry));
    auto attribute = std::make_unique<draco::AttributeMetadata>();
    attribute->AddEntryString("unit", "metre");
    mesh.AddAttributeMetadata(id, std::move(attribute));
  }
  draco::Encoder encoder;
  encoder.SetEncodingMethod(method);
  if (quantize) encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(mesh, &buffer).ok());
  return std::string(buffer.data(), buffer.size());
}

// Draco's unsigned varint.
void put_varint(std::string& out, std::uint32_t value) {
  do {
    out.push_back(static_cast<char>((value & 0x7f) | (value > 0x7f ? 0x80 : 0)));
    value >>= 7;
  } while (value != 0);
}

void put_u32(std::string& out, std::uint32_t value) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>(value >> (8 * k)));
}

// The start of a mesh bitstream: magic, version, triangle mesh, method, no flags.
std::string header(int major, int minor, int method) {
  std::string out = "DRACO";
  for (int b : {major, minor, 1, method, 0, 0}) out.push_back(static_cast<char>(b));
  return out;
}

TEST(DracoReader, RoundTripThroughTheWriter) {
  std::vector<Vec3f> original;
  std::string bytes = torus_drc(40, 20, &original);
  for (size_t batch : {size_t{7}, size_t{1} << 16}) {
    Collect sink;
    ASSERT_TRUE(read(bytes, sink, batch).is_ok());
    EXPECT_TRUE(sink.ended);
    EXPECT_EQ(sink.positions.size(), original.size());
    EXPECT_EQ(sink.triangles.size(), 2u * 40 * 20);
    // Positions within 14-bit quantization of the originals' range (2.6 / 2^14 per axis).
    for (const auto& q : sink.positions) {
      double best = 1e9;
      for (const auto& o : original) best = std::min(best, double(std::abs(o.x - q.x) + std::abs(o.y - q.y) + std::abs(o.z - q.z)));
      EXPECT_LT(best, 3 * 2.6 / (1 << 14));
    }
  }
}

// Decision (docs/formats.md): a point with a NaN or infinite coordinate is refused, naming it.
// Unquantized positions keep them through Draco's encoder, in both methods.
TEST(DracoReader, NonFiniteCoordinatesAreRefused) {
  std::vector<Vec3f> p;
  std::vector<Triangle> t;
  grid(6, 5, true, p, t);
  for (float bad : {std::nanf(""), INFINITY, -INFINITY}) {
    for (auto method : {draco::MESH_SEQUENTIAL_ENCODING, draco::MESH_EDGEBREAKER_ENCODING}) {
      std::vector<Vec3f> q = p;
      q[7].z = bad;
      Collect sink;
      Status s = read(encode(q, t, method, false, false), sink);
      ASSERT_FALSE(s.is_ok());
      EXPECT_EQ(s.code(), Code::kBadInput) << s.to_string();
      EXPECT_NE(s.message().find("has a coordinate that is not a finite number"), std::string::npos) << s.to_string();
      EXPECT_TRUE(sink.triangles.empty());
      EXPECT_FALSE(sink.ended);
    }
  }
}

TEST(DracoReader, DetectedFromContentWithoutAnExtension) {
  std::string bytes = torus_drc(12, 8);
  auto source = ByteSource::from_memory(bytes, "<stdin>");
  auto format = detect_format(*source);
  ASSERT_TRUE(format.is_ok());
  EXPECT_EQ(*format, MeshFormat::kDraco);
  Collect sink;
  EXPECT_TRUE(read_mesh(*source, {}, sink).is_ok());
  EXPECT_EQ(sink.triangles.size(), 2u * 12 * 8);
}

TEST(DracoReader, EveryTruncationIsOneCleanError) {
  std::string bytes = torus_drc(12, 8);
  for (size_t length = 0; length < bytes.size(); ++length) {
    Collect sink;
    Status s = read(bytes.substr(0, length), sink);
    ASSERT_FALSE(s.is_ok()) << "prefix of " << length << " bytes";
    EXPECT_EQ(s.code(), Code::kBadInput);
    EXPECT_EQ(s.to_string().find('\n'), std::string::npos);
  }
}

TEST(DracoReader, CorruptedBytesNeverCrash) {
  std::string bytes = torus_drc(12, 8);
  const unsigned seed = 4711;
  std::mt19937 rng(seed);
  size_t rejected = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::string damaged = bytes;
    for (int k = 0; k < 3; ++k) {
      size_t at = rng() % damaged.size();
      damaged[at] = static_cast<char>(rng());
    }
    Collect sink;
    Status s = read(damaged, sink);
    if (!s.is_ok()) {
      ++rejected;
      EXPECT_EQ(s.to_string().find('\n'), std::string::npos) << "seed " << seed << " trial " << trial;
    } else {
      // Whatever decodes must honour the sink contract (checked by Collect) and be complete.
      EXPECT_TRUE(sink.ended) << "seed " << seed << " trial " << trial;
    }
  }
  EXPECT_GT(rejected, 0u);
}

TEST(DracoHeader, CountsEqualTheDecodedCountsForBothMethods) {
  for (bool closed : {true, false}) {
    for (bool metadata : {false, true}) {
      for (auto method : {draco::MESH_SEQUENTIAL_ENCODING, draco::MESH_EDGEBREAKER_ENCODING}) {
        std::vector<Vec3f> p;
        std::vector<Triangle> t;
        grid(300, 40, closed, p, t);  // 12,000 points: 16-bit sequential indices
        const std::string bytes = encode(p, t, method, metadata);
        auto counts = read_draco_counts(bytes, "t.drc");
        ASSERT_TRUE(counts.is_ok()) << counts.status().to_string();
        EXPECT_EQ(counts->method, method == draco::MESH_SEQUENTIAL_ENCODING ? DracoMethod::kSequential
                                                                             : DracoMethod::kEdgebreaker);
        EXPECT_EQ(counts->version_major, 2);
        EXPECT_EQ(counts->version_minor, 2);
        Collect sink;
        ASSERT_TRUE(read(bytes, sink).is_ok());
        EXPECT_EQ(counts->faces, sink.triangles.size()) << "closed " << closed << " metadata " << metadata;
        EXPECT_EQ(counts->points, sink.positions.size()) << "closed " << closed << " metadata " << metadata;
        EXPECT_EQ(counts->faces, t.size());
      }
    }
  }
}

TEST(DracoHeader, CountsOfEveryBitstreamVersionDracoDecodes) {
  // Hand-written connectivity headers: sequential counts are uint32 before 2.2, varints from
  // 2.2; edgebreaker's are uint32 before 2.0, varints from 2.0, with a count of new vertices
  // before 2.2. Faces 70,000 and points 300 need three and two varint bytes.
  const std::uint32_t faces = 70000, points = 300;
  for (auto [major, minor] : {std::pair{1, 0}, {1, 3}, {2, 0}, {2, 1}, {2, 2}}) {
    const std::uint32_t version = std::uint32_t(major) << 8 | std::uint32_t(minor);
    std::string sequential = header(major, minor, 0);
    if (version < 0x202) {
      put_u32(sequential, faces);
      put_u32(sequential, points);
    } else {
      put_varint(sequential, faces);
      put_varint(sequential, points);
    }
    sequential.append(3 * faces, '\0');  // Draco wants room for the indices
    std::string edgebreaker = header(major, minor, 1);
    edgebreaker.push_back(2);  // valence traversal
    for (std::uint32_t value : {std::uint32_t{7}, points, faces}) {
      if (value == 7 && version >= 0x202) continue;  // new vertices: gone in 2.2
      if (version < 0x200) {
        put_u32(edgebreaker, value);
      } else {
        put_varint(edgebreaker, value);
      }
    }
    for (const std::string& bytes : {sequential, edgebreaker}) {
      auto counts = read_draco_counts(bytes, "t.drc");
      ASSERT_TRUE(counts.is_ok()) << major << "." << minor << ": " << counts.status().to_string();
      EXPECT_EQ(counts->faces, faces) << major << "." << minor;
      EXPECT_EQ(counts->points, points) << major << "." << minor;
    }
  }
}

TEST(DracoHeader, HostileHeadersAreBadInput) {
  std::string faces_past_the_end = header(2, 2, 0);
  put_varint(faces_past_the_end, 1000000);
  put_varint(faces_past_the_end, 3);
  std::string too_many_faces = header(2, 2, 1);
  too_many_faces.push_back(0);
  put_varint(too_many_faces, 3);
  put_varint(too_many_faces, 0xffffffffu);
  std::string endless_varint = header(2, 2, 1);
  endless_varint.push_back(0);
  endless_varint.append(6, '\xff');
  std::string deep_metadata = header(2, 2, 0);
  deep_metadata[10] = static_cast<char>(0x80);  // flags (little-endian, bytes 9 and 10): metadata
  deep_metadata.push_back(0);                       // no attribute metadata
  for (int level = 0; level < 100; ++level) deep_metadata += std::string("\x00\x01\x01x", 4);  // 0 entries, 1 child "x"
  std::string point_cloud = header(2, 2, 0);
  point_cloud[7] = 0;
  for (const std::string& bytes : {header(3, 0, 0), header(2, 3, 0), header(0, 9, 0), header(2, 2, 5), point_cloud,
                                   faces_past_the_end, too_many_faces, endless_varint, deep_metadata,
                                   std::string("DRACX\x02\x02\x01\x00\x00\x00")}) {
    auto counts = read_draco_counts(bytes, "t.drc");
    ASSERT_FALSE(counts.is_ok());
    EXPECT_EQ(counts.status().code(), Code::kBadInput);
    Collect sink;
    Status s = read(bytes, sink, 1 << 16, std::uint64_t{64} << 20);
    EXPECT_EQ(s.code(), Code::kBadInput) << s.to_string();
    EXPECT_EQ(s.to_string().find('\n'), std::string::npos);
  }
}

TEST(DracoHeader, EveryTruncatedHeaderIsBadInputUnderALimit) {
  for (auto method : {draco::MESH_SEQUENTIAL_ENCODING, draco::MESH_EDGEBREAKER_ENCODING}) {
    std::vector<Vec3f> p;
    std::vector<Triangle> t;
    grid(30, 20, true, p, t);
    const std::string bytes = encode(p, t, method, true);
    for (size_t length = 0; length < 64 && length < bytes.size(); ++length) {
      Collect sink;
      Status s = read(bytes.substr(0, length), sink, 1 << 16, std::uint64_t{16} << 20);
      ASSERT_EQ(s.code(), Code::kBadInput) << "prefix of " << length << " bytes: " << s.to_string();
      EXPECT_EQ(s.to_string().find('\n'), std::string::npos);
    }
  }
}

TEST(DracoReader, ADecodeOverTheLimitIsRefusedBeforeItStarts) {
  std::vector<Vec3f> p;
  std::vector<Triangle> t;
  grid(400, 100, true, p, t);  // 80,000 faces, 40,000 points: 23 to 26 MiB with the process
  for (auto method : {draco::MESH_SEQUENTIAL_ENCODING, draco::MESH_EDGEBREAKER_ENCODING}) {
    const std::string bytes = encode(p, t, method, false);
    Collect refused;
    Status s = read(bytes, refused, 1 << 16, std::uint64_t{22} << 20);
    EXPECT_EQ(s.code(), Code::kResources);
    EXPECT_TRUE(std::regex_match(s.to_string(),
                                 std::regex("t\\.drc: decoding this Draco mesh \\(80000 faces, 40000 points\\) needs "
                                            "about [0-9]+ MiB, over the --memory budget of 22 MiB")))
        << s.to_string();
    EXPECT_TRUE(refused.positions.empty() && refused.triangles.empty() && !refused.ended) << "nothing decoded";
    Collect decoded;
    ASSERT_TRUE(read(bytes, decoded, 1 << 16, std::uint64_t{32} << 20).is_ok());
    EXPECT_EQ(decoded.triangles.size(), t.size());
  }
}

TEST(DracoReader, TheLimitCountsTheFileItself) {
  // A file larger than the reader's first window whose header is hidden behind 5 MiB of
  // metadata: the counts come only once the file is whole, and the file alone, with the 20 MiB
  // counted for the process, passes 20 MiB.
  std::string bytes = header(2, 2, 0);
  bytes[10] = static_cast<char>(0x80);  // flags: metadata
  bytes.push_back(0);  // no attribute metadata
  bytes.push_back(5);  // five entries of 1 MiB
  for (int k = 0; k < 5; ++k) {
    bytes += std::string("\x01k", 2);
    put_varint(bytes, 1u << 20);
    bytes.append(1u << 20, 'v');
  }
  bytes.push_back(0);  // no sub-metadata
  put_varint(bytes, 1);
  put_varint(bytes, 3);
  bytes.append(16, '\0');
  testing::ScratchDir dir;
  {
    auto out = OutputFile::create(dir.file("t.drc"), true);
    ASSERT_TRUE(out.is_ok());
    ASSERT_TRUE((*out)->write(bytes.data(), bytes.size()).is_ok());
    ASSERT_TRUE((*out)->commit().is_ok());
  }
  Collect sink;
  ReadOptions options;
  options.memory_limit = std::uint64_t{20} << 20;
  Status s = read_mesh_file(dir.file("t.drc"), options, sink);  // a file: read a window at a time
  EXPECT_EQ(s.code(), Code::kResources) << s.to_string();
  EXPECT_NE(s.to_string().find("holding this Draco file needs about"), std::string::npos) << s.to_string();
  auto counts = read_draco_counts(bytes, "t.drc");
  ASSERT_TRUE(counts.is_ok()) << counts.status().to_string();
  EXPECT_EQ(counts->faces, 1u);
  EXPECT_EQ(counts->points, 3u);
}

}  // namespace
}  // namespace gaussmesh::format
