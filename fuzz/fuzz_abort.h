// How a fuzz target turns a broken invariant into a libFuzzer finding: print it and abort.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

namespace gaussmesh::fuzz {

inline void abort_if_broken(const std::string& broken) {
  if (broken.empty()) return;
  std::fprintf(stderr, "invariant broken: %s\n", broken.c_str());
  std::abort();
}

}  // namespace gaussmesh::fuzz
