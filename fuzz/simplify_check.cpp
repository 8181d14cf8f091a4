// The simplify check shared by fuzz_simplify and its regression test (simplify_check.h).
#include "fuzz/simplify_check.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <set>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::fuzz {
namespace {

// The fuzz bytes, read front to back; past the end every read is zero.
class Bytes {
 public:
  explicit Bytes(std::string_view bytes) : bytes_(bytes) {}
  bool has(std::size_t n) const { return bytes_.size() - at_ >= n; }
  std::uint8_t byte() { return has(1) ? static_cast<std::uint8_t>(bytes_[at_++]) : 0; }
  float f32() {
    float f = 0;
    if (has(4)) std::memcpy(&f, bytes_.data() + at_, 4);
    at_ = has(4) ? at_ + 4 : bytes_.size();
    return f;
  }

 private:
  std::string_view bytes_;
  std::size_t at_ = 0;
};

// Whether two faces of the mesh span the same three positions, in either orientation: a face
// twice, or two back to back. Such an input may keep them, as simplify keeps the topology.
bool has_face_twice(const Mesh& mesh) {
  // Positions by their bits, as the weld compares them (and NaN has an order).
  using Bits = std::array<std::uint32_t, 3>;
  std::set<std::array<Bits, 3>> seen;
  for (const Triangle& t : mesh.triangles) {
    std::array<Bits, 3> key;
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = mesh.positions[t.v[k] < mesh.positions.size() ? t.v[k] : 0];
      key[k] = {std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y), std::bit_cast<std::uint32_t>(p.z)};
    }
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) continue;  // simplify drops it
    std::sort(key.begin(), key.end());
    if (!seen.insert(key).second) return true;
  }
  return false;
}

std::string check_output(const Mesh& out, const SimplifyStats& stats, bool input_has_face_twice) {
  const std::size_t n = out.positions.size();
  for (const Vec3f& p : out.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return "a position is not finite";
  }
  std::set<std::array<VertexIndex, 3>> faces;
  for (const Triangle& t : out.triangles) {
    for (VertexIndex v : t.v) {
      if (v >= n) return "an index out of range";
    }
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) return "a face with a repeated corner";
    std::array<VertexIndex, 3> key{t.v[0], t.v[1], t.v[2]};
    std::sort(key.begin(), key.end());
    if (!faces.insert(key).second && !input_has_face_twice) return "a face twice";
  }
  if (!out.normals.empty() && out.normals.size() != n) return "normals not one per vertex";
  if (!out.colors.empty() && out.colors.size() != n) return "colours not one per vertex";
  if (!out.texcoords.empty() && out.texcoords.size() != n) return "texture coordinates not one per vertex";
  if (stats.output_faces != out.triangles.size() || stats.output_vertices != n) return "stats that do not count the output";
  return "";
}

std::string run(const Mesh& in, const SimplifyOptions& options, bool input_has_face_twice) {
  Mesh out;
  Result<SimplifyStats> stats = simplify(Source::memory(in.view()), Sink::memory(&out), options);
  if (!stats.is_ok()) return stats.status().message().empty() ? "an error without a message" : "";
  std::string broken = check_output(out, *stats, input_has_face_twice);
  if (broken.empty() && options.target.faces > 0 && stats->stopped_by == "target" && out.triangles.size() > options.target.faces) {
    broken = "stopped by the face target with more faces than it";
  }
  return broken;
}

}  // namespace

std::string check_simplify(std::string_view bytes) {
  Bytes in(bytes);
  const std::size_t vertices = 3 + in.byte() % (kMaxFuzzVertices - 2);
  const std::uint8_t flags = in.byte();
  const std::uint8_t amount = in.byte();
  Mesh mesh;
  for (std::size_t i = 0; i < vertices; ++i) {
    if (flags & 1) {
      mesh.positions.push_back({in.f32(), in.f32(), in.f32()});
    } else {
      auto lattice = [&] { return static_cast<float>(static_cast<std::int8_t>(in.byte())); };
      mesh.positions.push_back({lattice(), lattice(), lattice()});
    }
  }
  while (in.has(3) && mesh.triangles.size() < kMaxFuzzFaces) {
    Triangle t;
    for (VertexIndex& v : t.v) v = (flags & 2) ? in.byte() : in.byte() % vertices;
    mesh.triangles.push_back(t);
  }

  const bool twice = has_face_twice(mesh);
  SimplifyOptions options;
  options.resources.engine = Engine::kInCore;
  options.resources.threads = 1;
  options.mesher = (flags & 16) ? Mesher::kVoronoi : Mesher::kPatch;
  options.sampling.frequency = (flags >> 5) & 3;  // 0: auto
  options.weld = (flags & 128) ? Weld::kOn : Weld::kAuto;
  if (std::string broken = run(mesh, options, twice); !broken.empty()) return "without a target: " + broken;

  // With a target, auto would pick the frequency from it, up to kMaxAutoFrequency, whose
  // Gaussian sphere takes seconds to build under the sanitizers: the default keeps runs fast.
  if (options.sampling.frequency == kAutoFrequency) options.sampling.frequency = kDefaultFrequency;

  switch ((flags >> 2) & 3) {
    case 0: options.target.faces = 1 + amount % (mesh.triangles.size() + 1); break;
    case 1: options.target.ratio = (1 + amount % 100) / 100.0; break;
    case 2: options.target.max_error = amount / 16.0; break;
    default:
      options.target.max_error = (1 + amount) / 64.0;
      options.target.max_error_relative = true;
      break;
  }
  if (std::string broken = run(mesh, options, twice); !broken.empty()) return "with a target: " + broken;

  // Once more with values per vertex that differ between vertices at one place (seams, which a
  // target keeps: stream/attributes/seams.h) and colours weighed by the finish (--color-weight).
  for (std::size_t i = 0; i < vertices; ++i) {
    mesh.texcoords.push_back({float(i & 1), float((i >> 1) & 1)});
    mesh.colors.push_back({float(i % 3) / 2, float(i % 5) / 4, float(i % 7) / 6, 1});
  }
  options.color_weight = amount / 64.0;
  if (std::string broken = run(mesh, options, twice); !broken.empty()) return "with seams and colours: " + broken;
  return "";
}

}  // namespace gaussmesh::fuzz
