// Wall-clock seconds since a point in time: the one timer behind every pass's figures.
#pragma once

#include <chrono>

namespace gaussmesh::stream {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace gaussmesh::stream
