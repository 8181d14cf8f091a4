#include "tests/support/scattered_copy.h"

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"

namespace gaussmesh::testing {

bool write_scattered_copy(const std::string& in, const std::string& out, std::uint64_t seed) {
  auto mesh = stream::load_mesh(in);
  if (!mesh) return false;
  std::mt19937_64 rng(seed);
  std::vector<std::uint32_t> to_new(mesh->positions.size());
  std::iota(to_new.begin(), to_new.end(), 0u);
  std::shuffle(to_new.begin(), to_new.end(), rng);
  std::vector<format::Vec3f> positions(mesh->positions.size());
  for (std::size_t v = 0; v < positions.size(); ++v) positions[to_new[v]] = mesh->positions[v];
  mesh->positions.swap(positions);
  std::vector<format::Vec3f>().swap(positions);
  for (auto& t : mesh->triangles)
    for (auto& v : t.v) v = to_new[v];
  std::shuffle(mesh->triangles.begin(), mesh->triangles.end(), rng);
  auto file = format::OutputFile::create(out, true);
  if (!file) return false;
  if (!format::write_ply(**file, mesh->view(), {}).is_ok()) return false;
  return (*file)->commit().is_ok();
}

}  // namespace gaussmesh::testing
