// `gaussmesh simplify` on a coloured input, as a user runs it: two real fixtures given a colour
// that is a linear function of position, texture coordinates, normals and a property it does
// not know. Kept input vertices keep their colours; moved ones get the colour of the input
// surface under them; Google's draco_decoder reads the same colours from the .drc; unknown
// values and what the streaming engine drops are named in one warning each; --normals decides
// the normals; out of core the same from a spill of the input's vertices.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/analysis/mesh_distance.h"
#include "stream/attributes/attribute_transfer.h"
#include "stream/core/mesh.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

using format::Color;
using format::Vec3f;

std::string q(const std::string& text) { return "'" + text + "'"; }

// The colour function: each channel linear in one coordinate across the bounding box.
struct Gradient {
  Vec3f lo, hi;
  float channel(const Vec3f& p, int k) const { return ((&p.x)[k] - (&lo.x)[k]) / ((&hi.x)[k] - (&lo.x)[k]); }
  Color at(const Vec3f& p) const { return {channel(p, 0), channel(p, 1), channel(p, 2), 1}; }
  // The largest change of a channel per unit of distance.
  double slope() const { return 1 / std::min({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}); }
};

Gradient gradient_of(const stream::Mesh& m) {
  Gradient g{m.positions[0], m.positions[0]};
  for (const Vec3f& p : m.positions) {
    g.lo = {std::min(g.lo.x, p.x), std::min(g.lo.y, p.y), std::min(g.lo.z, p.z)};
    g.hi = {std::max(g.hi.x, p.x), std::max(g.hi.y, p.y), std::max(g.hi.z, p.z)};
  }
  return g;
}

// The fixture with colours, texture coordinates (x and y across the box) and normals, written
// as binary PLY with one property more ("quality") that the reader does not know.
std::string coloured_copy(const std::string& name, const std::string& path, stream::Mesh& mesh) {
  auto loaded = stream::load_mesh(fixture("real/" + name));
  EXPECT_TRUE(loaded) << loaded.status().to_string();
  mesh = std::move(*loaded);
  const Gradient g = gradient_of(mesh);
  for (const Vec3f& p : mesh.positions) {
    mesh.colors.push_back(g.at(p));
    mesh.texcoords.push_back({g.channel(p, 0), g.channel(p, 1)});
  }
  mesh.normals = stream::vertex_normals(mesh.view());
  std::vector<float> quality(mesh.positions.size(), 0.5f);
  format::PlyWriteOptions options;
  options.vertex_attributes.push_back({"quality", std::span<const float>(quality)});
  auto out = format::OutputFile::create(path, true);
  EXPECT_TRUE(out);
  EXPECT_TRUE(format::write_ply(**out, mesh.view(), options).is_ok());
  EXPECT_TRUE((*out)->commit().is_ok());
  return path;
}

// A torus of about twice `vertices` faces coloured by gradient_of (colours only), written to
// `path` as PLY; `mesh` gets it.
std::string coloured_torus(const std::string& path, std::size_t vertices, stream::Mesh& mesh) {
  ShapeOptions shape;
  shape.vertices = vertices;
  mesh = make_torus(1.0, 0.35, shape);
  const Gradient g = gradient_of(mesh);
  for (const Vec3f& p : mesh.positions) mesh.colors.push_back(g.at(p));
  auto file = format::OutputFile::create(path, true);
  EXPECT_TRUE(file);
  EXPECT_TRUE(format::write_ply(**file, mesh.view(), {}).is_ok());
  EXPECT_TRUE((*file)->commit().is_ok());
  return path;
}

stream::Mesh read_mesh(const std::string& path) {
  auto m = stream::load_mesh(path);
  EXPECT_TRUE(m) << m.status().to_string();
  return m ? std::move(*m) : stream::Mesh{};
}

// The largest colour error of `out` against the colour function beyond what the surface transfer
// allows: the function at each vertex's nearest point of the input's surface, within the two
// bytes' rounding (1/255), so 1/255 + the slope times the vertex's distance to the surface; <= 0
// when every vertex is within it.
double colour_excess_over_surface(const stream::Mesh& out, const stream::TriangleTree& surface, const Gradient& g) {
  double worst = -1;
  for (std::size_t v = 0; v < out.positions.size(); ++v) {
    const Vec3f& p = out.positions[v];
    const double allowed = 1.0 / 255 + 1e-6 + std::sqrt(surface.nearest_distance_squared({p.x, p.y, p.z})) * g.slope();
    const Color want = g.at(p);
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs((&out.colors[v].r)[k] - (&want.r)[k]) - allowed);
  }
  return worst;
}

class SimplifyAttributes : public ::testing::TestWithParam<std::string> {};

TEST_P(SimplifyAttributes, ColoursFollowTheSurfaceAndDracoKeepsThem) {
  ScratchDir dir;
  stream::Mesh input;
  const std::string in = coloured_copy(GetParam(), dir.file("in.ply"), input);
  const Gradient g = gradient_of(input);
  const stream::TriangleTree surface(input.view());
  for (const std::string target : {"", " --ratio 0.1", " --ratio 0.01"}) {
    SCOPED_TRACE(GetParam() + target);
    const std::string ply = dir.file("out.ply"), drc = dir.file("out.drc");
    auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(ply) + target);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.err.find("gaussmesh: " + in + ": warning: vertex values not understood and not kept: quality\n"), 0u)
        << run.err;
    EXPECT_EQ(run.err.find("warning:", run.err.find("warning:") + 1), std::string::npos) << run.err;  // one warning
    const stream::Mesh out = read_mesh(ply);
    ASSERT_EQ(out.colors.size(), out.positions.size());
    ASSERT_EQ(out.texcoords.size(), out.positions.size());
    ASSERT_EQ(out.normals.size(), out.positions.size());
    // Each channel within one step of 8 bits (the input's bytes and the output's, half a step
    // each) of the function at the nearest surface point, that is of the function at the vertex
    // plus the slope times the vertex's distance.
    double worst = 0;
    for (std::size_t v = 0; v < out.positions.size(); ++v) {
      const Vec3f& p = out.positions[v];
      const double distance = std::sqrt(surface.nearest_distance_squared({p.x, p.y, p.z}));
      const Color want = g.at(p);
      for (int k = 0; k < 3; ++k) {
        const double error = std::abs((&out.colors[v].r)[k] - (&want.r)[k]);
        worst = std::max(worst, error - distance * g.slope());
        EXPECT_LE(error, 1.0 / 255 + 1e-6 + distance * g.slope()) << "vertex " << v << " channel " << k;
      }
      if (target.empty()) {
        EXPECT_LT(distance, 1e-9) << "the plain approximation keeps input vertices";
      }
    }
    std::printf("  %s%s: %zu vertices, worst colour error beyond the distance term %.4f / 255\n", GetParam().c_str(),
                target.c_str(), out.positions.size(), 255 * worst);
    // The same run to Draco, decoded by Google's draco_decoder: the same colours, in bytes.
    run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(drc) + target + " -q");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const std::string decoded = dir.file("decoded.ply");
    auto decode = run_command("draco_decoder -i " + q(drc) + " -o " + q(decoded));
    ASSERT_EQ(decode.exit_code, 0) << decode.err;
    const stream::Mesh back = read_mesh(decoded);
    ASSERT_EQ(back.colors.size(), back.positions.size());
    ASSERT_EQ(back.positions.size(), out.positions.size());
    for (std::size_t v = 0; v < back.positions.size(); ++v) {
      std::size_t nearest = 0;
      double best = 1e30;
      for (std::size_t w = 0; w < out.positions.size(); ++w) {
        const Vec3f &a = back.positions[v], &b = out.positions[w];
        const double d = (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z);
        if (d < best) best = d, nearest = w;
      }
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(format::color_byte((&back.colors[v].r)[k]), format::color_byte((&out.colors[nearest].r)[k])) << v;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Fixtures, SimplifyAttributes, ::testing::Values("homer.off", "mech-holes-shark.off"));

TEST(SimplifyAttributesCli, NormalsAreKeptComputedOrLeftOut) {
  ScratchDir dir;
  stream::Mesh input;
  const std::string in = coloured_copy("cow.off", dir.file("in.ply"), input);
  const std::string out = dir.file("out.ply");
  for (const std::string normals : {"keep", "compute", "none"}) {
    auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " -q --normals " + normals);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const stream::Mesh m = read_mesh(out);
    EXPECT_EQ(m.normals.size(), normals == "none" ? 0 : m.positions.size()) << normals;
    EXPECT_EQ(m.colors.size(), m.positions.size()) << normals;
  }
  // A plain mesh gets normals only when asked to compute them.
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(fixture("real/cow.off")) + " -o " + q(out) + " -q");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(read_mesh(out).normals.empty());
  EXPECT_EQ(read_file(out).find("property uchar red"), std::string::npos);
  run = run_command(q(gaussmesh_binary()) + " simplify " + q(fixture("real/cow.off")) + " -o " + q(out) + " -q --normals compute");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(read_mesh(out).normals.size(), read_mesh(out).positions.size());
  run = run_command(q(gaussmesh_binary()) + " simplify " + q(fixture("real/cow.off")) + " -o " + q(out) + " --normals sideways");
  EXPECT_EQ(run.exit_code, 1);
}

// Out of core the input's vertices and their attributes are spilled at the ingest: the plain
// approximation (input vertices, each taking the nearest input vertex's values) gives the in-core
// bytes, from a file and from a pipe; with a target, whether the finish collapses the input held
// whole or a Gauss approximation, it gives them too, each vertex taking the values of the surface
// under it from the partition's triangles; nothing is left in --tmp.
TEST(SimplifyAttributesCli, TheStreamingEngineKeepsThem) {
  ScratchDir dir, tmp;
  stream::Mesh input;
  const std::string in = coloured_copy("homer.off", dir.file("in.ply"), input);
  const Gradient g = gradient_of(input);
  const std::string in_core = dir.file("in-core.ply"), streamed = dir.file("streamed.ply"), piped = dir.file("piped.ply");
  const std::string budget = " --tmp " + q(tmp.path().string()) + " -q";
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(in_core) + " --engine in-core -q");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(streamed) + " --memory 16M" + budget);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = run_command("cat " + q(in) + " | " + q(gaussmesh_binary()) + " simplify - -o " + q(piped) + " --memory 16M" + budget);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(read_file(streamed), read_file(in_core));
  EXPECT_EQ(read_file(piped), read_file(in_core));
  EXPECT_EQ(read_mesh(streamed).colors.size(), read_mesh(streamed).positions.size());
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));

  // 10 %: the finish collapses the input; 0.5 %: a Gauss approximation's vertices. Under the
  // automatic budget, since the surface search is taken only when it fits beside what the
  // process holds, and a sanitizer's quarantine holds much.
  for (const std::string ratio : {"0.1", "0.005"}) {
    SCOPED_TRACE(ratio);
    const std::string target = dir.file("target.ply"), target_in_core = dir.file("target-in-core.ply");
    run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(target) + " --ratio " + ratio +
                      " --engine out-of-core --report " + q(dir.file("r.json")) + budget);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const std::string report = read_file(dir.file("r.json"));
    EXPECT_NE(report.find("\"attribute_transfer\": \"surface\""), std::string::npos);
    EXPECT_NE(report.find(ratio == "0.1" ? "\"approximation\": \"input\"" : "\"approximation\": \"gauss\""), std::string::npos);
    EXPECT_EQ(report.find("\"chunked_finish\""), std::string::npos) << "the input held whole";
    run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(target_in_core) + " --ratio " + ratio +
                      " --engine in-core -q");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(read_file(target) == read_file(target_in_core)) << "the out-of-core output differs from the in-core one";
    const stream::Mesh out = read_mesh(target);
    ASSERT_EQ(out.colors.size(), out.positions.size());
    ASSERT_EQ(out.normals.size(), out.positions.size());
    EXPECT_LE(colour_excess_over_surface(out, stream::TriangleTree(input.view()), g), 0.0);
    EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  }
}

// A chunked finish's output that streams (PLY, OBJ) holds only its vertices to take the
// attributes, so they are kept under the smallest budget: each vertex takes the values of the
// input's surface under it, from the partition's triangles, as in core; --normals compute gives
// unit normals.
TEST(SimplifyAttributesCli, AChunkedFinishStreamsItsAttributes) {
  ScratchDir dir, tmp;
  stream::Mesh input;
  const std::string in = coloured_copy("homer.off", dir.file("in.ply"), input);
  const Gradient g = gradient_of(input);
  const stream::TriangleTree surface(input.view());
  for (const std::string& format : {std::string("ply"), std::string("obj")}) {
    for (const std::string& normals : {std::string("keep"), std::string("compute")}) {
      SCOPED_TRACE(format + " " + normals);
      const std::string out = dir.file("out." + format);
      auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " --ratio 0.1 --memory 16M --normals " +
                             normals + " --tmp " + q(tmp.path().string()) + " -q --report " + q(dir.file("r.json")));
      ASSERT_EQ(run.exit_code, 0) << run.err;
      const std::string report = read_file(dir.file("r.json"));
      EXPECT_NE(report.find("\"chunked_finish\""), std::string::npos);
      EXPECT_EQ(report.find("too large to hold"), std::string::npos) << report;
      EXPECT_NE(report.find("\"attribute_transfer\": \"surface\""), std::string::npos) << report;
      const stream::Mesh m = read_mesh(out);
      ASSERT_EQ(m.colors.size(), m.positions.size());
      EXPECT_LE(colour_excess_over_surface(m, surface, g), 0.0);
      if (format == "ply") {  // (gaussmesh reads an OBJ's colours, not its vt and vn)
        ASSERT_EQ(m.texcoords.size(), m.positions.size());
        ASSERT_EQ(m.normals.size(), m.positions.size());
        for (const Vec3f& n : m.normals) EXPECT_NEAR(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z), 1.0, 1e-5);
      } else {
        const std::string text = read_file(out);
        EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1 + 3 * m.positions.size() + m.triangles.size());  // v, vt, vn, f
      }
      EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
    }
  }
}

// A chunked finish's output to Draco is gathered whole, and takes the surface's values the same
// way: a coloured torus of 100k faces to 10 % under 32 MiB (too large to collapse whole, its
// output small enough to encode), read back within 1/255 + slope times the distance.
TEST(SimplifyAttributesCli, AChunkedFinishToDracoTakesTheSurfacesValues) {
  ScratchDir dir, tmp;
  stream::Mesh torus;
  const std::string in = coloured_torus(dir.file("in.ply"), 50000, torus), out = dir.file("out.drc");
  const Gradient g = gradient_of(torus);
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " --ratio 0.1 --memory 32M --tmp " +
                         q(tmp.path().string()) + " -q --report " + q(dir.file("r.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string report = read_file(dir.file("r.json"));
  EXPECT_NE(report.find("\"chunked_finish\""), std::string::npos) << report;
  EXPECT_NE(report.find("\"attribute_transfer\": \"surface\""), std::string::npos) << report;
  const stream::Mesh m = read_mesh(out);
  ASSERT_EQ(m.colors.size(), m.positions.size());
  EXPECT_LE(colour_excess_over_surface(m, stream::TriangleTree(torus.view()), g), 0.0);
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
}

// An output whose vertices' search does not fit an explicit budget beside what the process
// holds takes the input's values in runs of vertices, each run with passes of its own over the
// input's vertices: a coloured torus of 1M faces to half of them under 32 MiB (250k output
// vertices, about 22 MB of search) keeps its colours, every vertex that of its nearest input
// vertex as one search over them all finds it, without a warning and within the budget's peak.
// Computed normals need every vertex's faces at once: those alone are left out, and said so.
TEST(SimplifyAttributesCli, AnOutputTooLargeToHoldTakesItsValuesInRuns) {
  ScratchDir dir, tmp;
  stream::Mesh torus;
  const std::string in = coloured_torus(dir.file("in.ply"), 500000, torus), out = dir.file("out.ply");
  std::vector<format::VertexAttributes> values(torus.positions.size());
  for (std::size_t v = 0; v < values.size(); ++v) values[v].color = torus.colors[v];
  const stream::VertexPassFn input = [&](const stream::VertexBatchFn& batch) {
    return batch(torus.positions, values);
  };
  for (const std::string normals : {"keep", "compute"}) {
    SCOPED_TRACE(normals);
    auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " --ratio 0.5 --memory 32M --normals " +
                           normals + " --tmp " + q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const std::string report = read_file(dir.file("r.json"));
    EXPECT_NE(report.find("\"chunked_finish\""), std::string::npos);
    EXPECT_NE(report.find("\"attribute_transfer\": \"nearest_vertex\""), std::string::npos) << report;
    EXPECT_EQ(report.find("\"attribute_runs\": 0"), std::string::npos) << report;
    EXPECT_EQ(report.find("\"attribute_runs\": 1,"), std::string::npos) << report;
    const stream::Mesh m = read_mesh(out);
    ASSERT_EQ(m.colors.size(), m.positions.size());
    ASSERT_GT(m.positions.size(), 200000u);
    auto want = stream::nearest_vertex_values(input, m.positions, stream::surface_area(m.positions, m.triangles));
    ASSERT_TRUE(want) << want.status().to_string();
    std::size_t wrong = 0;
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
      for (int k = 0; k < 3; ++k)
        wrong += format::color_byte((&m.colors[v].r)[k]) != format::color_byte((&(*want)[v].color.r)[k]);
    }
    EXPECT_EQ(wrong, 0u);
    if (normals == "keep") {
      EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << "the summary only: " << run.err;
    } else {
      EXPECT_TRUE(m.normals.empty());
      EXPECT_NE(run.err.find("warning: normals not kept: the output is too large to hold within --memory with them"),
                std::string::npos)
          << run.err;
    }
    EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  }
}

// When even the vertices do not fit an explicit budget, the run writes the output without its
// attributes and says so, once: a coloured torus of 250k faces to half of them under 16 MiB.
TEST(SimplifyAttributesCli, AnOutputTooLargeToHoldGoesWithoutThemAndSaysSo) {
  ScratchDir dir, tmp;
  stream::Mesh torus;
  const std::string in = coloured_torus(dir.file("in.ply"), 125000, torus), out = dir.file("out.ply");
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " --ratio 0.5 --memory 16M --tmp " +
                         q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(read_file(dir.file("r.json")).find("\"chunked_finish\""), std::string::npos);
  EXPECT_NE(run.err.find("warning: colours not kept: the output is too large to hold within --memory with them"), std::string::npos)
      << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 2) << "the warning and the summary: " << run.err;
  EXPECT_TRUE(read_mesh(out).colors.empty());
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
}

}  // namespace
}  // namespace gaussmesh::testing
