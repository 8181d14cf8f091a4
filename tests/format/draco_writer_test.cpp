// Tests for format/draco_writer: encode generated meshes and the cow, decode them with the
// Draco library and with Google's draco_decoder CLI, check counts, positions and validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

using testing::ScratchDir;

struct PlainMesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  MeshView view() const { return {positions, triangles}; }
};

// Keeps everything a reader delivers.
class CollectSink final : public MeshSink {
 public:
  explicit CollectSink(PlainMesh& mesh) : mesh_(mesh) {}
  Status on_vertices(std::span<const Vec3f> batch) override {
    mesh_.positions.insert(mesh_.positions.end(), batch.begin(), batch.end());
    return {};
  }
  Status on_triangles(std::span<const Triangle> batch) override {
    mesh_.triangles.insert(mesh_.triangles.end(), batch.begin(), batch.end());
    return {};
  }

 private:
  PlainMesh& mesh_;
};

PlainMesh read_cow() {
  PlainMesh mesh;
  auto source = ByteSource::open(testing::fixture("real/cow.off"));
  EXPECT_TRUE(source.is_ok());
  if (!source) return mesh;
  CollectSink sink(mesh);
  Status read = read_off(**source, ReadOptions{}, sink);
  EXPECT_TRUE(read.is_ok()) << read.to_string();
  return mesh;
}

// A closed n x m torus grid (every quad split in two), no two vertices at one position.
PlainMesh torus(int n, int m) {
  PlainMesh mesh;
  const double kPi = 3.14159265358979;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      double u = 2 * kPi * i / n, v = 2 * kPi * j / m;
      mesh.positions.push_back({float((3 + std::cos(v)) * std::cos(u)),
                                float((3 + std::cos(v)) * std::sin(u)), float(std::sin(v))});
    }
  }
  auto id = [&](int i, int j) { return static_cast<VertexIndex>((i % n) * m + (j % m)); };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < m; ++j) {
      mesh.triangles.push_back({{id(i, j), id(i + 1, j), id(i + 1, j + 1)}});
      mesh.triangles.push_back({{id(i, j), id(i + 1, j + 1), id(i, j + 1)}});
    }
  }
  return mesh;
}

// Writes mesh to path and commits; returns the first failure.
Status write_file_draco(const std::string& path, MeshView mesh, const DracoWriteOptions& options) {
  auto out = OutputFile::create(path, true);
  if (!out) return out.status();
  GM_RETURN_IF_ERROR(write_draco(**out, mesh, options));
  return (*out)->commit();
}

// Decodes with the Draco library into plain arrays (positions per point, faces).
PlainMesh decode(const std::string& bytes) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  EXPECT_TRUE(decoded.ok()) << decoded.status().error_msg();
  PlainMesh mesh;
  if (!decoded.ok()) return mesh;
  std::unique_ptr<draco::Mesh> dm = std::move(decoded).value();
  const draco::PointAttribute* position = dm->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  EXPECT_NE(position, nullptr);
  if (position == nullptr) return mesh;
  for (uint32_t p = 0; p < dm->num_points(); ++p) {
    std::array<float, 3> v{};
    position->GetMappedValue(draco::PointIndex(p), v.data());
    mesh.positions.push_back({v[0], v[1], v[2]});
  }
  for (uint32_t f = 0; f < dm->num_faces(); ++f) {
    const auto& face = dm->face(draco::FaceIndex(f));
    mesh.triangles.push_back({{face[0].value(), face[1].value(), face[2].value()}});
  }
  return mesh;
}

// Largest quantization error Draco may make: half a step over the largest extent.
double quantization_tolerance(const PlainMesh& mesh, int bits) {
  Vec3f lo = mesh.positions[0], hi = mesh.positions[0];
  for (const Vec3f& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  double range = std::max({double(hi.x) - lo.x, double(hi.y) - lo.y, double(hi.z) - lo.z});
  return 0.5 * range / ((1 << bits) - 1) * (1 + 1e-3) + 1e-6 * range;
}

// Chebyshev distance: the quantizer bounds each coordinate separately.
double distance(const Vec3f& a, const Vec3f& b) {
  return std::max({std::abs(double(a.x) - b.x), std::abs(double(a.y) - b.y), std::abs(double(a.z) - b.z)});
}

// Index of the nearest position in `in` to p (brute force: test meshes are small).
size_t nearest(const std::vector<Vec3f>& in, const Vec3f& p) {
  size_t best = 0;
  for (size_t i = 1; i < in.size(); ++i) {
    if (distance(in[i], p) < distance(in[best], p)) best = i;
  }
  return best;
}

std::set<std::array<float, 3>> unique_positions(const std::vector<Vec3f>& positions) {
  std::set<std::array<float, 3>> unique;
  for (const Vec3f& p : positions) unique.insert({p.x, p.y, p.z});
  return unique;
}

// Counts from a PLY header ("element vertex N", "element face N").
std::pair<long long, long long> ply_header_counts(const std::string& ply) {
  std::istringstream in(ply);
  std::string line;
  long long vertices = -1, faces = -1;
  while (std::getline(in, line) && line.rfind("end_header", 0) != 0) {
    std::istringstream words(line);
    std::string keyword, element;
    long long count = -1;
    words >> keyword >> element >> count;
    if (keyword == "element" && element == "vertex") vertices = count;
    if (keyword == "element" && element == "face") faces = count;
  }
  return {vertices, faces};
}

// Checks counts, every decoded point near an original vertex and the faces mapping onto the
// original faces (as vertex sets) through that matching.
void expect_round_trip(const PlainMesh& original, const PlainMesh& decoded, int bits) {
  ASSERT_EQ(decoded.positions.size(), original.positions.size());
  ASSERT_EQ(decoded.triangles.size(), original.triangles.size());
  const double tolerance = quantization_tolerance(original, bits);
  std::vector<size_t> match(decoded.positions.size());
  double worst = 0;
  for (size_t i = 0; i < decoded.positions.size(); ++i) {
    match[i] = nearest(original.positions, decoded.positions[i]);
    worst = std::max(worst, distance(original.positions[match[i]], decoded.positions[i]));
  }
  EXPECT_LE(worst, tolerance) << "qp " << bits;
  std::multiset<std::array<size_t, 3>> want, got;
  for (const Triangle& t : original.triangles) {
    std::array<size_t, 3> s = {t.v[0], t.v[1], t.v[2]};
    std::rotate(s.begin(), std::min_element(s.begin(), s.end()), s.end());
    want.insert(s);
  }
  for (const Triangle& t : decoded.triangles) {
    std::array<size_t, 3> s = {match[t.v[0]], match[t.v[1]], match[t.v[2]]};
    std::rotate(s.begin(), std::min_element(s.begin(), s.end()), s.end());
    got.insert(s);
  }
  EXPECT_TRUE(want == got) << "faces differ (orientation included)";
}

TEST(DracoWriter, TorusRoundTripsWithinQuantizationError) {
  PlainMesh mesh = torus(40, 17);
  ScratchDir dir;
  for (int bits : {8, 11, 14, 20}) {
    SCOPED_TRACE("qp " + std::to_string(bits));
    std::string path = dir.file("torus-" + std::to_string(bits) + ".drc");
    ASSERT_TRUE(write_file_draco(path, mesh.view(), {bits, 7}).is_ok());
    expect_round_trip(mesh, decode(testing::read_file(path)), bits);
  }
}

// Draco's quantizer computes in float: a box whose quantization factor or extent would leave
// float's range is written unquantized, so that such a mesh round-trips exactly instead of
// decoding to one point. Every scale from 1e-37 to corners at ±2e38 comes back within the quantization
// error of its own scale (exactly where unquantized).
TEST(DracoWriter, ExtremeScalesRoundTrip) {
  PlainMesh unit = torus(20, 9);
  ScratchDir dir;
  for (double scale : {1e-37, 1e-33, 1e-30, 1.0, 1e30, 1e37, 5e37}) {  // 5e37: corners at ±2e38
    SCOPED_TRACE("scale " + std::to_string(scale));
    PlainMesh mesh = unit;
    for (Vec3f& p : mesh.positions) p = {float(p.x * scale), float(p.y * scale), float(p.z * scale)};
    const std::string path = dir.file("scaled.drc");
    ASSERT_TRUE(write_file_draco(path, mesh.view(), {14, 7}).is_ok());
    expect_round_trip(mesh, decode(testing::read_file(path)), 14);
  }
}

TEST(DracoWriter, EveryCompressionLevelDecodes) {
  PlainMesh mesh = torus(25, 9);
  ScratchDir dir;
  for (int level = 0; level <= 10; ++level) {
    SCOPED_TRACE("cl " + std::to_string(level));
    std::string path = dir.file("cl.drc");
    ASSERT_TRUE(write_file_draco(path, mesh.view(), {14, level}).is_ok());
    expect_round_trip(mesh, decode(testing::read_file(path)), 14);
  }
}

TEST(DracoWriter, CowRoundTrips) {
  PlainMesh cow = read_cow();
  ASSERT_EQ(cow.positions.size(), 2904u);
  ASSERT_EQ(cow.triangles.size(), 5804u);
  ScratchDir dir;
  std::string path = dir.file("cow.drc");
  ASSERT_TRUE(write_file_draco(path, cow.view(), {}).is_ok());
  PlainMesh decoded = decode(testing::read_file(path));
  EXPECT_EQ(decoded.positions.size(), 2904u);
  EXPECT_EQ(decoded.triangles.size(), 5804u);
  // Every decoded point lies within the quantization error of some input vertex and back.
  const double tolerance = quantization_tolerance(cow, 14);
  for (const Vec3f& p : decoded.positions) {
    EXPECT_LE(distance(cow.positions[nearest(cow.positions, p)], p), tolerance);
  }
  for (const Vec3f& p : cow.positions) {
    EXPECT_LE(distance(decoded.positions[nearest(decoded.positions, p)], p), tolerance);
  }
}

TEST(DracoWriter, GooglesDecoderReadsTheOutput) {
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/draco_decoder"))
      << "draco_decoder missing: Debian package draco, installed by scripts/bootstrap";
  PlainMesh cow = read_cow();
  ScratchDir dir;
  std::string drc = dir.file("cow.drc"), ply = dir.file("cow.ply");
  ASSERT_TRUE(write_file_draco(drc, cow.view(), {}).is_ok());
  auto r = testing::run_command("/usr/bin/draco_decoder -i '" + drc + "' -o '" + ply + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  auto [vertices, faces] = ply_header_counts(testing::read_file(ply));
  EXPECT_EQ(vertices, 2904);
  EXPECT_EQ(faces, 5804);
}

// The figures in docs/formats.md: how many of the cow's distinct positions survive
// quantization at 8, 11 (Draco's default) and 14 bits (ours). Draco never merges points: the
// point count stays 2,904 even where positions coincide after quantization.
TEST(DracoWriter, CowVertexCollapseByQuantization) {
  PlainMesh cow = read_cow();
  const size_t distinct_in = unique_positions(cow.positions).size();
  ScratchDir dir;
  const int bits[3] = {8, 11, 14};
  size_t distinct_out[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    std::string path = dir.file("cow.drc");
    ASSERT_TRUE(write_file_draco(path, cow.view(), {bits[i], 7}).is_ok());
    PlainMesh decoded = decode(testing::read_file(path));
    EXPECT_EQ(decoded.positions.size(), cow.positions.size());
    distinct_out[i] = unique_positions(decoded.positions).size();
    std::printf("cow: qp %d keeps %zu of %zu distinct positions (%zu collapse), %zu bytes\n",
                bits[i], distinct_out[i], distinct_in, distinct_in - distinct_out[i],
                static_cast<size_t>(std::filesystem::file_size(path)));
  }
  EXPECT_LT(distinct_out[0], distinct_in) << "qp 8 (step ~1/255 of the cow) merges close vertices";
  EXPECT_LE(distinct_out[0], distinct_out[1]);
  EXPECT_LE(distinct_out[1], distinct_out[2]);
  EXPECT_EQ(distinct_out[2], distinct_in) << "qp 14 should keep every distinct cow position";
}

// What Draco 1.5 keeps of unusual input (docs/formats.md). A simplifier's output has
// none of these, so its decoded counts equal what it wrote (every .drc we write decodes with
// Google's own decoder to the same counts).
PlainMesh tetrahedron() {
  PlainMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{{0, 2, 1}}, {{0, 1, 3}}, {{0, 3, 2}}, {{1, 2, 3}}};
  return m;
}

PlainMesh encode_and_decode(const PlainMesh& mesh) {
  ScratchDir dir;
  std::string path = dir.file("odd.drc");
  Status s = write_file_draco(path, mesh.view(), {});
  EXPECT_TRUE(s.is_ok()) << s.to_string();
  return decode(testing::read_file(path));
}

TEST(DracoWriterObserved, UnreferencedVerticesAreDropped) {
  PlainMesh mesh = tetrahedron();
  mesh.positions.push_back({5, 5, 5});
  PlainMesh d = encode_and_decode(mesh);
  EXPECT_EQ(d.positions.size(), 4u);
  EXPECT_EQ(d.triangles.size(), 4u);
}

TEST(DracoWriterObserved, FacesWithARepeatedIndexAreDropped) {
  PlainMesh mesh = tetrahedron();
  mesh.triangles.push_back({{0, 0, 1}});
  PlainMesh d = encode_and_decode(mesh);
  EXPECT_EQ(d.positions.size(), 4u);
  EXPECT_EQ(d.triangles.size(), 4u);
}

TEST(DracoWriterObserved, ZeroAreaFacesAreKept) {
  // A fan of three triangles around vertex 3; the middle one (0, 2, 1) has collinear corners.
  PlainMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {1, 1, 0}};
  mesh.triangles = {{{0, 1, 3}}, {{1, 2, 3}}, {{0, 2, 1}}};
  PlainMesh d = encode_and_decode(mesh);
  EXPECT_EQ(d.positions.size(), 4u);
  EXPECT_EQ(d.triangles.size(), 3u);
}

TEST(DracoWriterObserved, CoincidentVerticesStayApart) {
  // Two triangles that touch along an edge by position only (vertices 3, 4 sit on 2, 1).
  PlainMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}};
  mesh.triangles = {{{0, 1, 2}}, {{3, 4, 5}}};
  PlainMesh d = encode_and_decode(mesh);
  EXPECT_EQ(d.positions.size(), 6u);
  EXPECT_EQ(d.triangles.size(), 2u);
}

TEST(DracoWriterObserved, NonManifoldEdgesSplitVertices) {
  // A duplicated face puts three faces on each of its edges: Draco keeps every face but
  // splits the vertices of those edges into extra points.
  PlainMesh mesh = tetrahedron();
  mesh.triangles.push_back({{1, 3, 0}});
  PlainMesh d = encode_and_decode(mesh);
  EXPECT_EQ(d.triangles.size(), 5u);
  EXPECT_GT(d.positions.size(), 4u);
  std::printf("tetrahedron + duplicate face: %zu points, %zu faces after decoding\n",
              d.positions.size(), d.triangles.size());
}

TEST(DracoWriter, RejectsBadOptionsAndInput) {
  PlainMesh mesh = torus(6, 5);
  ScratchDir dir;
  std::string path = dir.file("bad.drc");
  struct Case {
    DracoWriteOptions options;
    Code code;
  };
  for (Case c : {Case{{0, 7}, Code::kUsage}, Case{{31, 7}, Code::kUsage}, Case{{14, -1}, Code::kUsage},
                 Case{{14, 11}, Code::kUsage}}) {
    Status s = write_file_draco(path, mesh.view(), c.options);
    EXPECT_EQ(s.code(), c.code) << c.options.quantization_bits << " " << c.options.compression_level;
  }
  // qp 30 is valid but Draco's encoder then takes ~20 s and GBs whatever the mesh size
  // (docs/formats.md), so the upper end is exercised at 22.
  for (int bits : {1, 22}) {
    Status s = write_file_draco(path, mesh.view(), {bits, 7});
    EXPECT_TRUE(s.is_ok()) << "qp " << bits << ": " << s.to_string();
  }
  std::filesystem::remove(path);

  PlainMesh empty;
  EXPECT_EQ(write_file_draco(path, empty.view(), {}).code(), Code::kProcessing);
  PlainMesh points_only;
  points_only.positions = mesh.positions;
  EXPECT_EQ(write_file_draco(path, points_only.view(), {}).code(), Code::kProcessing);
  // Faces exist but all repeat an index: Draco's own refusal ("All triangles are
  // degenerate.") comes back as a kProcessing Status naming the file.
  PlainMesh all_degenerate;
  all_degenerate.positions = {{0, 0, 0}, {1, 0, 0}};
  all_degenerate.triangles = {{{0, 0, 1}}, {{1, 1, 0}}};
  Status degenerate = write_file_draco(path, all_degenerate.view(), {});
  EXPECT_EQ(degenerate.code(), Code::kProcessing);
  EXPECT_NE(degenerate.to_string().find("Draco"), std::string::npos) << degenerate.to_string();
  PlainMesh out_of_range = mesh;
  out_of_range.triangles.push_back({{0, 1, static_cast<VertexIndex>(mesh.positions.size())}});
  Status s = write_file_draco(path, out_of_range.view(), {});
  EXPECT_EQ(s.code(), Code::kProcessing);
  EXPECT_NE(s.to_string().find("bad.drc"), std::string::npos) << s.to_string();
  // Nothing was committed: no file, temporary or final.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace gaussmesh::format
