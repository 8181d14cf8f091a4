// Writes the paper's analytic test shapes as binary PLY for the figures (scripts/render-figures):
// the convex morph from the sphere to a rounded cube (Fig. 2: p = 2, 4, 8, 16), the thin and thick
// tori (Fig. 3), the dented sphere (Fig. 4) and the genus-2 surface.
// Usage: write_shapes DIR [vertices=4000]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "tests/support/shapes.h"

using namespace gaussmesh;

namespace {

bool write(const std::string& path, const stream::Mesh& mesh) {
  auto out = format::OutputFile::create(path, true);
  if (!out) {
    std::fprintf(stderr, "write_shapes: %s\n", out.status().to_string().c_str());
    return false;
  }
  format::PlyWriteOptions options;
  options.comments.push_back("gaussmesh write_shapes");
  Status status = format::write_ply(**out, mesh.view(), options);
  if (status) status = (*out)->commit();
  if (!status) std::fprintf(stderr, "write_shapes: %s\n", status.to_string().c_str());
  return static_cast<bool>(status);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: write_shapes DIR [vertices=4000]\n");
    return 1;
  }
  const std::string dir = argv[1];
  testing::ShapeOptions options;
  options.vertices = argc > 2 ? std::strtoul(argv[2], nullptr, 10) : 4000;
  bool ok = true;
  for (int p : {2, 4, 8, 16}) ok &= write(dir + "/morph-p" + std::to_string(p) + ".ply", testing::make_rounded_cube(p, options));
  ok &= write(dir + "/thin-torus.ply", testing::make_torus(1, 0.25, options));
  ok &= write(dir + "/thick-torus.ply", testing::make_torus(1, 0.7, options));
  ok &= write(dir + "/dented-sphere.ply", testing::make_dented_sphere(0.3, options));
  ok &= write(dir + "/genus-2.ply", testing::make_genus2(options));
  return ok ? 0 : 1;
}
