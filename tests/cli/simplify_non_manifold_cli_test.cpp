// The non-manifold policy (docs/cli.md, "Non-manifold input") on generated fins, bow ties and
// fans, through the real binary: `info` counts the defects; in core `simplify` splits them (a
// vertex per fan), keeps every face, counts the copies in the report and writes a manifold
// without degenerate or duplicate faces; out of core it stops with exit 3 and one line naming
// the input, leaving nothing behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

namespace fs = std::filesystem;

std::string q(const std::string& text) { return "'" + text + "'"; }
std::string binary() { return q(gaussmesh_binary()); }

Mesh torus() {
  ShapeOptions shape;
  shape.vertices = 3000;
  return make_torus(1.0, 0.35, shape);
}

// One more face on the first face's first edge, standing off the surface: an edge with three faces.
Mesh with_fin(Mesh m) {
  const Triangle t = m.triangles[0];
  const format::Vec3f a = m.positions[t.v[0]], b = m.positions[t.v[1]];
  m.positions.push_back({(a.x + b.x) / 2, (a.y + b.y) / 2, (a.z + b.z) / 2 + 0.2f});
  m.triangles.push_back({{t.v[0], t.v[1], static_cast<VertexIndex>(m.positions.size() - 1)}});
  return m;
}

// A second copy moved so that its leftmost vertex lands on the first's rightmost, and shares it:
// a vertex joining two separate fans.
Mesh bow_tie(const Mesh& m) {
  const auto by_x = [](const format::Vec3f& p, const format::Vec3f& q) { return p.x < q.x; };
  const auto right = static_cast<VertexIndex>(std::max_element(m.positions.begin(), m.positions.end(), by_x) - m.positions.begin());
  const auto left = static_cast<VertexIndex>(std::min_element(m.positions.begin(), m.positions.end(), by_x) - m.positions.begin());
  Mesh out = m;
  const auto n = static_cast<VertexIndex>(m.positions.size());
  const format::Vec3f shift{m.positions[right].x - m.positions[left].x, m.positions[right].y - m.positions[left].y,
                            m.positions[right].z - m.positions[left].z};
  for (const format::Vec3f& p : m.positions) out.positions.push_back({p.x + shift.x, p.y + shift.y, p.z + shift.z});
  for (Triangle t : m.triangles) {
    for (VertexIndex& v : t.v) v = v == left ? right : v + n;
    out.triangles.push_back(t);
  }
  return out;
}

// A small closed fan of six faces around vertex 0, away from the surface: a vertex with two fans.
Mesh with_fan(Mesh m) {
  const format::Vec3f c = m.positions[0];
  const auto base = static_cast<VertexIndex>(m.positions.size());
  for (int i = 0; i < 6; ++i) {
    const double a = 2 * M_PI * i / 6;
    m.positions.push_back({c.x + 0.05f * float(std::cos(a)), c.y + 0.05f * float(std::sin(a)), c.z + 0.15f});
  }
  for (VertexIndex i = 0; i < 6; ++i) m.triangles.push_back({{0, base + i, base + (i + 1) % 6}});
  return m;
}

// Two faces at vertex 0 that share no edge taken out: a hole whose rim passes twice through that
// vertex, which then has two fans (the meshers can carry such a vertex into the output).
Mesh with_pinched_hole(Mesh m) {
  std::vector<std::size_t> around;
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    if (std::count(std::begin(m.triangles[f].v), std::end(m.triangles[f].v), 0u) > 0) around.push_back(f);
  }
  const auto shared = [&](std::size_t a, std::size_t b) {
    int n = 0;
    for (VertexIndex v : m.triangles[a].v) n += std::count(std::begin(m.triangles[b].v), std::end(m.triangles[b].v), v);
    return n;
  };
  for (std::size_t b : around) {
    if (shared(around[0], b) == 1) {
      m.triangles.erase(m.triangles.begin() + std::max(around[0], b));
      m.triangles.erase(m.triangles.begin() + std::min(around[0], b));
      break;
    }
  }
  return m;
}

void write(const Mesh& m, const std::string& path) {
  auto out = format::OutputFile::create(path, true);
  ASSERT_TRUE(out.is_ok());
  ASSERT_TRUE(format::write_ply(**out, m.view(), {}).is_ok());
  ASSERT_TRUE((*out)->commit().is_ok());
}

nlohmann::json info(const std::string& path) {
  const auto run = run_command(binary() + " info " + q(path) + " --report -");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return nlohmann::json::parse(run.out);
}

struct Defect {
  const char* name;
  Mesh mesh;
  bool non_manifold_edge;
  int components_after;  // of the output: the defect's part comes loose and stays
};

TEST(SimplifyNonManifold, InCoreSplitsAndKeepsEveryFaceOutOfCoreStops) {
  const Mesh base = torus();
  const Defect defects[] = {{"fin", with_fin(base), true, 2},
                            {"bow tie", bow_tie(base), false, 2},
                            {"fan", with_fan(base), false, 2},
                            {"pinched hole", with_pinched_hole(base), false, 1}};
  for (const Defect& d : defects) {
    SCOPED_TRACE(d.name);
    ScratchDir dir, tmp;
    const std::string in = dir.file("in.ply");
    write(d.mesh, in);
    const nlohmann::json before = info(in);
    EXPECT_EQ(before["non_manifold_edges"].get<int>() > 0, d.non_manifold_edge);
    EXPECT_GT(before["non_manifold_vertices"].get<int>(), 0);

    for (const std::string& target : {std::string(), std::string(" --ratio 0.1")}) {
      SCOPED_TRACE(target);
      const std::string out = dir.file("out.ply");
      const auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(out) + target + " --engine in-core --report " +
                                   q(dir.file("r.json")));
      ASSERT_EQ(run.exit_code, 0) << run.err;
      EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;
      const nlohmann::json report = nlohmann::json::parse(read_file(dir.file("r.json")));
      EXPECT_GT(report["split_vertices"].get<int>(), 0);
      EXPECT_EQ(report["skipped_input_faces"], 0);
      EXPECT_FALSE(report["mesher_fallback"].get<bool>());
      const nlohmann::json after = info(out);
      EXPECT_EQ(after["components"], d.components_after);
      EXPECT_EQ(after["non_manifold_edges"], 0);
      EXPECT_EQ(after["non_manifold_vertices"], 0);
      EXPECT_EQ(after["degenerate_faces"], 0);
      EXPECT_EQ(after["duplicate_faces"], 0);
      EXPECT_TRUE(after["manifold"].get<bool>());
    }

    const std::string out = dir.file("out-of-core.ply");
    const auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(out) + " --memory 16M --tmp " + q(tmp.path().string()));
    EXPECT_EQ(run.exit_code, 3) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_EQ(run.err.rfind("gaussmesh: " + in + ": not a manifold where the out-of-core mesher needs one", 0), 0u) << run.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_TRUE(fs::is_empty(tmp.path()));
  }
}

TEST(SimplifyNonManifold, AManifoldInputHasNoWarning) {
  ScratchDir dir;
  const std::string in = dir.file("in.ply");
  write(torus(), in);
  const auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(dir.file("out.ply")) + " --engine in-core");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace gaussmesh::testing
