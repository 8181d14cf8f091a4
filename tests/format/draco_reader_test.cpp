// Tests of Draco input: round trip through write_draco, detection from content and stdin-like
// sources, and that truncated or corrupted files are one clean kBadInput error, never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

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

Status read(const std::string& bytes, Collect& sink, size_t batch = 1 << 16) {
  auto source = ByteSource::from_memory(bytes, "t.drc");
  ReadOptions options;
  options.batch_size = batch;
  return read_mesh(*source, options, sink);
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

}  // namespace
}  // namespace gaussmesh::format
