// Quadric error metrics (Garland & Heckbert 1997) for the quadric finish: the squared distance
// to a set of planes, weighted by area, as a symmetric 4×4 form. `Quadric` is the double form
// the decimation works with; `FixedQuadric` is its 64-bit fixed-point form, whose sums do not
// depend on their order, so that the in-core run and the out-of-core one (which adds the same
// faces chunk by chunk, on several threads) reach the same bits.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace gaussmesh::stream {

struct Vec3dq {
  double x = 0, y = 0, z = 0;
};
inline Vec3dq add(const Vec3dq& a, const Vec3dq& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3dq sub(const Vec3dq& a, const Vec3dq& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3dq scale(const Vec3dq& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3dq cross(const Vec3dq& a, const Vec3dq& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double dot(const Vec3dq& a, const Vec3dq& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline double norm2(const Vec3dq& a) { return dot(a, a); }
inline double norm(const Vec3dq& a) { return std::sqrt(norm2(a)); }

// E(p) = pᵀ A p + 2 bᵀ p + c, with A = Σ w n nᵀ, b = Σ w d n, c = Σ w d², for planes n·p + d = 0
// of weight w (area); `weight` = Σ w, so E / weight is a mean squared distance.
struct Quadric {
  // a00 a01 a02 a11 a12 a22 b0 b1 b2 c
  std::array<double, 10> q{};
  double weight = 0;

  static Quadric plane(const Vec3dq& n, double d, double w) {
    Quadric r;
    r.q = {w * n.x * n.x, w * n.x * n.y, w * n.x * n.z, w * n.y * n.y, w * n.y * n.z, w * n.z * n.z,
           w * d * n.x,   w * d * n.y,   w * d * n.z,   w * d * d};
    r.weight = w;
    return r;
  }
  Quadric& operator+=(const Quadric& o) {
    for (int i = 0; i < 10; ++i) q[i] += o.q[i];
    weight += o.weight;
    return *this;
  }
  double error(const Vec3dq& p) const {
    const double e = q[0] * p.x * p.x + 2 * q[1] * p.x * p.y + 2 * q[2] * p.x * p.z + q[3] * p.y * p.y +
                     2 * q[4] * p.y * p.z + q[5] * p.z * p.z + 2 * (q[6] * p.x + q[7] * p.y + q[8] * p.z) + q[9];
    return e > 0 ? e : 0;
  }
  // E(p) / weight, the mean squared distance to the planes; E(p) when there is no weight (only
  // constraint planes).
  double mean_error(const Vec3dq& p) const {
    const double e = error(p);
    return weight > 0 ? e / weight : e;
  }
  // The minimiser of E, when A is well conditioned (its determinant is not tiny against the cube
  // of its trace, i.e. the planes span three directions); false otherwise.
  bool minimiser(Vec3dq& out) const {
    const double a00 = q[0], a01 = q[1], a02 = q[2], a11 = q[3], a12 = q[4], a22 = q[5];
    const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    const double trace = a00 + a11 + a22;
    if (!(trace > 0) || !(std::abs(det) > 1e-9 * trace * trace * trace)) return false;
    const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
    const double b0 = -q[6], b1 = -q[7], b2 = -q[8];
    out = {(c00 * b0 + c01 * b1 + c02 * b2) / det, (c01 * b0 + c11 * b1 + c12 * b2) / det,
           (c02 * b0 + c12 * b1 + c22 * b2) / det};
    return std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z);
  }
};

// Fixed point: coefficients and weight times 2^kFixedQuadricBits, rounded. Coordinates are
// normalised first (QuadricFrame), so a plane's coefficients are at most ~3 × its area, and a
// vertex's sum stays below 2^63 while the surface it absorbs has less than ~30,000 times the
// squared diagonal of area. Sums wrap (unsigned arithmetic) rather than overflow.
inline constexpr int kFixedQuadricBits = 48;

// Round half away from zero, without libm's call (the quadrics pass rounds 11 values a face).
inline std::int64_t round_to_int(double x) {
  return x >= 0 ? std::int64_t(x + 0.5) : -std::int64_t(0.5 - x);
}

struct FixedQuadric {
  std::array<std::int64_t, 11> q{};  // the 10 coefficients, then the weight

  static FixedQuadric from(const Quadric& d) {
    FixedQuadric r;
    const double scale = std::ldexp(1.0, kFixedQuadricBits);
    for (int i = 0; i < 10; ++i) r.q[i] = round_to_int(d.q[i] * scale);
    r.q[10] = round_to_int(d.weight * scale);
    return r;
  }
  FixedQuadric& operator+=(const FixedQuadric& o) {
    for (int i = 0; i < 11; ++i) q[i] = std::int64_t(std::uint64_t(q[i]) + std::uint64_t(o.q[i]));
    return *this;
  }
  Quadric to_double() const {
    Quadric r;
    const double scale = std::ldexp(1.0, -kFixedQuadricBits);
    for (int i = 0; i < 10; ++i) r.q[i] = double(q[i]) * scale;
    r.weight = double(q[10]) * scale;
    return r;
  }
};

// float(d), kept as a float. GCC 12's SLP vectorizer (at -O2 and -O3) folds double(float(d))
// back to d in vectorized lanes, so a position rounded to float and tested in double would be
// tested unrounded: the empty asm makes the rounded value opaque (tests/stream/finish/
// quadric_decimation_test.cpp, RoundedPositionsAreTheOnesTested).
inline float to_float(double d) {
  float f = float(d);
  __asm__("" : "+m"(f));
  return f;
}

// Maps positions into the unit-diagonal frame the quadrics live in: (p - origin) / scale.
// Colour as a quadric (Hoppe 1999's attribute quadrics, colour_quadrics.h): faces whose colour
// ramps are c(x) = g·x + d, each of weight s, ask a vertex at x for the colour that suits them
// best, their weighted mean, and leave Σ s (g·x + d)² - (Σ s (g·x + d))² / Σ s of squared
// colour error. The first sum goes into the vertex's Quadric; the second needs these sums, per
// channel, and is taken off by effective(). A colour that is one linear ramp across all its faces
// then costs nothing, wherever the vertex goes.
struct ColourSum {
  double s = 0;
  std::array<std::array<double, 3>, 3> g{};  // per channel: Σ s g
  std::array<double, 3> d{};                 // per channel: Σ s d
  ColourSum& operator+=(const ColourSum& o) {
    s += o.s;
    for (int c = 0; c < 3; ++c) {
      for (int i = 0; i < 3; ++i) g[c][i] += o.g[c][i];
      d[c] += o.d[c];
    }
    return *this;
  }
  // q less what the faces' best common colour takes off.
  Quadric effective(Quadric q) const {
    if (!(s > 0)) return q;
    for (int c = 0; c < 3; ++c) {
      const auto& a = g[c];
      const double k = 1 / s, e = d[c];
      q.q[0] -= k * a[0] * a[0], q.q[1] -= k * a[0] * a[1], q.q[2] -= k * a[0] * a[2];
      q.q[3] -= k * a[1] * a[1], q.q[4] -= k * a[1] * a[2], q.q[5] -= k * a[2] * a[2];
      q.q[6] -= k * e * a[0], q.q[7] -= k * e * a[1], q.q[8] -= k * e * a[2], q.q[9] -= k * e * e;
    }
    return q;
  }
};

struct QuadricFrame {
  Vec3dq origin;
  double scale = 1;
  Vec3dq to_frame(float x, float y, float z) const {
    return {(double(x) - origin.x) / scale, (double(y) - origin.y) / scale, (double(z) - origin.z) / scale};
  }
};

}  // namespace gaussmesh::stream
