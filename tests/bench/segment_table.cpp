// Prints docs/segment.md's table: spherical segmentation (paper §6) of the analytic shapes in
// several random orientations and of the genus-0/1 fixtures over several Gaussian-sphere
// orientations: segments, faces per segment, smoothing iterations, poles, merges.
// Usage: segment_table [frequency=2] [orientations=8] [smoothing cap] [--write DIR] (DIR: coloured PLYs and
// PNG renders of every orientation, for the figures).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "stream/analysis/segmentation.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

using namespace gaussmesh;

namespace {

struct Case {
  std::string name;
  std::uint32_t expected;
  bool analytic;  // rotate the shape; else rotate G
  std::function<stream::Mesh(std::uint64_t seed)> make;
};

// A PNG of an RGB image with stored (uncompressed) deflate blocks: no zlib needed.
std::string encode_png(const std::vector<std::uint8_t>& rgb, int w, int h) {
  auto crc = [](const std::string& bytes) {
    std::uint32_t c = 0xFFFFFFFFu;
    for (unsigned char byte : bytes) {
      c ^= byte;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1)));
    }
    return ~c;
  };
  auto be32 = [](std::string& out, std::uint32_t v) {
    for (int k = 3; k >= 0; --k) out.push_back(static_cast<char>(v >> (8 * k) & 0xFF));
  };
  auto chunk = [&](std::string& out, const char* type, const std::string& data) {
    be32(out, static_cast<std::uint32_t>(data.size()));
    const std::string body = std::string(type, 4) + data;
    out += body;
    be32(out, crc(body));
  };
  std::string raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);  // filter: none
    raw.append(reinterpret_cast<const char*>(rgb.data()) + 3 * static_cast<std::size_t>(y) * w, 3 * w);
  }
  std::string z = "\x78\x01";
  for (std::size_t at = 0; at < raw.size() || at == 0; at += 65535) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - at);
    z.push_back(at + n >= raw.size() ? 1 : 0);
    z.push_back(static_cast<char>(n & 0xFF));
    z.push_back(static_cast<char>(n >> 8));
    z.push_back(static_cast<char>(~n & 0xFF));
    z.push_back(static_cast<char>((~n >> 8) & 0xFF));
    z.append(raw, at, n);
    if (raw.empty()) break;
  }
  std::uint32_t s1 = 1, s2 = 0;
  for (unsigned char byte : raw) {
    s1 = (s1 + byte) % 65521;
    s2 = (s2 + s1) % 65521;
  }
  be32(z, (s2 << 16) | s1);
  std::string header;
  be32(header, static_cast<std::uint32_t>(w));
  be32(header, static_cast<std::uint32_t>(h));
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit RGB
  std::string png = "\x89PNG\r\n\x1a\n";
  chunk(png, "IHDR", header);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", "");
  return png;
}

// A flat-shaded orthographic z-buffer render (PNG) seen from two sides, for the docs.
void render_png(const std::string& path, const stream::Mesh& mesh, const std::vector<std::uint8_t>& red,
                const std::vector<std::uint8_t>& green, const std::vector<std::uint8_t>& blue) {
  const int w = 360, h = 360;
  std::vector<float> depth(2 * w * h, -1e30f);
  std::vector<std::uint8_t> image(3 * 2 * w * h, 255);
  format::Vec3f lo = mesh.positions[0], hi = lo;
  for (const auto& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double cx = (lo.x + hi.x) / 2, cy = (lo.y + hi.y) / 2, cz = (lo.z + hi.z) / 2;
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) * 0.62;
  for (int view = 0; view < 2; ++view) {
    // Camera: tilted 35° about x, then 0° or 180° about the vertical axis.
    const double a = 0.61, b = view == 0 ? 0.4 : 0.4 + 3.14159265;
    auto project = [&](const format::Vec3f& p, double& sx, double& sy, double& sz) {
      double x = p.x - cx, y = p.y - cy, z = p.z - cz;
      const double x1 = std::cos(b) * x + std::sin(b) * y, y1 = -std::sin(b) * x + std::cos(b) * y;
      const double y2 = std::cos(a) * y1 - std::sin(a) * z, z2 = std::sin(a) * y1 + std::cos(a) * z;
      sx = (x1 / extent * 0.5 + 0.5) * w + view * w;
      sy = (0.5 - z2 / extent * 0.5) * h;
      sz = y2;  // larger is nearer... viewer looks along +y2
      sz = -sz;
    };
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      double X[3], Y[3], Z[3];
      for (int k = 0; k < 3; ++k) project(mesh.positions[mesh.triangles[f].v[k]], X[k], Y[k], Z[k]);
      const double area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
      if (area >= 0) continue;  // back face (screen y points down)
      // Shade by the normal's facing in camera space.
      const double ux = X[1] - X[0], uy = Y[1] - Y[0], uz = Z[1] - Z[0], vx = X[2] - X[0], vy = Y[2] - Y[0], vz = Z[2] - Z[0];
      const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      const double shade = 0.35 + 0.65 * std::fabs(nz) / std::sqrt(nx * nx + ny * ny + nz * nz + 1e-30);
      const int x0 = std::max(view * w, int(std::floor(std::min({X[0], X[1], X[2]})))),
                x1 = std::min(view * w + w - 1, int(std::ceil(std::max({X[0], X[1], X[2]}))));
      const int y0 = std::max(0, int(std::floor(std::min({Y[0], Y[1], Y[2]})))),
                y1 = std::min(h - 1, int(std::ceil(std::max({Y[0], Y[1], Y[2]}))));
      for (int py = y0; py <= y1; ++py) {
        for (int px = x0; px <= x1; ++px) {
          const double qx = px + 0.5, qy = py + 0.5;
          double l[3];
          for (int k = 0; k < 3; ++k) {
            const int i = (k + 1) % 3, j = (k + 2) % 3;
            l[k] = ((X[j] - X[i]) * (qy - Y[i]) - (qx - X[i]) * (Y[j] - Y[i])) / area;
          }
          if (l[0] < 0 || l[1] < 0 || l[2] < 0) continue;
          const float z = static_cast<float>(l[0] * Z[0] + l[1] * Z[1] + l[2] * Z[2]);
          const std::size_t at = static_cast<std::size_t>(py) * 2 * w + px;
          if (z <= depth[at]) continue;
          depth[at] = z;
          image[3 * at] = static_cast<std::uint8_t>(red[f] * shade);
          image[3 * at + 1] = static_cast<std::uint8_t>(green[f] * shade);
          image[3 * at + 2] = static_cast<std::uint8_t>(blue[f] * shade);
        }
      }
    }
  }
  testing::write_file(path, encode_png(image, 2 * w, h));
}

void write_coloured(const std::string& path, const stream::Mesh& mesh, const stream::SegmentationResult& r) {
  static const std::uint8_t palette[][3] = {{220, 50, 47}, {60, 170, 60}, {38, 110, 210}, {230, 190, 30}, {160, 80, 200}};
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint8_t> red(nf), green(nf), blue(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto* c = palette[r.face_segment[f] % 5];
    const int dim = r.face_pole[f] ? 40 : 0;  // pole faces slightly darker (Fig. 20, second step)
    red[f] = static_cast<std::uint8_t>(c[0] - c[0] * dim / 255);
    green[f] = static_cast<std::uint8_t>(c[1] - c[1] * dim / 255);
    blue[f] = static_cast<std::uint8_t>(c[2] - c[2] * dim / 255);
  }
  auto out = format::OutputFile::create(path, true);
  if (!out) return;
  format::PlyWriteOptions o;
  o.face_attributes = {{"red", std::span<const std::uint8_t>(red)},
                       {"green", std::span<const std::uint8_t>(green)},
                       {"blue", std::span<const std::uint8_t>(blue)},
                       {"segment", std::span<const std::uint32_t>(r.face_segment)}};
  if (format::write_ply(**out, mesh.view(), o)) (void)(*out)->commit();
  render_png(path.substr(0, path.size() - 4) + ".png", mesh, red, green, blue);
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t frequency = 2, orientations = 8;
  std::string write_dir;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--write") == 0 && i + 1 < argc) write_dir = argv[++i];
    else positional.push_back(argv[i]);
  }
  if (positional.size() > 0) frequency = static_cast<std::uint32_t>(std::atoi(positional[0].c_str()));
  if (positional.size() > 1) orientations = static_cast<std::uint32_t>(std::atoi(positional[1].c_str()));
  stream::SegmentationOptions options;
  if (positional.size() > 2) options.max_smooth = static_cast<std::uint32_t>(std::atoi(positional[2].c_str()));

  auto shape = [](auto generator) {
    return [generator](std::uint64_t seed) {
      testing::ShapeOptions o;
      o.rotation = testing::random_rotation(seed);
      return generator(o);
    };
  };
  auto fixture = [](const std::string& name) {
    return [name](std::uint64_t) { return stream::load_mesh(testing::fixture("real/" + name)).value(); };
  };
  std::vector<Case> cases = {
      {"sphere", 1, true, shape([](testing::ShapeOptions o) { o.vertices = 5000; return testing::make_sphere(o); })},
      {"rounded cube p=6", 1, true,
       shape([](testing::ShapeOptions o) { o.vertices = 8000; return testing::make_rounded_cube(6, o); })},
      {"thin torus r/R=0.25", 2, true,
       shape([](testing::ShapeOptions o) { o.vertices = 6000; return testing::make_torus(1, 0.25, o); })},
      {"thick torus r/R=0.7", 2, true,
       shape([](testing::ShapeOptions o) { o.vertices = 6000; return testing::make_torus(1, 0.7, o); })},
      {"genus 2", 3, true, shape([](testing::ShapeOptions o) { o.vertices = 8000; return testing::make_genus2(o); })},
      {"cow.off", 1, false, fixture("cow.off")},
      {"knot1.off", 2, false, fixture("knot1.off")},
  };

  std::printf("G: icosahedron, frequency %u (%u triangles); %u orientations (seeds 1..%u); smoothing cap %u\n\n",
              frequency, 20 * frequency * frequency, orientations, orientations, options.max_smooth);
  std::printf("| shape | faces | genus | expected | segments (per orientation) | faces per segment (orientation 1) | smoothing iterations | poles | greedy aggregates | merges | duplicate labels | ms |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    std::string segs, faces, iters, poles, greedy, merges, dups;
    std::size_t nf = 0, genus = 0;
    double ms = 0;
    bool all_ok = true;
    for (std::uint64_t seed = 1; seed <= orientations; ++seed) {
      const stream::Mesh mesh = c.make(seed);
      stream::GaussSphereOptions go;
      go.frequency = frequency;
      if (!c.analytic) go.rotation = stream::gauss_rotation_from_seed(seed);
      const auto gauss = stream::GaussSphere::create(go).value();
      const auto t0 = std::chrono::steady_clock::now();
      auto r = stream::segment_mesh(mesh.view(), gauss, options);
      ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!r) {
        std::printf("| %s | error: %s |\n", c.name.c_str(), r.status().to_string().c_str());
        all_ok = false;
        break;
      }
      nf = mesh.triangles.size();
      genus = r->genus;
      auto add = [](std::string& s, const std::string& v) { s += (s.empty() ? "" : " ") + v; };
      add(segs, std::to_string(r->segment_count) + (r->segment_count == c.expected ? "" : "!"));
      add(iters, std::to_string(r->smooth_iterations) + (r->smooth_cap_hit ? "(cap)" : ""));
      add(poles, std::to_string(r->poles));
      add(greedy, std::to_string(r->greedy_aggregates));
      add(merges, std::to_string(r->merges));
      std::size_t d = 0;
      for (std::size_t x : r->duplicate_labels) d += x;
      add(dups, std::to_string(d));
      if (seed == 1) {
        for (std::size_t s = 0; s < r->segment_count; ++s) add(faces, std::to_string(r->segment_faces[s]));
      }
      if (!write_dir.empty()) {
        std::string file = c.name;
        for (char& ch : file) {
          if (ch == ' ' || ch == '/' || ch == '=' || ch == '.') ch = '_';
        }
        write_coloured(write_dir + "/" + file + "-" + std::to_string(seed) + ".ply", mesh, *r);
      }
    }
    if (!all_ok) continue;
    std::printf("| %s | %zu | %zu | %u | %s | %s | %s | %s | %s | %s | %s | %.0f |\n", c.name.c_str(), nf, genus,
                c.expected, segs.c_str(), faces.c_str(), iters.c_str(), poles.c_str(), greedy.c_str(), merges.c_str(),
                dups.c_str(), ms / orientations);
  }
  return 0;
}
