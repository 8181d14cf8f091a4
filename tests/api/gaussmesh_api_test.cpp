// The public API as an embedding program uses it (include/gaussmesh/gaussmesh.h only): sources
// and sinks in memory and on disk, the engine choice, errors as values, the same mesh from
// either engine.
#include <gaussmesh/gaussmesh.h>

#include <bit>
#include <cmath>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/test_util.h"

namespace gaussmesh {
namespace {

using testing::fixture;
using testing::ScratchDir;

// A closed UV sphere of (rings - 1) * segments * 2 triangles, outward-facing.
Mesh uv_sphere(std::uint32_t rings, std::uint32_t segments) {
  Mesh m;
  const double pi = std::acos(-1.0);
  m.positions.push_back({0, 0, 1});
  for (std::uint32_t r = 1; r < rings; ++r) {
    const double theta = pi * r / rings;
    for (std::uint32_t s = 0; s < segments; ++s) {
      const double phi = 2 * pi * s / segments;
      m.positions.push_back({float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)), float(std::cos(theta))});
    }
  }
  m.positions.push_back({0, 0, -1});
  const auto ring = [&](std::uint32_t r, std::uint32_t s) { return 1 + (r - 1) * segments + s % segments; };
  const VertexIndex south = static_cast<VertexIndex>(m.positions.size() - 1);
  for (std::uint32_t s = 0; s < segments; ++s) {
    m.triangles.push_back({{0, ring(1, s), ring(1, s + 1)}});
    for (std::uint32_t r = 1; r + 1 < rings; ++r) {
      m.triangles.push_back({{ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)}});
      m.triangles.push_back({{ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)}});
    }
    m.triangles.push_back({{ring(rings - 1, s), south, ring(rings - 1, s + 1)}});
  }
  return m;
}

TEST(GaussmeshApi, SimplifiesAMeshInMemoryIntoMemory) {
  const Mesh sphere = uv_sphere(40, 80);
  Mesh out;
  auto stats = simplify(Source::memory(sphere.view()), Sink::memory(&out));
  ASSERT_TRUE(stats) << stats.status().to_string();
  EXPECT_FALSE(stats->out_of_core);
  EXPECT_EQ(stats->input_faces, sphere.triangles.size());
  EXPECT_EQ(stats->output_faces, out.triangles.size());
  EXPECT_GT(out.triangles.size(), 20u);
  EXPECT_LT(out.triangles.size(), sphere.triangles.size() / 4);
  auto measured = info(Source::memory(out.view()));
  ASSERT_TRUE(measured) << measured.status().to_string();
  EXPECT_TRUE(measured->closed && measured->manifold);
  ASSERT_TRUE(measured->genus.has_value());
  EXPECT_EQ(*measured->genus, 0);
  EXPECT_NE(stats->report_json.find("\"output_faces\""), std::string::npos);
}

TEST(GaussmeshApi, BothEnginesGiveTheSameMesh) {
  ScratchDir tmp;
  for (const char* name : {"real/cow.off", "real/mech-holes-shark.off"}) {
    Mesh in_core, streamed;
    SimplifyOptions options;
    options.resources.engine = Engine::kInCore;
    auto a = simplify(Source::file(fixture(name)), Sink::memory(&in_core), options);
    ASSERT_TRUE(a) << a.status().to_string();
    options.resources.engine = Engine::kOutOfCore;
    options.resources.memory_bytes = kMinMemory;
    options.resources.tmp_dir = tmp.path().string();
    auto b = simplify(Source::file(fixture(name)), Sink::memory(&streamed), options);
    ASSERT_TRUE(b) << b.status().to_string();
    EXPECT_FALSE(a->out_of_core);
    EXPECT_TRUE(b->out_of_core);
    EXPECT_GE(b->chunks, 1u) << name;
    EXPECT_EQ(in_core.positions, streamed.positions) << name;
    EXPECT_EQ(in_core.triangles, streamed.triangles) << name;
  }
}

// An OFF fixture of triangles (the bundled ones are) read with the standard library alone.
Mesh read_triangle_off(const std::string& path) {
  std::istringstream in(testing::read_file(path));
  std::string magic;
  std::size_t vertices = 0, faces = 0, edges = 0;
  in >> magic >> vertices >> faces >> edges;
  Mesh m;
  m.positions.resize(vertices);
  for (Vec3f& p : m.positions) in >> p.x >> p.y >> p.z;
  m.triangles.resize(faces);
  for (Triangle& t : m.triangles) {
    int n = 0;
    in >> n >> t.v[0] >> t.v[1] >> t.v[2];
    EXPECT_EQ(n, 3);
  }
  EXPECT_TRUE(in) << path;
  return m;
}

// The mesh as a binary little-endian PLY file (the streaming engine reads files).
std::string write_ply_file(const Mesh& m, const std::string& path) {
  std::string bytes = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(m.positions.size()) +
                      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                      std::to_string(m.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  static_assert(std::endian::native == std::endian::little);
  bytes.append(reinterpret_cast<const char*>(m.positions.data()), m.positions.size() * sizeof(Vec3f));
  for (const Triangle& t : m.triangles) {
    bytes.push_back(3);
    bytes.append(reinterpret_cast<const char*>(t.v), sizeof t.v);
  }
  testing::write_file(path, bytes);
  return path;
}

// The run depends on the shape, not on its units: the cow scaled by a power of two (exact in
// float) from 2^-60 to 2^60 gives the same faces and the same positions up to that scale, with
// and without a face target, in both engines.
TEST(GaussmeshApi, TheOutputDoesNotDependOnTheScale) {
  ScratchDir tmp;
  const Mesh cow = read_triangle_off(fixture("real/cow.off"));
  for (double ratio : {0.0, 0.1}) {
    for (Engine engine : {Engine::kInCore, Engine::kOutOfCore}) {
      SimplifyOptions options;
      options.target.ratio = ratio;
      options.resources.engine = engine;
      options.resources.tmp_dir = tmp.path().string();
      Mesh unit;
      auto a = simplify(Source::file(write_ply_file(cow, tmp.file("unit.ply"))), Sink::memory(&unit), options);
      ASSERT_TRUE(a) << a.status().to_string();
      for (int exponent : {-60, -20, 20, 60}) {
        SCOPED_TRACE("ratio " + std::to_string(ratio) + ", scale 2^" + std::to_string(exponent));
        Mesh scaled = cow;
        for (Vec3f& p : scaled.positions) p = {std::ldexp(p.x, exponent), std::ldexp(p.y, exponent), std::ldexp(p.z, exponent)};
        Mesh out;
        auto b = simplify(Source::file(write_ply_file(scaled, tmp.file("scaled.ply"))), Sink::memory(&out), options);
        ASSERT_TRUE(b) << b.status().to_string();
        for (Vec3f& p : out.positions) p = {std::ldexp(p.x, -exponent), std::ldexp(p.y, -exponent), std::ldexp(p.z, -exponent)};
        EXPECT_EQ(out.triangles, unit.triangles);
        EXPECT_EQ(out.positions, unit.positions);
      }
    }
  }
}

// A mesh in memory with colours and texture coordinates gives them to the mesh out, one per
// vertex, the normals as asked.
TEST(GaussmeshApi, AttributesGoFromMeshToMesh) {
  Mesh sphere = uv_sphere(24, 48);
  for (const Vec3f& p : sphere.positions) {
    sphere.colors.push_back({0.5f + 0.5f * p.x, 0.5f, 0.5f - 0.5f * p.z, 1});
    sphere.texcoords.push_back({p.x, p.y});
  }
  for (Normals normals : {Normals::kKeep, Normals::kCompute, Normals::kNone}) {
    SimplifyOptions options;
    options.normals = normals;
    options.target.ratio = 0.1;
    Mesh out;
    auto stats = simplify(Source::memory(sphere.view()), Sink::memory(&out), options);
    ASSERT_TRUE(stats) << stats.status().to_string();
    EXPECT_TRUE(stats->warnings.empty());
    EXPECT_EQ(out.colors.size(), out.positions.size());
    EXPECT_EQ(out.texcoords.size(), out.positions.size());
    EXPECT_EQ(out.normals.size(), normals == Normals::kCompute ? out.positions.size() : 0u);
    for (std::size_t v = 0; v < out.positions.size(); ++v) EXPECT_NEAR(out.colors[v].g, 0.5f, 1e-6);
  }
}

TEST(GaussmeshApi, AFaceTargetGivesThatManyFacesInBothEngines) {
  ScratchDir tmp;
  Mesh in_core, streamed;
  SimplifyOptions options;
  options.target.faces = 400;
  options.resources.engine = Engine::kInCore;
  auto a = simplify(Source::file(fixture("real/knot1.off")), Sink::memory(&in_core), options);
  ASSERT_TRUE(a) << a.status().to_string();
  EXPECT_EQ(a->target_faces, 400u);
  EXPECT_EQ(a->output_faces, 400u);
  EXPECT_EQ(a->stopped_by, "target");
  EXPECT_GT(a->approximation_faces, 400u);
  auto measured = info(Source::memory(in_core.view()));
  ASSERT_TRUE(measured) << measured.status().to_string();
  EXPECT_TRUE(measured->closed && measured->manifold);
  EXPECT_EQ(measured->genus, std::optional<long long>(1));  // the knot is a torus
  options.resources.engine = Engine::kOutOfCore;
  options.resources.tmp_dir = tmp.path().string();
  auto b = simplify(Source::file(fixture("real/knot1.off")), Sink::memory(&streamed), options);
  ASSERT_TRUE(b) << b.status().to_string();
  EXPECT_EQ(in_core.positions, streamed.positions);
  EXPECT_EQ(in_core.triangles, streamed.triangles);
}

TEST(GaussmeshApi, AFilesBytesInMemoryReadAsTheFile) {
  const std::string bytes = testing::read_file(fixture("real/cow.off"));
  Mesh from_bytes, from_file;
  auto a = simplify(Source::file_bytes(bytes, "cow.off"), Sink::memory(&from_bytes));
  ASSERT_TRUE(a) << a.status().to_string();
  auto b = simplify(Source::file(fixture("real/cow.off")), Sink::memory(&from_file));
  ASSERT_TRUE(b) << b.status().to_string();
  EXPECT_EQ(from_bytes.triangles, from_file.triangles);
  EXPECT_EQ(from_bytes.positions, from_file.positions);
  auto measured = info(Source::file_bytes(bytes, "cow.off"));
  ASSERT_TRUE(measured) << measured.status().to_string();
  EXPECT_EQ(measured->format, MeshFormat::kOff);
  EXPECT_EQ(measured->faces, a->input_faces);
  // A truncated copy is bad input named by the bytes' name.
  auto truncated = info(Source::file_bytes(std::string_view(bytes).substr(0, bytes.size() / 2), "half.off"));
  ASSERT_FALSE(truncated);
  EXPECT_EQ(truncated.status().code(), Code::kBadInput);
  EXPECT_NE(truncated.status().to_string().find("half.off"), std::string::npos);
}

TEST(GaussmeshApi, EngineFollowsTheBudgetAndTheInputSize) {
  const Source small = Source::file(fixture("real/cow.off"));
  ResourceOptions automatic;
  auto choice = choose_engine(small, automatic);
  ASSERT_TRUE(choice);
  EXPECT_EQ(choice->engine, Engine::kInCore);
  EXPECT_EQ(choice->memory_bytes, auto_memory_budget());

  ResourceOptions tight;
  tight.memory_bytes = kMinMemory;  // less than the in-core working set of any mesh
  choice = choose_engine(small, tight);
  ASSERT_TRUE(choice);
  EXPECT_EQ(choice->engine, Engine::kOutOfCore);
  EXPECT_EQ(choice->memory_bytes, kMinMemory);

  choice = choose_engine(Source::standard_input(), automatic);  // size unknown: stream
  ASSERT_TRUE(choice);
  EXPECT_EQ(choice->engine, Engine::kOutOfCore);

  ResourceOptions forced;
  forced.engine = Engine::kOutOfCore;
  choice = choose_engine(small, forced);
  ASSERT_TRUE(choice);
  EXPECT_EQ(choice->engine, Engine::kOutOfCore);

  EXPECT_GE(auto_memory_budget(), kMinMemory);
  EXPECT_LE(auto_memory_budget(), std::uint64_t{64} << 20);
  EXPECT_GT(in_core_bytes(kInCoreMaxFaces), in_core_bytes(1));
}

TEST(GaussmeshApi, ErrorsAreValuesWithTheirCode) {
  ResourceOptions too_small;
  too_small.memory_bytes = 1 << 20;
  auto choice = choose_engine(Source::file(fixture("real/cow.off")), too_small);
  ASSERT_FALSE(choice);
  EXPECT_EQ(choice.status().code(), Code::kUsage);

  SimplifyOptions bad_frequency;
  bad_frequency.sampling.frequency = kMaxFrequency + 1;  // 0 is kAutoFrequency
  Mesh out;
  auto stats = simplify(Source::file(fixture("real/cow.off")), Sink::memory(&out), bad_frequency);
  ASSERT_FALSE(stats);
  EXPECT_EQ(stats.status().code(), Code::kUsage);

  for (auto set : {+[](TargetOptions& t) { t.ratio = 1.5; }, +[](TargetOptions& t) { t.max_error = -1; },
                   +[](TargetOptions& t) { t.faces = 5805; }}) {
    SimplifyOptions bad_target;
    set(bad_target.target);
    stats = simplify(Source::file(fixture("real/cow.off")), Sink::memory(&out), bad_target);
    ASSERT_FALSE(stats);
    EXPECT_EQ(stats.status().code(), Code::kUsage) << stats.status().to_string();
  }

  stats = simplify(Source::file(fixture("bad/invalid.off")), Sink::memory(&out));
  ASSERT_FALSE(stats);
  EXPECT_EQ(stats.status().code(), Code::kBadInput);
  EXPECT_NE(stats.status().where().find("invalid.off"), std::string::npos);

  Mesh broken;
  broken.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  broken.triangles = {{{0, 1, 7}}};
  stats = simplify(Source::memory(broken.view()), Sink::memory(&out));
  ASSERT_FALSE(stats);
  EXPECT_EQ(stats.status().code(), Code::kBadInput);

  SimplifyOptions streaming;
  streaming.resources.engine = Engine::kOutOfCore;
  stats = simplify(Source::memory(uv_sphere(8, 16).view()), Sink::memory(&out), streaming);
  ASSERT_FALSE(stats);
  EXPECT_EQ(stats.status().code(), Code::kUsage);
}

TEST(GaussmeshApi, WritesFilesThroughSinksAndSamplesIntoVectors) {
  ScratchDir dir;
  auto stats = simplify(Source::file(fixture("real/fandisk.off")), Sink::file(dir.file("f.ply")));
  ASSERT_TRUE(stats) << stats.status().to_string();
  auto back = info(Source::file(dir.file("f.ply")));
  ASSERT_TRUE(back) << back.status().to_string();
  EXPECT_EQ(back->format, MeshFormat::kPly);
  EXPECT_EQ(back->faces, stats->output_faces);

  std::vector<Sample> samples;
  auto sampled = sample(Source::file(fixture("real/fandisk.off")), dir.file("s.ply"), {}, &samples);
  ASSERT_TRUE(sampled) << sampled.status().to_string();
  EXPECT_EQ(samples.size(), sampled->samples);
  EXPECT_GT(samples.size(), 10u);
  auto points = info(Source::file(dir.file("s.ply")));
  ASSERT_TRUE(points) << points.status().to_string();
  EXPECT_EQ(points->vertices, samples.size());

  auto d = compare(Source::file(fixture("real/fandisk.off")), Source::file(dir.file("f.ply")));
  ASSERT_TRUE(d) << d.status().to_string();
  EXPECT_GT(d->hausdorff, 0);
  EXPECT_LT(d->pct(d->hausdorff), 8.0);
}

}  // namespace
}  // namespace gaussmesh
