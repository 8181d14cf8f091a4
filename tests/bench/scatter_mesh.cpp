// Writes a scattered copy of a mesh (vertex ids and face order shuffled) for the benchmarks'
// badly ordered inputs:  scatter_mesh IN OUT.ply [--seed S]   (default seed 7). Exit 1 on failure.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/support/scattered_copy.h"

int main(int argc, char** argv) {
  if (argc != 3 && !(argc == 5 && std::string(argv[3]) == "--seed")) {
    std::fprintf(stderr, "usage: scatter_mesh IN OUT.ply [--seed S]\n");
    return 1;
  }
  const std::uint64_t seed = argc == 5 ? std::strtoull(argv[4], nullptr, 10) : 7;
  if (!gaussmesh::testing::write_scattered_copy(argv[1], argv[2], seed)) {
    std::fprintf(stderr, "scatter_mesh: could not copy %s to %s\n", argv[1], argv[2]);
    return 1;
  }
  return 0;
}
