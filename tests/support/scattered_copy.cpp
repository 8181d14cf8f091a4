#include "tests/support/scattered_copy.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"

namespace gaussmesh::testing {

stream::Mesh scattered_mesh(stream::Mesh mesh, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::uint32_t> to_new(mesh.positions.size());
  std::iota(to_new.begin(), to_new.end(), 0u);
  std::shuffle(to_new.begin(), to_new.end(), rng);
  std::vector<format::Vec3f> positions(mesh.positions.size());
  for (std::size_t v = 0; v < positions.size(); ++v) positions[to_new[v]] = mesh.positions[v];
  mesh.positions.swap(positions);
  for (auto& t : mesh.triangles)
    for (auto& v : t.v) v = to_new[v];
  std::shuffle(mesh.triangles.begin(), mesh.triangles.end(), rng);
  return mesh;
}

stream::Mesh soup_mesh(stream::Mesh mesh, std::uint64_t seed) {
  if (seed != 0) {
    std::mt19937_64 rng(seed);
    std::shuffle(mesh.triangles.begin(), mesh.triangles.end(), rng);
  }
  stream::Mesh soup;
  soup.positions.reserve(3 * mesh.triangles.size());
  soup.triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const auto first = static_cast<std::uint32_t>(soup.positions.size());
    for (const auto v : t.v) soup.positions.push_back(mesh.positions[v]);
    soup.triangles.push_back({{first, first + 1, first + 2}});
  }
  return soup;
}

bool write_binary_ply(const std::string& path, const stream::Mesh& mesh) {
  auto file = format::OutputFile::create(path, true);
  if (!file) return false;
  if (!format::write_ply(**file, mesh.view(), {}).is_ok()) return false;
  return (*file)->commit().is_ok();
}

namespace {

// Binary STL: an 80-byte header, the facet count, then per facet a normal (left zero: readers
// recompute it), three corners and a 16-bit attribute, little-endian.
bool write_stl_file(const std::string& out, const stream::Mesh& mesh) {
  auto file = format::OutputFile::create(out, true);
  if (!file) return false;
  std::vector<char> bytes(84, 0);
  const auto count = static_cast<std::uint32_t>(mesh.triangles.size());
  std::memcpy(bytes.data() + 80, &count, 4);
  for (const auto& t : mesh.triangles) {
    char record[50] = {};
    for (int k = 0; k < 3; ++k) std::memcpy(record + 12 + 12 * k, &mesh.positions[t.v[k]], 12);
    bytes.insert(bytes.end(), record, record + 50);
    if (bytes.size() >= (std::size_t{1} << 20)) {
      if (!(*file)->write(bytes.data(), bytes.size()).is_ok()) return false;
      bytes.clear();
    }
  }
  if (!(*file)->write(bytes.data(), bytes.size()).is_ok()) return false;
  return (*file)->commit().is_ok();
}

}  // namespace

bool write_scattered_copy(const std::string& in, const std::string& out, std::uint64_t seed) {
  auto mesh = stream::load_mesh(in);
  return mesh && write_binary_ply(out, scattered_mesh(std::move(*mesh), seed));
}

bool write_soup_copy(const std::string& in, const std::string& out, std::uint64_t seed, bool stl) {
  auto mesh = stream::load_mesh(in);
  if (!mesh) return false;
  const stream::Mesh soup = soup_mesh(std::move(*mesh), seed);
  return stl ? write_stl_file(out, soup) : write_binary_ply(out, soup);
}

}  // namespace gaussmesh::testing
