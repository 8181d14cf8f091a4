// The public options turned into the engine's, with their validation.
#include <cmath>

#include "api/internal.h"

namespace gaussmesh::api {

Result<std::vector<stream::GaussSphereOptions>> gauss_spheres(const SamplingOptions& o) {
  stream::GaussSphereOptions base;
  switch (o.base) {
    case GaussBase::kIcosahedron: base.base = stream::GaussBase::kIcosahedron; break;
    case GaussBase::kOctahedron: base.base = stream::GaussBase::kOctahedron; break;
    case GaussBase::kTetrahedron: base.base = stream::GaussBase::kTetrahedron; break;
  }
  if (o.frequency > stream::kMaxGaussFrequency) {
    return Status::error(Code::kUsage, "--frequency", "must be between 1 and " + std::to_string(stream::kMaxGaussFrequency));
  }
  base.frequency = o.frequency == kAutoFrequency ? kDefaultFrequency : o.frequency;
  if (o.orientations == 0) return Status::error(Code::kUsage, "--orientations", "must be at least 1");
  std::vector<stream::GaussSphereOptions> spheres;
  for (std::uint32_t k = 0; k < o.orientations; ++k) {
    stream::GaussSphereOptions s = base;
    s.rotation = stream::gauss_rotation_from_seed(o.seed + k);
    if (k == 0 && o.rotation) {
      const auto& q = *o.rotation;
      const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!std::isfinite(len) || len == 0) {
        return Status::error(Code::kUsage, "--rotation", "expected a non-zero quaternion w,x,y,z");
      }
      s.rotation = q;
    }
    spheres.push_back(s);
  }
  return spheres;
}

Result<std::vector<stream::GaussSphereOptions>> frequency_ladder(const SamplingOptions& o) {
  if (o.orientations != 1) {
    return Status::error(Code::kUsage, "--orientations", "--frequency auto tries frequencies, not orientations: give one");
  }
  SamplingOptions one = o;
  one.frequency = 1;
  auto base = gauss_spheres(one);
  if (!base) return base.status();
  std::vector<stream::GaussSphereOptions> ladder;
  for (std::uint32_t f = 1; f <= kMaxAutoFrequency; f *= 2) {
    stream::GaussSphereOptions s = (*base)[0];
    s.frequency = f;
    ladder.push_back(s);
  }
  return ladder;
}

stream::SamplerOptions sampler_options(const SamplingOptions& o) {
  stream::SamplerOptions s;
  s.smooth_iterations = o.smooth;
  s.sample_test = o.sample_test == SampleTest::kPaper ? stream::SampleTest::kPaper : stream::SampleTest::kExact;
  return s;
}

}  // namespace gaussmesh::api
