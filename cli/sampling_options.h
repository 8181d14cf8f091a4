// The sampling options shared by `sample`, `simplify` and `segment` (DESIGN §5): --base
// --frequency --level --seed --rotation --orientations --smooth --sample-test, their parsing and
// validation into stream options.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::cli {

inline constexpr std::uint32_t kDefaultFrequency = 4;

struct SamplingOptions {
  std::string base = "icosa";
  long long frequency = -1;     // -1: not given
  int level = -1;               // -1: not given; else frequency = 2^level
  std::uint64_t seed = stream::kDefaultGaussSeed;
  std::string rotation;         // "w,x,y,z" or empty
  std::uint32_t orientations = 1;
  std::uint32_t smooth = 0;
  std::string sample_test = "exact";
};

// Adds the options to a subcommand; values land in options (which must outlive parsing).
void add_sampling_options(CLI::App& sub, SamplingOptions& options);

// The Gaussian spheres to try, in order: orientation 0 is --rotation if given, else the rotation
// drawn from --seed; orientation k > 0 is drawn from seed + k. Errors (kUsage): unknown base,
// both --frequency and --level, a level above 9, a frequency out of range, a malformed or zero
// rotation, --orientations 0.
format::Result<std::vector<stream::GaussSphereOptions>> gauss_sphere_options(const SamplingOptions& options);

// Errors (kUsage): --sample-test other than exact or paper.
format::Result<stream::SamplerOptions> sampler_options(const SamplingOptions& options);

}  // namespace gaussmesh::cli
