// Generator of large benchmark inputs: writes a binary little-endian PLY of about N triangles by
// refining a real mesh (barycentric f×f grid per base face, watertight global numbering) or an
// analytic shape (icosahedral sphere, parametric torus), streaming: memory does not grow with N.
//
//   make_large_mesh --triangles N [--source cow|sphere|torus|FILE] [--out FILE|-] [--seed S]
//                   [--noise X]
//
// Refinement of a base mesh with V vertices, E edges, F faces at frequency f (f² ≈ N / F):
//   vertices  V + E·(f−1) + F·(f−1)(f−2)/2, numbered base vertices first, then the interior
//             points of base edge e (edges sorted by (lower id, higher id)), counted from the
//             lower base vertex, then the interior points of each base face — so a point on a
//             shared base edge has one id, and the result has the base mesh's topology;
//   faces     F·f², base face by base face, oriented like their base face.
// Positions are barycentric interpolations, displaced along the interpolated vertex normal by
// noise·diagonal·g(p), g a smooth seeded sum of sinusoids (wavelength ~3 % of the diagonal), so
// the surface is not piecewise flat; --noise 0 gives the exact piecewise-flat refinement.
// `sphere` is a refined icosahedron projected onto the unit sphere; `torus` a (u, v) grid with
// R = 1, r = 0.4. The vertex section is written first (the header needs both counts, computed
// up front), then the faces. Prints counts, seconds and peak RSS (VmHWM) on stderr.
// Exit codes: 0 ok, 1 usage, 2 bad source mesh, 4 output.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "format/output_file.h"
#include "stream/core/exact_predicates.h"
#include "stream/core/mesh.h"
#include "stream/core/process_memory.h"
#include "tests/support/test_util.h"

namespace gaussmesh::bench {
namespace {

using format::Code;
using format::Status;

// stream::Vec3d and its operators, dot and cross (stream/core/exact_predicates.h).
using stream::Vec3d;
Vec3d normalized(Vec3d a) {
  double n = std::sqrt(dot(a, a));
  return n > 0 ? (1.0 / n) * a : Vec3d{0, 0, 1};
}

// Smooth scalar field in [-1, 1]: the mean of three sinusoids along seeded random directions.
class Displacement {
 public:
  Displacement(double amplitude, double wavelength, std::uint64_t seed) : amplitude_(amplitude) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> gauss;
    std::uniform_real_distribution<double> phase(0, 2 * M_PI);
    const double k = wavelength > 0 ? 2 * M_PI / wavelength : 0;
    for (auto& wave : waves_) {
      wave.first = k * normalized({gauss(rng), gauss(rng), gauss(rng)});
      wave.second = phase(rng);
    }
  }
  Vec3d apply(Vec3d p, Vec3d normal) const {
    if (amplitude_ == 0) return p;
    double g = 0;
    for (const auto& [direction, phase] : waves_) g += std::sin(dot(direction, p) + phase);
    return p + (amplitude_ * g / double(waves_.size())) * normal;
  }

 private:
  double amplitude_;
  std::array<std::pair<Vec3d, double>, 3> waves_;
};

// Buffers small records and hands them to the output in 1 MiB pieces.
class BufferedWriter {
 public:
  explicit BufferedWriter(format::OutputFile& out) : out_(out) { buffer_.reserve(kSize); }
  Status put(const void* data, size_t size) {
    if (buffer_.size() + size > kSize) GM_RETURN_IF_ERROR(flush());
    const char* bytes = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), bytes, bytes + size);
    return {};
  }
  Status vertex(Vec3d p) {
    const float xyz[3] = {float(p.x), float(p.y), float(p.z)};
    return put(xyz, sizeof xyz);
  }
  Status face(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    char record[13];
    record[0] = 3;
    const std::int32_t v[3] = {std::int32_t(a), std::int32_t(b), std::int32_t(c)};
    std::memcpy(record + 1, v, 12);
    ++faces_;
    return put(record, sizeof record);
  }
  Status flush() {
    Status status = out_.write(buffer_.data(), buffer_.size());
    buffer_.clear();
    return status;
  }
  std::uint64_t faces() const { return faces_; }

 private:
  static constexpr size_t kSize = size_t{1} << 20;
  format::OutputFile& out_;
  std::vector<char> buffer_;
  std::uint64_t faces_ = 0;
};

Status write_header(BufferedWriter& out, const std::string& comment, std::uint64_t vertices, std::uint64_t faces) {
  // PLY "int" indices: refuse what would not fit rather than write a corrupt file.
  if (vertices > 0x7FFFFFFFull) {
    return Status::error(Code::kUsage, "--triangles", std::to_string(vertices) + " vertices exceed PLY int indices");
  }
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment " + comment + "\nelement vertex " +
                       std::to_string(vertices) + "\nproperty float x\nproperty float y\nproperty float z\n" +
                       "element face " + std::to_string(faces) +
                       "\nproperty list uchar int vertex_indices\nend_header\n";
  return out.put(header.data(), header.size());
}

// A small base mesh and what refinement needs about it.
struct BaseMesh {
  std::vector<Vec3d> positions;
  std::vector<std::array<std::uint32_t, 3>> faces;
  std::vector<Vec3d> normals;                                  // area-weighted vertex normals
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;  // sorted, (lower, higher)
  bool on_sphere = false;  // project every point onto the unit sphere (normal = position)
  double diagonal = 1;

  std::uint64_t edge_index(std::uint32_t a, std::uint32_t b) const {
    auto key = std::minmax(a, b);
    auto it = std::lower_bound(edges.begin(), edges.end(), std::pair<std::uint32_t, std::uint32_t>(key.first, key.second));
    return std::uint64_t(it - edges.begin());
  }
};

// Faces, edges, normals and diagonal from positions and faces; faces with a repeated corner are
// dropped (they have no grid).
BaseMesh make_base(std::vector<Vec3d> positions, const std::vector<std::array<std::uint32_t, 3>>& faces, bool on_sphere) {
  BaseMesh base;
  base.positions = std::move(positions);
  base.on_sphere = on_sphere;
  base.normals.assign(base.positions.size(), Vec3d{});
  for (const auto& f : faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
    base.faces.push_back(f);
    Vec3d n = cross(base.positions[f[1]] - base.positions[f[0]], base.positions[f[2]] - base.positions[f[0]]);
    for (std::uint32_t v : f) base.normals[v] = base.normals[v] + n;
    for (int i = 0; i < 3; ++i) {
      auto key = std::minmax(f[i], f[(i + 1) % 3]);
      base.edges.emplace_back(key.first, key.second);
    }
  }
  std::sort(base.edges.begin(), base.edges.end());
  base.edges.erase(std::unique(base.edges.begin(), base.edges.end()), base.edges.end());
  for (Vec3d& n : base.normals) n = normalized(n);
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3d& p : base.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  base.diagonal = base.positions.empty() ? 1 : std::sqrt(dot(hi - lo, hi - lo));
  return base;
}

BaseMesh icosahedron() {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3d> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                          {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (Vec3d& v : p) v = normalized(v);
  std::vector<std::array<std::uint32_t, 3>> f = {
      {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
      {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  return make_base(std::move(p), f, true);
}

format::Result<BaseMesh> load_base(const std::string& path) {
  auto mesh = stream::load_mesh(path);
  if (!mesh) return mesh.status();
  std::vector<Vec3d> positions;
  positions.reserve(mesh->positions.size());
  for (const auto& p : mesh->positions) positions.push_back({p.x, p.y, p.z});
  std::vector<std::array<std::uint32_t, 3>> faces;
  faces.reserve(mesh->triangles.size());
  for (const auto& t : mesh->triangles) {
    if (t.v[0] >= positions.size() || t.v[1] >= positions.size() || t.v[2] >= positions.size()) {
      return Status::error(Code::kBadInput, path, "face index out of range");
    }
    faces.push_back({t.v[0], t.v[1], t.v[2]});
  }
  BaseMesh base = make_base(std::move(positions), faces, false);
  if (base.faces.empty()) return Status::error(Code::kBadInput, path, "no usable faces");
  return base;
}

// Writes the refinement of base at frequency f (see the file comment for the numbering).
Status write_refined(format::OutputFile& file, const BaseMesh& base, std::uint64_t f, const Displacement& displace,
                     const std::string& comment, std::uint64_t& vertices_out, std::uint64_t& faces_out) {
  const std::uint64_t nv = base.positions.size(), ne = base.edges.size(), nf = base.faces.size();
  const std::uint64_t per_edge = f - 1, per_face = (f - 1) * (f - 2) / 2;
  vertices_out = nv + ne * per_edge + nf * per_face;
  faces_out = nf * f * f;
  BufferedWriter out(file);
  GM_RETURN_IF_ERROR(write_header(out, comment, vertices_out, faces_out));

  // A point given by barycentric weights on corners a, b, c (summing to 1), displaced.
  auto point = [&](std::array<std::uint32_t, 3> corners, std::array<double, 3> w) {
    Vec3d p{}, n{};
    for (int i = 0; i < 3; ++i) {
      p = p + w[i] * base.positions[corners[i]];
      n = n + w[i] * base.normals[corners[i]];
    }
    if (base.on_sphere) {
      p = normalized(p);
      n = p;
    } else {
      n = normalized(n);
    }
    return displace.apply(p, n);
  };
  const double inv = 1.0 / double(f);
  for (std::uint32_t v = 0; v < nv; ++v) GM_RETURN_IF_ERROR(out.vertex(point({v, v, v}, {1, 0, 0})));
  for (const auto& [u, v] : base.edges) {
    for (std::uint64_t m = 1; m < f; ++m) {
      GM_RETURN_IF_ERROR(out.vertex(point({u, v, v}, {1 - double(m) * inv, double(m) * inv, 0})));
    }
  }
  for (const auto& face : base.faces) {
    for (std::uint64_t j = 1; j + 2 <= f; ++j) {
      for (std::uint64_t k = 1; j + k + 1 <= f; ++k) {
        const double wj = double(j) * inv, wk = double(k) * inv;
        GM_RETURN_IF_ERROR(out.vertex(point(face, {1 - wj - wk, wj, wk})));
      }
    }
  }

  for (std::uint64_t t = 0; t < nf; ++t) {
    const auto [a, b, c] = base.faces[t];
    const std::uint64_t edge_ab = nv + base.edge_index(a, b) * per_edge;
    const std::uint64_t edge_ac = nv + base.edge_index(a, c) * per_edge;
    const std::uint64_t edge_bc = nv + base.edge_index(b, c) * per_edge;
    const std::uint64_t interior = nv + ne * per_edge + t * per_face;
    // Interior point of edge (u, v) at `steps` grid steps from u.
    auto on_edge = [f](std::uint64_t first, std::uint32_t u, std::uint32_t v, std::uint64_t steps) {
      return first + (u < v ? steps : f - steps) - 1;
    };
    // Grid point with weights (i, j, k) / f on (a, b, c), i = f - j - k.
    auto id = [&](std::uint64_t j, std::uint64_t k) -> std::uint64_t {
      const std::uint64_t i = f - j - k;
      if (j == 0 && k == 0) return a;
      if (j == f) return b;
      if (k == f) return c;
      if (k == 0) return on_edge(edge_ab, a, b, j);
      if (j == 0) return on_edge(edge_ac, a, c, k);
      if (i == 0) return on_edge(edge_bc, b, c, k);
      // Row j holds f - 1 - j interior points; rows 1 .. j-1 come first.
      return interior + (j - 1) * (f - 1) - (j - 1) * j / 2 + (k - 1);
    };
    for (std::uint64_t j = 0; j < f; ++j) {
      for (std::uint64_t k = 0; j + k < f; ++k) {
        GM_RETURN_IF_ERROR(out.face(id(j, k), id(j + 1, k), id(j, k + 1)));
        if (j + k + 2 <= f) GM_RETURN_IF_ERROR(out.face(id(j + 1, k), id(j + 1, k + 1), id(j, k + 1)));
      }
    }
  }
  GM_RETURN_IF_ERROR(out.flush());
  if (out.faces() != faces_out) return Status::error(Code::kProcessing, "refine", "face count mismatch");
  return {};
}

// A torus (R = 1, r = 0.4) as a rows × cols grid over (v, u), outward-oriented.
Status write_torus(format::OutputFile& file, std::uint64_t triangles, const Displacement& displace,
                   const std::string& comment, std::uint64_t& vertices_out, std::uint64_t& faces_out) {
  const double big = 1.0, small = 0.4;
  const std::uint64_t rows = std::max<std::uint64_t>(3, std::uint64_t(std::llround(std::sqrt(double(triangles) * small / (2 * big)))));
  const std::uint64_t cols = std::max<std::uint64_t>(3, (triangles + 2 * rows - 1) / (2 * rows));
  vertices_out = rows * cols;
  faces_out = 2 * rows * cols;
  BufferedWriter out(file);
  GM_RETURN_IF_ERROR(write_header(out, comment, vertices_out, faces_out));
  for (std::uint64_t i = 0; i < rows; ++i) {
    const double v = 2 * M_PI * double(i) / double(rows);
    for (std::uint64_t j = 0; j < cols; ++j) {
      const double u = 2 * M_PI * double(j) / double(cols);
      const Vec3d n{std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v)};
      const Vec3d p{(big + small * std::cos(v)) * std::cos(u), (big + small * std::cos(v)) * std::sin(u),
                    small * std::sin(v)};
      GM_RETURN_IF_ERROR(out.vertex(displace.apply(p, n)));
    }
  }
  for (std::uint64_t i = 0; i < rows; ++i) {
    const std::uint64_t i1 = (i + 1) % rows;
    for (std::uint64_t j = 0; j < cols; ++j) {
      const std::uint64_t j1 = (j + 1) % cols;
      const std::uint64_t a = i * cols + j, b = i * cols + j1, c = i1 * cols + j1, d = i1 * cols + j;
      GM_RETURN_IF_ERROR(out.face(a, b, c));
      GM_RETURN_IF_ERROR(out.face(a, c, d));
    }
  }
  return out.flush();
}

int usage() {
  std::fprintf(stderr,
               "usage: make_large_mesh --triangles N [--source cow|sphere|torus|FILE] [--out FILE|-] "
               "[--seed S] [--noise X]\n"
               "  --noise X  smooth displacement amplitude, fraction of the bounding-box diagonal "
               "(default 0.001; 0: piecewise flat)\n");
  return 1;
}

int fail(const Status& status) {
  std::fprintf(stderr, "make_large_mesh: %s\n", status.to_string().c_str());
  return int(status.code());
}

}  // namespace
}  // namespace gaussmesh::bench

int main(int argc, char** argv) {
  using namespace gaussmesh;
  using namespace gaussmesh::bench;
  std::uint64_t triangles = 0;
  std::string source = "cow", out_path = "-";
  std::uint64_t seed = 1;
  double noise = 0.001;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (i + 1 >= argc) return usage();
    std::string value = argv[++i];
    char* end = nullptr;
    if (arg == "--triangles") {
      triangles = std::strtoull(value.c_str(), &end, 10);
    } else if (arg == "--source") {
      source = value;
    } else if (arg == "--out" || arg == "-o") {
      out_path = value;
    } else if (arg == "--seed") {
      seed = std::strtoull(value.c_str(), &end, 10);
    } else if (arg == "--noise") {
      noise = std::strtod(value.c_str(), &end);
    } else {
      return usage();
    }
    if (end != nullptr && (*end != '\0' || value.empty())) return usage();
  }
  if (triangles == 0 || !(noise >= 0)) return usage();

  const auto started = std::chrono::steady_clock::now();
  auto file = format::OutputFile::create(out_path, true);
  if (!file) return fail(file.status());
  std::uint64_t vertices = 0, faces = 0;
  std::string comment = "make_large_mesh source " + source + " seed " + std::to_string(seed) + " noise " +
                        std::to_string(noise);
  Status status;
  if (source == "torus") {
    const double diagonal = std::sqrt(2.8 * 2.8 * 2 + 0.8 * 0.8);
    Displacement displace(noise * diagonal, 0.03 * diagonal, seed);
    status = write_torus(**file, triangles, displace, comment, vertices, faces);
  } else {
    format::Result<BaseMesh> base = source == "sphere" ? format::Result<BaseMesh>(icosahedron())
                                                       : load_base(source == "cow" ? testing::fixture("real/cow.off") : source);
    if (!base) return fail(base.status());
    const double nf = double(base->faces.size());
    const std::uint64_t f = std::max<std::uint64_t>(1, std::uint64_t(std::llround(std::sqrt(double(triangles) / nf))));
    comment += " frequency " + std::to_string(f);
    Displacement displace(noise * base->diagonal, 0.03 * base->diagonal, seed);
    status = write_refined(**file, *base, f, displace, comment, vertices, faces);
  }
  if (!status) return fail(status);
  status = (*file)->commit();
  if (!status) return fail(status);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::fprintf(stderr, "make_large_mesh: %s: %llu vertices, %llu triangles, %.1f MB in %.1f s; peak RSS %.1f MB\n",
               (*file)->name().c_str(), (unsigned long long)vertices, (unsigned long long)faces,
               double((*file)->bytes_written()) / 1e6, seconds, double(stream::peak_rss()) / 1e6);
  return 0;
}
