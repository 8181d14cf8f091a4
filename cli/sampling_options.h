// The sampling options shared by `sample`, `simplify` and `segment`: --base --frequency --level
// --seed --rotation --orientations --smooth --sample-test, parsed into the API's SamplingOptions.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::cli {

struct SamplingFlags {
  std::string base = "icosa";
  std::string frequency;     // a number, "auto", or empty: not given
  int level = -1;            // -1: not given; else frequency = 2^level
  std::uint64_t seed = kDefaultSeed;
  std::string rotation;      // "w,x,y,z" or empty
  std::uint32_t orientations = 1;
  std::uint32_t smooth = 0;
  std::string sample_test = "exact";
};

// Adds the options to a subcommand; values land in flags (which must outlive parsing).
void add_sampling_options(CLI::App& sub, SamplingFlags& flags);

// The flags over `defaults` (whose frequency stands when neither --frequency nor --level is
// given). Errors (kUsage): unknown base, both --frequency and --level, a level above 9, a
// frequency out of range, a malformed rotation, --orientations 0, an unknown --sample-test.
Result<SamplingOptions> sampling_options(const SamplingFlags& flags, SamplingOptions defaults = {});

}  // namespace gaussmesh::cli
