// `gaussmesh simplify` on textured OBJ files whose texture coordinates are given per face corner:
// a UV sphere (one seam from pole to pole, and a value per face at each pole) and a cube whose six
// sides are six tiles of an atlas (every cube edge a seam). With a target no output face crosses a
// seam (no texture stretched across one), every corner's texture coordinate is the function the
// input's follow at its position, and the surface welded by position is still closed and of genus
// 0. Without a target the run says the seams are not kept.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stream/attributes/seams.h"
#include "stream/core/mesh.h"
#include "stream/core/mesh_topology.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }

constexpr double kPi = 3.14159265358979323846;

// A UV sphere of `rings` × `segments` quads (triangles at the poles): u is the longitude / 2π,
// v is 1 - latitude / π; the column of texture coordinates at u = 1 repeats the one at u = 0.
std::string uv_sphere_obj(int rings, int segments) {
  std::string obj;
  auto vertex = [&](int i, int j) {
    if (i == 0) return 1;
    if (i == rings) return 2 + (rings - 1) * segments;
    return 2 + (i - 1) * segments + j % segments;
  };
  obj += "v 0 0 1\n";
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = kPi * i / rings, ph = 2 * kPi * j / segments;
      obj += "v " + std::to_string(std::sin(th) * std::cos(ph)) + " " + std::to_string(std::sin(th) * std::sin(ph)) +
             " " + std::to_string(std::cos(th)) + "\n";
    }
  obj += "v 0 0 -1\n";
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j)
      obj += "vt " + std::to_string(double(j) / segments) + " " + std::to_string(1 - double(i) / rings) + "\n";
  auto corner = [&](int i, int j) {
    return std::to_string(vertex(i, j)) + "/" + std::to_string(1 + i * (segments + 1) + j);
  };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      // A quad (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1); one triangle at each pole.
      if (i < rings - 1) obj += "f " + corner(i, j) + " " + corner(i + 1, j) + " " + corner(i + 1, j + 1) + "\n";
      if (i > 0 && i < rings - 1) obj += "f " + corner(i, j) + " " + corner(i + 1, j + 1) + " " + corner(i, j + 1) + "\n";
      if (i == rings - 1) obj += "f " + corner(i, j) + " " + corner(i + 1, j) + " " + corner(i, j + 1) + "\n";
    }
  return obj;
}

// A cube [-1, 1]^3, each side an n × n grid, each side its own tile of a 3 × 2 atlas: side s
// maps its two in-plane coordinates to ((s % 3 + (a + 1) / 2) / 3, (s / 3 + (b + 1) / 2) / 2).
std::string atlas_cube_obj(int n) {
  std::string obj;
  int vertices = 0, texcoords = 0;
  for (int s = 0; s < 6; ++s) {
    const int axis = s % 3;
    const double sign = s < 3 ? 1 : -1;
    const int base_v = vertices, base_t = texcoords;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j) {
        const double a = -1 + 2.0 * i / n, b = -1 + 2.0 * j / n;
        double p[3];
        p[axis] = sign, p[(axis + 1) % 3] = a, p[(axis + 2) % 3] = b;
        obj += "v " + std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
        obj += "vt " + std::to_string((s % 3 + (a + 1) / 2) / 3) + " " + std::to_string((s / 3 + (b + 1) / 2) / 2) + "\n";
        ++vertices, ++texcoords;
      }
    auto c = [&](int i, int j) {
      const int k = i * (n + 1) + j;
      return std::to_string(base_v + k + 1) + "/" + std::to_string(base_t + k + 1);
    };
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        // Outward: a × b points along the axis; reversed on the negative sides.
        if (sign > 0) {
          obj += "f " + c(i, j) + " " + c(i + 1, j) + " " + c(i + 1, j + 1) + "\n";
          obj += "f " + c(i, j) + " " + c(i + 1, j + 1) + " " + c(i, j + 1) + "\n";
        } else {
          obj += "f " + c(i, j) + " " + c(i + 1, j + 1) + " " + c(i + 1, j) + "\n";
          obj += "f " + c(i, j) + " " + c(i, j + 1) + " " + c(i + 1, j + 1) + "\n";
        }
      }
  }
  return obj;
}

// The UV sphere as PLY stores a textured mesh: a vertex per (ring, segment) of the grid, the
// column at u = 1 repeating the one at u = 0 and each pole a row of vertices at one place, so the
// seam and the poles are split into vertices with different texture coordinates (s, t).
std::string uv_sphere_ply(int rings, int segments) {
  std::string vertices, faces;
  int face_count = 0;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const double th = kPi * i / rings, ph = 2 * kPi * (j % segments) / segments;
      const double x = i == 0 || i == rings ? 0 : std::sin(th) * std::cos(ph), y = i == 0 || i == rings ? 0 : std::sin(th) * std::sin(ph);
      vertices += std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(std::cos(th)) + " " +
                  std::to_string(double(j) / segments) + " " + std::to_string(1 - double(i) / rings) + "\n";
    }
  auto id = [&](int i, int j) { return std::to_string(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i < rings - 1) faces += "3 " + id(i, j) + " " + id(i + 1, j) + " " + id(i + 1, j + 1) + "\n", ++face_count;
      if (i > 0 && i < rings - 1) faces += "3 " + id(i, j) + " " + id(i + 1, j + 1) + " " + id(i, j + 1) + "\n", ++face_count;
      if (i == rings - 1) faces += "3 " + id(i, j) + " " + id(i + 1, j) + " " + id(i, j + 1) + "\n", ++face_count;
    }
  return "ply\nformat ascii 1.0\nelement vertex " + std::to_string((rings + 1) * (segments + 1)) +
         "\nproperty float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\nelement face " +
         std::to_string(face_count) + "\nproperty list uchar int vertex_indices\nend_header\n" + vertices + faces;
}

stream::Mesh read_with_corners(const std::string& path) {
  format::ReadOptions options;
  options.corner_values = true;
  auto m = stream::load_mesh(path, options);
  EXPECT_TRUE(m) << m.status().to_string();
  return m ? std::move(*m) : stream::Mesh{};
}

// `in` simplified to `ratio` of its faces, as OBJ, read back with its texture coordinates.
stream::Mesh simplified(const ScratchDir& dir, const std::string& in, double ratio) {
  const std::string out = dir.file("out.obj");
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(out) + " -q --ratio " +
                         std::to_string(ratio));
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return run.exit_code == 0 ? read_with_corners(out) : stream::Mesh{};
}

// The output welded by position (its seams found again) is a closed manifold of genus 0.
void expect_closed_sphere(const stream::Mesh& out) {
  auto seams = stream::find_seams(out.view());
  ASSERT_TRUE(seams.has_value()) << "the output keeps no seam";
  EXPECT_EQ(seams->welded.triangles.size(), out.triangles.size()) << "a face lost to the weld";
  auto topology = stream::compute_topology(seams->welded.view());
  ASSERT_TRUE(topology) << topology.status().to_string();
  EXPECT_TRUE(topology->is_manifold());
  EXPECT_TRUE(topology->is_closed());
  ASSERT_TRUE(topology->genus.has_value());
  EXPECT_EQ(*topology->genus, 0);
}

// `in` simplified to 10 % with `flags`, to `dir`'s file `out`: the run and its report.
std::pair<CommandResult, nlohmann::json> tenth(const ScratchDir& dir, const std::string& in, const std::string& out,
                                               const std::string& flags) {
  auto r = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(dir.file(out)) + " --ratio 0.1 " + flags +
                       " --report " + q(dir.file(out + ".json")));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return {r, r.exit_code == 0 ? nlohmann::json::parse(read_file(dir.file(out + ".json"))) : nlohmann::json::object()};
}

// A simplified UV sphere kept its seam: no face spans more than half the texture's width, and
// welded by position it is closed, of genus 0.
void expect_seam_kept(const stream::Mesh& out) {
  ASSERT_EQ(out.texcoords.size(), out.positions.size());
  for (const auto& t : out.triangles) {
    float lo = 2, hi = -1;
    for (const auto v : t.v) lo = std::min(lo, out.texcoords[v].u), hi = std::max(hi, out.texcoords[v].u);
    EXPECT_LT(hi - lo, 0.5) << "a face across the seam";
  }
  expect_closed_sphere(out);
}

std::size_t faces_of(const std::string& obj) {
  std::size_t faces = 0;
  for (std::size_t at = 0; (at = obj.find("\nf ", at)) != std::string::npos; ++at) ++faces;
  return faces;
}

TEST(SimplifySeamsCli, NoFaceOfASphereCrossesItsSeam) {
  ScratchDir dir;
  const std::string in = dir.file("sphere.obj"), text = uv_sphere_obj(40, 80);
  write_file(in, text);
  const std::size_t input_faces = faces_of(text);
  for (const double ratio : {0.5, 0.1, 0.01}) {
    SCOPED_TRACE(ratio);
    const stream::Mesh out = simplified(dir, in, ratio);
    ASSERT_EQ(out.texcoords.size(), out.positions.size());
    const double target = std::round(ratio * double(input_faces));
    EXPECT_LE(double(out.triangles.size()), target);
    EXPECT_GE(double(out.triangles.size()), 0.99 * target - 1);
    double worst_u = 0, worst_v = 0;
    for (const auto& t : out.triangles) {
      float lo = 2, hi = -1;
      for (const auto v : t.v) {
        const auto& p = out.positions[v];
        const auto& uv = out.texcoords[v];
        lo = std::min(lo, uv.u), hi = std::max(hi, uv.u);
        if (std::hypot(p.x, p.y) > 1e-3) {  // away from the poles, u is the longitude
          const double want = std::atan2(p.y, p.x) / (2 * kPi);
          double d = 1;
          for (const double shift : {-1.0, 0.0, 1.0}) d = std::min(d, std::abs(uv.u - (want + shift)));
          worst_u = std::max(worst_u, d);
        }
        const double r = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
        worst_v = std::max(worst_v, std::abs(uv.v - (1 - std::acos(std::clamp(p.z / r, -1.0, 1.0)) / kPi)));
      }
      EXPECT_LT(hi - lo, 0.5) << "a face across the seam: u from " << lo << " to " << hi;
    }
    // Moved vertices take the input surface under them (on their side of the seam), whose faces
    // are chords of the sphere: a few thousandths at these sizes.
    std::printf("  ratio %.2f: %zu faces, worst texture coordinate error u %.4f v %.4f\n", ratio, out.triangles.size(),
                worst_u, worst_v);
    EXPECT_LT(worst_u, 0.005);
    EXPECT_LT(worst_v, 0.005);
    expect_closed_sphere(out);
  }
}

TEST(SimplifySeamsCli, EveryFaceOfAnAtlasCubeStaysInOneTile) {
  ScratchDir dir;
  const std::string in = dir.file("cube.obj"), text = atlas_cube_obj(24);
  write_file(in, text);
  const std::size_t input_faces = faces_of(text);
  for (const double ratio : {0.1, 0.01}) {
    SCOPED_TRACE(ratio);
    const stream::Mesh out = simplified(dir, in, ratio);
    ASSERT_EQ(out.texcoords.size(), out.positions.size());
    EXPECT_LE(double(out.triangles.size()), std::round(ratio * double(input_faces)));
    for (const auto& t : out.triangles) {
      // The tile of the face: the side whose plane holds all three corners.
      int side = -1;
      for (int s = 0; s < 6 && side < 0; ++s) {
        bool all = true;
        for (const auto v : t.v) all = all && std::abs((&out.positions[v].x)[s % 3] - (s < 3 ? 1 : -1)) < 1e-5;
        if (all) side = s;
      }
      ASSERT_GE(side, 0) << "a face off the cube's sides";
      for (const auto v : t.v) {
        const auto& p = out.positions[v];
        const double a = (&p.x)[(side % 3 + 1) % 3], b = (&p.x)[(side % 3 + 2) % 3];
        EXPECT_NEAR(out.texcoords[v].u, (side % 3 + (a + 1) / 2) / 3, 1e-5) << "side " << side;
        EXPECT_NEAR(out.texcoords[v].v, (side / 3 + (b + 1) / 2) / 2, 1e-5) << "side " << side;
      }
    }
    expect_closed_sphere(out);
  }
}

TEST(SimplifySeamsCli, WithoutATargetTheRunSaysTheSeamsAreNotKept) {
  ScratchDir dir;
  const std::string in = dir.file("sphere.obj");
  write_file(in, uv_sphere_obj(20, 40));
  auto run = run_command(q(gaussmesh_binary()) + " simplify " + q(in) + " -o " + q(dir.file("out.obj")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning: the input's values differ at 21 positions"), std::string::npos) << run.err;
}

// Only the in-core reader keeps per-corner values, and the engine choice's size rule (16 bytes
// of file a face) takes a textured OBJ for several times its faces. Under --engine auto the file
// is counted instead, and runs in core when that count fits the budget: here 6,240 faces, which
// with a target's finish need about 20 MiB in core, where the size rule would count ~30 MiB.
TEST(SimplifySeamsCli, AnObjThatFitsWhenCountedRunsInCoreAndKeepsItsSeams) {
  ScratchDir dir;
  const std::string in = dir.file("sphere.obj"), plain = dir.file("plain.obj"), text = uv_sphere_obj(40, 80);
  write_file(in, text);
  // The same sphere without texture coordinates in its corners ("f a/b" -> "f a").
  std::string stripped;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '/') {
      while (i + 1 < text.size() && text[i + 1] != ' ' && text[i + 1] != '\n') ++i;
      continue;
    }
    stripped += text[i];
  }
  write_file(plain, stripped);
  const auto [counted, counted_report] = tenth(dir, in, "counted.obj", "--memory 24M");
  EXPECT_FALSE(counted_report["out_of_core"].get<bool>());
  EXPECT_TRUE(counted_report["output_attributes"]["texcoords"].get<bool>());
  EXPECT_EQ(counted.err.find("vt"), std::string::npos) << counted.err;
  tenth(dir, in, "held.obj", "--engine in-core");
  EXPECT_EQ(read_file(dir.file("counted.obj")), read_file(dir.file("held.obj")));
  expect_seam_kept(read_with_corners(dir.file("counted.obj")));
  // Without corner values the file streams as the size rule says.
  EXPECT_TRUE(tenth(dir, plain, "plain.obj", "--memory 24M").second["out_of_core"].get<bool>());
  // Few faces but long lists (two million texture coordinates, 16 MB held): counted with its
  // lists, the file does not fit and streams.
  std::string lists = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 2000000; ++i) lists += "vt 0 0\n";
  write_file(dir.file("lists.obj"), lists + "f 1/1 2/2 3/3\n");
  EXPECT_TRUE(tenth(dir, dir.file("lists.obj"), "lists.ply", "--memory 24M").second["out_of_core"].get<bool>());
  // A budget the counted faces do not fit: the file streams, and says what it does not keep.
  const auto [tight, tight_report] = tenth(dir, in, "tight.obj", "--memory 16M");
  EXPECT_TRUE(tight_report["out_of_core"].get<bool>());
  EXPECT_FALSE(tight_report["output_attributes"]["texcoords"].get<bool>());
  EXPECT_NE(tight.err.find("texture coordinates (vt"), std::string::npos) << tight.err;
}

// From a pipe the same sphere is copied to a file first (it is shorter than the largest file the
// size rule holds in core), so it is counted and read as that file: in core, its seams kept, the
// file's bytes, nothing left in --tmp. Forced to stream, the pipe is not copied, and the run
// says what it does not keep.
TEST(SimplifySeamsCli, ATexturedObjFromAPipeIsReadAsTheFile) {
  ScratchDir dir, tmp;
  const std::string in = dir.file("sphere.obj");
  write_file(in, uv_sphere_obj(40, 80));
  const std::string tmp_flag = " --tmp " + q(tmp.path().string());
  tenth(dir, in, "file.obj", "--memory 24M");
  for (const std::string engine : {"", " --engine out-of-core"}) {
    SCOPED_TRACE(engine);
    auto run = run_command("cat " + q(in) + " | " + q(gaussmesh_binary()) + " simplify - -o " + q(dir.file("piped.obj")) +
                           " --ratio 0.1 --memory 24M" + engine + tmp_flag + " --report " + q(dir.file("piped.json")));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto report = nlohmann::json::parse(read_file(dir.file("piped.json")));
    EXPECT_EQ(report["out_of_core"].get<bool>(), !engine.empty());
    EXPECT_EQ(report["output_attributes"]["texcoords"].get<bool>(), engine.empty());
    EXPECT_EQ(run.err.find("texture coordinates (vt") == std::string::npos, engine.empty()) << run.err;
    if (engine.empty()) {
      EXPECT_TRUE(read_file(dir.file("piped.obj")) == read_file(dir.file("file.obj")));
      expect_seam_kept(read_with_corners(dir.file("piped.obj")));
    }
    EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  }
}

// A PLY split at its seams (the same sphere) is counted the same way; forced to stream, the run
// says that its seams are simplified apart.
TEST(SimplifySeamsCli, APlySplitAtItsSeamsThatFitsWhenCountedRunsInCore) {
  ScratchDir dir;
  const std::string in = dir.file("sphere.ply");
  write_file(in, uv_sphere_ply(40, 80));
  const auto [counted, counted_report] = tenth(dir, in, "counted.obj", "--memory 24M");
  EXPECT_FALSE(counted_report["out_of_core"].get<bool>());
  EXPECT_GT(counted_report["seam_vertices"].get<int>(), 0);
  EXPECT_EQ(counted.err.find("warning"), std::string::npos) << counted.err;
  expect_seam_kept(read_with_corners(dir.file("counted.obj")));
  const auto [streamed, streamed_report] = tenth(dir, in, "streamed.obj", "--engine out-of-core --memory 24M");
  EXPECT_TRUE(streamed_report["out_of_core"].get<bool>());
  EXPECT_NE(streamed.err.find("texture coordinates stream without their seams"), std::string::npos) << streamed.err;
  // One face over half a million declared vertices (32 MB held at 64 B each): counted with its
  // vertices, the file does not fit and streams.
  std::string many = "ply\nformat ascii 1.0\nelement vertex 500000\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float s\nproperty float t\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 500000; ++i) many += std::to_string(i % 3 == 1) + " " + std::to_string(i % 3 == 2) + " 0 0 0\n";
  write_file(dir.file("many.ply"), many + "3 0 1 2\n");
  EXPECT_TRUE(tenth(dir, dir.file("many.ply"), "many.obj", "--memory 24M").second["out_of_core"].get<bool>());
}

}  // namespace
}  // namespace gaussmesh::testing
