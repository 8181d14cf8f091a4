// The sampling options shared by sample, simplify and segment: registration and validation.
#include "cli/sampling_options.h"

#include <cmath>
#include <sstream>

namespace gaussmesh::cli {

using format::Code;
using format::Status;

void add_sampling_options(CLI::App& sub, SamplingOptions& o) {
  sub.add_option("--base", o.base, "Base polyhedron of the Gaussian sphere: icosa|octa|tetra")->capture_default_str();
  sub.add_option("--frequency", o.frequency, "Sub-triangles per base edge f (f² per base face; default 4)");
  sub.add_option("--level", o.level, "Subdivision level K: frequency 2^K");
  sub.add_option("--seed", o.seed, "Seed of the Gaussian sphere's pseudo-random rotation")->capture_default_str();
  sub.add_option("--rotation", o.rotation, "Rotation of the Gaussian sphere as a quaternion w,x,y,z");
  sub.add_option("--orientations", o.orientations, "Try K orientations, keep the one with fewest samples")
      ->capture_default_str();
  sub.add_option("--smooth", o.smooth, "Low-pass filter iterations on face normals")->capture_default_str();
  sub.add_option("--sample-test", o.sample_test, "exact (winding numbers) or paper (quantized + filters)")
      ->capture_default_str();
}

format::Result<std::vector<stream::GaussSphereOptions>> gauss_sphere_options(const SamplingOptions& o) {
  stream::GaussSphereOptions base;
  if (o.base == "icosa") base.base = stream::GaussBase::kIcosahedron;
  else if (o.base == "octa") base.base = stream::GaussBase::kOctahedron;
  else if (o.base == "tetra") base.base = stream::GaussBase::kTetrahedron;
  else return Status::error(Code::kUsage, "--base", "expected icosa, octa or tetra, got '" + o.base + "'");
  if (o.frequency >= 0 && o.level >= 0) {
    return Status::error(Code::kUsage, "--level", "give --frequency or --level, not both");
  }
  if (o.level > 9) return Status::error(Code::kUsage, "--level", "at most 9 (frequency 512)");
  if (o.frequency == 0 || o.frequency > static_cast<long long>(stream::kMaxGaussFrequency) || o.frequency < -1) {
    return Status::error(Code::kUsage, "--frequency",
                         "must be between 1 and " + std::to_string(stream::kMaxGaussFrequency));
  }
  base.frequency = o.level >= 0 ? (1u << o.level)
                                : (o.frequency > 0 ? static_cast<std::uint32_t>(o.frequency) : kDefaultFrequency);
  if (o.orientations == 0) return Status::error(Code::kUsage, "--orientations", "must be at least 1");
  std::vector<stream::GaussSphereOptions> spheres;
  for (std::uint32_t k = 0; k < o.orientations; ++k) {
    stream::GaussSphereOptions s = base;
    s.rotation = stream::gauss_rotation_from_seed(o.seed + k);
    if (k == 0 && !o.rotation.empty()) {
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
    spheres.push_back(s);
  }
  return spheres;
}

format::Result<stream::SamplerOptions> sampler_options(const SamplingOptions& o) {
  stream::SamplerOptions s;
  s.smooth_iterations = o.smooth;
  if (o.sample_test == "exact") s.sample_test = stream::SampleTest::kExact;
  else if (o.sample_test == "paper") s.sample_test = stream::SampleTest::kPaper;
  else return Status::error(Code::kUsage, "--sample-test", "expected exact or paper, got '" + o.sample_test + "'");
  return s;
}

}  // namespace gaussmesh::cli
