// Writes a badly ordered copy of a mesh for the benchmarks' inputs (docs/benchmarks.md):
//   scatter_mesh IN OUT [--seed S] [--soup | --stl]
// by default vertex ids and face order shuffled (binary PLY); --soup: a triangle soup (faces
// shuffled, three vertices of their own each) as binary PLY; --stl: the same soup as binary STL.
// Default seed 7. Exit 1 on failure.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/support/scattered_copy.h"

int main(int argc, char** argv) {
  std::uint64_t seed = 7;
  bool soup = false, stl = false, ok = argc >= 3;
  for (int i = 3; ok && i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--soup") soup = true;
    else if (a == "--stl") stl = true;
    else ok = false;
  }
  if (!ok) {
    std::fprintf(stderr, "usage: scatter_mesh IN OUT [--seed S] [--soup | --stl]\n");
    return 1;
  }
  const bool written = soup || stl ? gaussmesh::testing::write_soup_copy(argv[1], argv[2], seed, stl)
                                   : gaussmesh::testing::write_scattered_copy(argv[1], argv[2], seed);
  if (!written) {
    std::fprintf(stderr, "scatter_mesh: could not copy %s to %s\n", argv[1], argv[2]);
    return 1;
  }
  return 0;
}
