// The sampling options shared by sample, simplify and segment: registration and parsing.
#include "cli/sampling_options.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace gaussmesh::cli {

void add_sampling_options(CLI::App& sub, SamplingFlags& o) {
  sub.add_option("--base", o.base, "Base polyhedron of the Gaussian sphere: icosa|octa|tetra")->capture_default_str();
  sub.add_option("--frequency", o.frequency,
                 "Sub-triangles per base edge f (f² per base face), or auto: chosen from the target (the default; "
                 "4 without a target)");
  sub.add_option("--level", o.level, "Subdivision level K: frequency 2^K");
  sub.add_option("--seed", o.seed, "Seed of the Gaussian sphere's pseudo-random rotation")->capture_default_str();
  sub.add_option("--rotation", o.rotation, "Rotation of the Gaussian sphere as a quaternion w,x,y,z");
  sub.add_option("--orientations", o.orientations, "Try K orientations, keep the one with fewest samples")
      ->capture_default_str();
  sub.add_option("--smooth", o.smooth, "Low-pass filter iterations on face normals")->capture_default_str();
  sub.add_option("--sample-test", o.sample_test, "exact (winding numbers) or paper (quantized + filters)")
      ->capture_default_str();
}

Result<SamplingOptions> sampling_options(const SamplingFlags& o, SamplingOptions s) {
  if (o.base == "icosa") s.base = GaussBase::kIcosahedron;
  else if (o.base == "octa") s.base = GaussBase::kOctahedron;
  else if (o.base == "tetra") s.base = GaussBase::kTetrahedron;
  else return Status::error(Code::kUsage, "--base", "expected icosa, octa or tetra, got '" + o.base + "'");
  if (!o.frequency.empty() && o.level >= 0) {
    return Status::error(Code::kUsage, "--level", "give --frequency or --level, not both");
  }
  if (o.level > 9) return Status::error(Code::kUsage, "--level", "at most 9 (frequency 512)");
  if (o.level >= 0) s.frequency = 1u << o.level;
  if (o.frequency == "auto") {
    s.frequency = kAutoFrequency;
  } else if (!o.frequency.empty()) {
    char* end = nullptr;
    errno = 0;
    const long long f = std::strtoll(o.frequency.c_str(), &end, 10);
    if (errno != 0 || end == o.frequency.c_str() || *end != '\0' || f < 1 || f > static_cast<long long>(kMaxFrequency)) {
      return Status::error(Code::kUsage, "--frequency",
                           "must be auto or between 1 and " + std::to_string(kMaxFrequency) + ", got '" + o.frequency + "'");
    }
    s.frequency = static_cast<std::uint32_t>(f);
  }
  if (o.orientations == 0) return Status::error(Code::kUsage, "--orientations", "must be at least 1");
  s.orientations = o.orientations;
  s.seed = o.seed;
  if (!o.rotation.empty()) {
    std::array<double, 4> q{};
    std::stringstream in(o.rotation);
    char comma = 0;
    bool ok = static_cast<bool>(in >> q[0]);
    for (int i = 1; i < 4 && ok; ++i) ok = (in >> comma) && comma == ',' && (in >> q[i]);
    in >> std::ws;
    const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!ok || !in.eof() || !std::isfinite(len) || len == 0) {
      return Status::error(Code::kUsage, "--rotation", "expected a non-zero quaternion w,x,y,z, got '" + o.rotation + "'");
    }
    s.rotation = q;
  }
  s.smooth = o.smooth;
  if (o.sample_test == "exact") s.sample_test = SampleTest::kExact;
  else if (o.sample_test == "paper") s.sample_test = SampleTest::kPaper;
  else return Status::error(Code::kUsage, "--sample-test", "expected exact or paper, got '" + o.sample_test + "'");
  return s;
}

}  // namespace gaussmesh::cli
