// The optimized sampler against a straightforward reference (no golden files): adjacency from a
// std::map of directed edges, normals in double, labels by brute force over every Gaussian
// triangle with exact containment, feature edges from a std::map of undirected edges, vertex
// decisions with windings around every Gaussian vertex in the polygon's hemisphere, patches
// and the untriangulatable merge with maps. Every decision of the optimized code (adjacency,
// labels, feature bits, vertex records, patches, candidates, samples, stats) must equal the
// reference's on the real fixtures and on noisy generated meshes with defects, for f = 2, 4, 8,
// both sample tests, smooth 0 and 2. The untriangulatable merge, which runs on the patch graph,
// is also checked against the previous merge over the mesh round by round (mesh_round_sample)
// on every fixture in eight orientations and on noisy shapes where many patches merge.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <gtest/gtest.h>

#include "stream/core/exact_predicates.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/core/canonical_order.h"
#include "stream/sampling/patch_filters.h"
#include "stream/sampling/sampler.h"
#include "tests/support/shapes.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using format::Triangle;

constexpr double kMargin = 1e-3;  // the sampler's hemisphere margin (docs/sampling.md)

// The reference's exact predicate: CGAL's, called directly (not the sampler's filtered one).
int ref_orient(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  using P = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  const CGAL::Orientation o = CGAL::orientation(P(0, 0, 0), P(a.x, a.y, a.z), P(b.x, b.y, b.z), P(c.x, c.y, c.z));
  return o == CGAL::POSITIVE ? 1 : (o == CGAL::NEGATIVE ? -1 : 0);
}

bool collapsed(const Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }
Vec3d d3(const Vec3f& v) { return {v.x, v.y, v.z}; }

// ---- Reference adjacency ----------------------------------------------------------------------

MeshAdjacency ref_adjacency(const Mesh& m) {
  const std::size_t nv = m.positions.size(), nf = m.triangles.size();
  MeshAdjacency a;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> directed;  // (from, to) -> faces
  std::vector<std::vector<std::uint32_t>> star(nv);  // corners in increasing order
  for (std::uint32_t f = 0; f < nf; ++f) {
    const Triangle& t = m.triangles[f];
    if (collapsed(t)) {
      ++a.collapsed_faces;
      continue;
    }
    for (std::uint32_t i = 0; i < 3; ++i) {
      directed[{t.v[i], t.v[(i + 1) % 3]}].push_back(f);
      star[t.v[i]].push_back(3 * f + i);
    }
  }
  a.edge_neighbor.assign(3 * nf, MeshAdjacency::kNoFace);
  for (std::uint32_t f = 0; f < nf; ++f) {
    const Triangle& t = m.triangles[f];
    if (collapsed(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const auto& out = directed[{t.v[i], t.v[(i + 1) % 3]}];
      auto back = directed.find({t.v[(i + 1) % 3], t.v[i]});
      if (out.size() == 1 && back != directed.end() && back->second.size() == 1) a.edge_neighbor[3 * f + i] = back->second[0];
      else ++a.break_edges;
    }
  }
  a.vertex_offsets.push_back(0);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto& s = star[v];
    std::vector<bool> used(s.size(), false);
    auto walk = [&](std::size_t r, bool closed) {
      const std::size_t start = r;
      a.slot_flags.push_back(MeshAdjacency::kFanStart | (closed ? MeshAdjacency::kFanClosed : 0));
      while (true) {
        used[r] = true;
        a.vertex_corners.push_back(s[r]);
        const std::uint32_t c = s[r];
        const std::uint32_t next = a.edge_neighbor[3 * (c / 3) + (c % 3 + 2) % 3];
        if (next == MeshAdjacency::kNoFace) break;
        std::size_t nr = s.size();
        for (std::size_t x = 0; x < s.size(); ++x)
          if (s[x] / 3 == next) nr = x;
        if (nr == s.size() || nr == start || used[nr]) break;
        a.slot_flags.push_back(0);
        r = nr;
      }
    };
    for (std::size_t r = 0; r < s.size(); ++r)
      if (a.edge_neighbor[s[r]] == MeshAdjacency::kNoFace) walk(r, false);
    for (std::size_t r = 0; r < s.size(); ++r)
      if (!used[r]) walk(r, true);
    a.vertex_offsets.push_back(static_cast<std::uint32_t>(a.vertex_corners.size()));
  }
  return a;
}

// ---- Reference normals (double, then rounded to float) -----------------------------------------

Vec3f reference_unit(const Vec3d& v) {
  const double len = std::sqrt(dot(v, v));
  if (!(len > 0)) return {};
  const double s = 1.0 / len;
  return {float(v.x * s), float(v.y * s), float(v.z * s)};
}

FaceNormals ref_normals(const Mesh& m, const MeshAdjacency& a, std::uint32_t smooth) {
  const std::size_t nf = m.triangles.size();
  FaceNormals out;
  out.normal.assign(nf, Vec3f{});
  out.degenerate.assign(nf, 0);
  std::vector<double> area(nf, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = m.triangles[f];
    const Vec3d p0 = d3(m.positions[t.v[0]]), p1 = d3(m.positions[t.v[1]]), p2 = d3(m.positions[t.v[2]]);
    const Vec3d n = cross(p1 - p0, p2 - p0);
    const double len = std::sqrt(dot(n, n));
    const double scale = dot(p1 - p0, p1 - p0) + dot(p2 - p0, p2 - p0) + dot(p2 - p1, p2 - p1);
    if (!(len > 1e-7 * scale)) {
      out.degenerate[f] = 1;
      ++out.degenerate_count;
      continue;
    }
    out.normal[f] = {float(n.x * (1.0 / len)), float(n.y * (1.0 / len)), float(n.z * (1.0 / len))};
    area[f] = float(0.5 * len);
  }
  std::vector<Vec3f> inherited = out.normal;
  for (std::size_t f = 0; f < nf; ++f) {
    if (!out.degenerate[f]) continue;
    Vec3d sum{};
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t g = a.edge_neighbor[3 * f + i];
      if (g != MeshAdjacency::kNoFace && !out.degenerate[g]) sum = sum + area[g] * d3(out.normal[g]);
    }
    inherited[f] = reference_unit(sum);
  }
  out.normal = inherited;
  for (std::uint32_t it = 0; it < smooth; ++it) {
    std::vector<Vec3f> next(nf);
    for (std::size_t f = 0; f < nf; ++f) {
      Vec3d sum = area[f] * d3(out.normal[f]);
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = a.edge_neighbor[3 * f + i];
        if (g != MeshAdjacency::kNoFace) sum = sum + area[g] * d3(out.normal[g]);
      }
      const Vec3f u = reference_unit(sum);
      next[f] = (u.x == 0 && u.y == 0 && u.z == 0) ? out.normal[f] : u;
    }
    out.normal = next;
  }
  return out;
}

// ---- Reference labels: brute force with exact containment ---------------------------------------

// The Gaussian triangles whose closed spherical triangle holds n exactly, and whether n is so
// close to a cell boundary (|det| < 1e-12) that double rounding may pick either side.
struct Containment {
  std::vector<std::uint32_t> holders;
  bool near_boundary = false;
};

Containment contain(const GaussSphere& g, const Vec3d& n) {
  Containment c;
  const double len = std::sqrt(dot(n, n));
  for (std::uint32_t t = 0; t < g.triangle_count(); ++t) {
    if (dot(n, g.triangle_center(t)) < len * (g.triangle_cap_cos(t) - 1e-6)) continue;
    const auto& v = g.triangle_vertices(t);
    bool inside = true;
    for (int i = 0; i < 3; ++i) {
      const Vec3d& a = g.vertex(v[i]);
      const Vec3d& b = g.vertex(v[(i + 1) % 3]);
      if (ref_orient(a, b, n) < 0) inside = false;
      if (std::abs(dot(cross(a, b), n)) < 1e-12 * len) {
        // Near this edge's great circle: only a boundary if also between a and b.
        if (dot(n, g.triangle_center(t)) >= len * (g.triangle_cap_cos(t) - 1e-6)) c.near_boundary = true;
      }
    }
    if (inside) c.holders.push_back(t);
  }
  return c;
}

struct RefLabels {
  std::vector<std::uint32_t> label;
  std::size_t ambiguous = 0;  // near a cell boundary: the optimized label is adopted if it holds n
};

// Brute force over all Gaussian triangles; where the direction is numerically on a cell
// boundary, the optimized label is accepted if it is one of the (near-)holders.
RefLabels ref_labels(const FaceNormals& n, const GaussSphere& g, const std::vector<std::uint32_t>& optimized) {
  RefLabels r;
  r.label.resize(n.normal.size());
  for (std::size_t f = 0; f < n.normal.size(); ++f) {
    const Vec3f& v = n.normal[f];
    if (v.x == 0 && v.y == 0 && v.z == 0) {
      r.label[f] = kNoLabel;
      continue;
    }
    const Containment c = contain(g, d3(v));
    if (c.holders.size() == 1 && !c.near_boundary) {
      r.label[f] = c.holders[0];
    } else {
      ++r.ambiguous;
      r.label[f] = optimized[f];
      bool near = std::find(c.holders.begin(), c.holders.end(), optimized[f]) != c.holders.end();
      if (!near && optimized[f] < g.triangle_count()) {
        // Accept a neighbour of a holder within 1e-12 of the shared edge.
        const auto& tv = g.triangle_vertices(optimized[f]);
        const Vec3d p = d3(v);
        double worst = 0;
        for (int i = 0; i < 3; ++i) worst = std::min(worst, dot(cross(g.vertex(tv[i]), g.vertex(tv[(i + 1) % 3])), p));
        near = worst > -1e-12;
      }
      EXPECT_TRUE(near) << "face " << f << ": label " << optimized[f] << " does not hold its normal";
    }
  }
  return r;
}

// ---- Reference feature edges ----------------------------------------------------------------

std::vector<std::uint8_t> ref_feature(const Mesh& m, const std::vector<std::uint32_t>& labels) {
  const std::size_t nf = m.triangles.size();
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::pair<std::uint32_t, bool>>> edges;  // faces, forward?
  for (std::uint32_t f = 0; f < nf; ++f) {
    const Triangle& t = m.triangles[f];
    if (collapsed(t)) continue;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = t.v[i], b = t.v[(i + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back({f, a < b});
    }
  }
  std::vector<std::uint8_t> feature(nf, 0);
  for (std::uint32_t f = 0; f < nf; ++f) {
    const Triangle& t = m.triangles[f];
    if (collapsed(t)) {
      feature[f] = 7;
      continue;
    }
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = t.v[i], b = t.v[(i + 1) % 3];
      const auto& faces = edges[{std::min(a, b), std::max(a, b)}];
      const bool manifold = faces.size() == 2 && faces[0].second != faces[1].second;
      const std::uint32_t other = faces[0].first == f ? faces.back().first : faces[0].first;
      if (!manifold || labels[other] != labels[f]) feature[f] |= static_cast<std::uint8_t>(1u << i);
    }
  }
  return feature;
}

// ---- Reference vertex decisions ---------------------------------------------------------------

int ref_winding(const std::vector<Vec3d>& poly, const Vec3d& g) {
  // Crossing rule in the tangent plane, every comparison an exact sign (docs/sampling.md).
  const double ax = std::abs(g.x), ay = std::abs(g.y), az = std::abs(g.z);
  const Vec3d d = ax <= ay && ax <= az ? Vec3d{1, 0, 0} : (ay <= az ? Vec3d{0, 1, 0} : Vec3d{0, 0, 1});
  int w = 0;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec3d& a = poly[i];
    const Vec3d& b = poly[(i + 1) % poly.size()];
    const bool above_a = ref_orient(a, g, d) > 0, above_b = ref_orient(b, g, d) > 0;
    if (!above_a && above_b && ref_orient(a, b, g) > 0) ++w;
    if (above_a && !above_b && ref_orient(a, b, g) < 0) --w;
  }
  return w;
}

Characteristic ref_classify(int w, double side) {
  if (w == 0) return Characteristic::kNone;
  if (w < 0) return Characteristic::kSaddle;
  return side < 0 ? Characteristic::kConvex : Characteristic::kConcave;
}

std::vector<VertexRecord> ref_vertices(const Mesh& m, const MeshAdjacency& a, const FaceNormals& n,
                                       const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                                       const GaussSphere& g, bool exact, std::uint32_t begin, std::uint32_t end) {
  std::vector<VertexRecord> out;
  for (std::uint32_t v = begin; v < end; ++v) {
    // Fans as lists of faces.
    std::vector<std::vector<std::uint32_t>> fans;
    std::uint32_t features = 0;
    std::set<std::uint32_t> distinct;
    for (std::uint32_t s = a.star_begin(v); s < a.star_end(v); ++s) {
      const std::uint32_t c = a.vertex_corners[s], f = c / 3, i = c % 3;
      if (a.slot_flags[s] & MeshAdjacency::kFanStart) fans.emplace_back();
      fans.back().push_back(f);
      features += feature[f] >> i & 1;
      features += a.edge_neighbor[3 * f + (i + 2) % 3] == MeshAdjacency::kNoFace;
      distinct.insert(labels[f]);
    }
    if (fans.empty()) continue;
    VertexRecord r;
    r.vertex = v;
    r.feature_edges = static_cast<std::uint16_t>(features);
    r.is_candidate = features >= 3;
    const bool test_exact = exact && distinct.size() > 1;
    if (!r.is_candidate && !test_exact) continue;
    const bool unlabelled = distinct.count(kNoLabel) > 0;
    auto side = [&](const Vec3d& gv) {
      double s = 0;
      for (std::uint32_t k = a.star_begin(v); k < a.star_end(v); ++k) {
        const std::uint32_t c = a.vertex_corners[k];
        s += dot(d3(m.positions[m.triangles[c / 3].v[(c % 3 + 1) % 3]]) - d3(m.positions[v]), gv);
      }
      return s;
    };
    if (r.is_candidate) {
      bool tree = !unlabelled;
      for (const auto& fan : fans) {
        if (!tree) break;
        std::set<std::uint32_t> ls;
        for (std::size_t j = 0; j < fan.size(); ++j) {
          const std::uint32_t x = labels[fan[j]], y = labels[fan[(j + 1) % fan.size()]];
          if (x != y && !g.are_edge_adjacent(x, y)) tree = false;
          ls.insert(x);
        }
        if (!tree) break;
        std::size_t adjacencies = 0;
        for (std::uint32_t x : ls)
          for (std::uint32_t y : ls) adjacencies += x < y && g.are_edge_adjacent(x, y);
        if (adjacencies + 1 != ls.size()) tree = false;
      }
      r.is_tree = tree;
      if (!unlabelled) {
        std::vector<std::uint32_t> common;
        for (std::uint32_t gv = 0; gv < g.vertex_count(); ++gv) {
          bool all = true;
          for (std::uint32_t l : distinct) all = all && g.triangle_has_vertex(l, gv);
          if (all) common.push_back(gv);
        }
        if (common.size() == 1) {
          r.gauss_vertex = common[0];
          const auto around = g.vertex_triangles(common[0]);
          for (std::size_t k = 0; k < around.size() && k < 8; ++k)
            if (distinct.count(around[k])) r.cover_mask |= static_cast<std::uint8_t>(1u << k);
        }
      }
    }
    int w_vg = 0, first = 0;
    std::uint32_t exact_g = kNoGaussVertex, enclosed = 0;
    bool fallback = false;
    for (const auto& fan : fans) {
      std::vector<Vec3d> poly;
      for (std::uint32_t f : fan)
        if (!n.degenerate[f]) poly.push_back(d3(n.normal[f]));
      if (poly.size() < 3) continue;
      Vec3d c{};
      for (const Vec3d& p : poly) c = c + p;
      const double len = std::sqrt(dot(c, c));
      if (!(len > 0)) {
        fallback = true;
        continue;
      }
      c = (1.0 / len) * c;
      double cos_theta = 1;
      for (const Vec3d& p : poly) cos_theta = std::min(cos_theta, dot(p, c));
      if (!(cos_theta > kMargin)) {
        fallback = true;
        continue;
      }
      if (r.gauss_vertex != kNoGaussVertex && dot(g.vertex(r.gauss_vertex), c) > kMargin)
        w_vg += ref_winding(poly, g.vertex(r.gauss_vertex));
      if (!test_exact) continue;
      // Every Gaussian vertex in the open hemisphere (with margin): outside the polygon's cap
      // the winding is exactly zero, so this is the cap search without the search.
      for (std::uint32_t gv = 0; gv < g.vertex_count(); ++gv) {
        const double gc = dot(g.vertex(gv), c);
        if (!(gc > kMargin) || gc < cos_theta - 1e-3) continue;  // outside the cap: winding 0
        const int w = ref_winding(poly, g.vertex(gv));
        if (w == 0) continue;
        ++enclosed;
        if (exact_g == kNoGaussVertex || gv < exact_g) {
          exact_g = gv;
          first = w;
        }
      }
    }
    if (r.gauss_vertex != kNoGaussVertex) {
      r.winding = static_cast<std::int8_t>(std::clamp(w_vg, -127, 127));
      r.characteristic = ref_classify(w_vg, side(g.vertex(r.gauss_vertex)));
    }
    if (test_exact) {
      r.is_exact_sample = enclosed > 0 || (fallback && r.is_candidate);
      r.enclosed = static_cast<std::uint8_t>(std::min<std::uint32_t>(enclosed, 255));
      if (exact_g != kNoGaussVertex) {
        r.exact_gauss_vertex = exact_g;
        r.exact_winding = static_cast<std::int8_t>(std::clamp(first, -127, 127));
        r.exact_characteristic = ref_classify(first, side(g.vertex(exact_g)));
      }
    }
    if (r.is_candidate || r.is_exact_sample) out.push_back(r);
  }
  return out;
}

// ---- Reference patches and merge plan -------------------------------------------------------

Patches ref_patches(const MeshAdjacency& a, const std::vector<std::uint32_t>& labels,
                    const std::vector<std::uint8_t>& feature, const Mesh* keyed = nullptr) {
  const std::size_t nf = labels.size();
  Patches p;
  p.face_patch.assign(nf, kNoPatch);
  for (std::uint32_t seed = 0; seed < nf; ++seed) {
    if (p.face_patch[seed] != kNoPatch) continue;
    const std::uint32_t id = static_cast<std::uint32_t>(p.patch_label.size());
    p.patch_label.push_back(labels[seed]);
    std::vector<std::uint32_t> queue{seed};
    p.face_patch[seed] = id;
    for (std::size_t k = 0; k < queue.size(); ++k) {
      const std::uint32_t f = queue[k];
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t g = a.edge_neighbor[3 * f + i];
        if (!(feature[f] >> i & 1) && g != MeshAdjacency::kNoFace && p.face_patch[g] == kNoPatch) {
          p.face_patch[g] = id;
          queue.push_back(g);
        }
      }
    }
    p.patch_size.push_back(static_cast<std::uint32_t>(queue.size()));
  }
  if (!keyed) return p;
  // Renumbered by each patch's first face in the order of (face_order_key, id).
  std::map<std::pair<std::uint64_t, std::uint32_t>, std::uint32_t> first;  // -> patch
  std::vector<std::pair<std::uint64_t, std::uint32_t>> least(p.patch_label.size(), {~0ull, ~0u});
  for (std::uint32_t f = 0; f < nf; ++f) {
    const auto& t = keyed->triangles[f].v;
    const auto key = std::pair(face_order_key(keyed->positions[t[0]], keyed->positions[t[1]], keyed->positions[t[2]]), f);
    least[p.face_patch[f]] = std::min(least[p.face_patch[f]], key);
  }
  for (std::uint32_t q = 0; q < least.size(); ++q) first[least[q]] = q;
  std::vector<std::uint32_t> renamed(least.size());
  Patches out;
  for (const auto& [key, q] : first) {
    renamed[q] = static_cast<std::uint32_t>(out.patch_label.size());
    out.patch_label.push_back(p.patch_label[q]);
    out.patch_size.push_back(p.patch_size[q]);
  }
  for (std::uint32_t q : p.face_patch) out.face_patch.push_back(renamed[q]);
  return out;
}

std::vector<std::uint32_t> ref_plan(const Mesh& m, const MeshAdjacency& a, const Patches& p,
                                    const std::vector<std::uint8_t>& feature, const std::vector<std::uint8_t>& is_candidate) {
  const std::size_t np = p.patch_label.size();
  std::vector<std::set<std::uint32_t>> candidates(np);
  std::vector<std::map<std::uint32_t, std::uint32_t>> shared(np);  // neighbour -> feature edges
  for (std::uint32_t f = 0; f < m.triangles.size(); ++f) {
    const std::uint32_t q = p.face_patch[f];
    for (int i = 0; i < 3; ++i) {
      if (is_candidate[m.triangles[f].v[i]]) candidates[q].insert(m.triangles[f].v[i]);
      const std::uint32_t g = a.edge_neighbor[3 * f + i];
      if ((feature[f] >> i & 1) && g != MeshAdjacency::kNoFace && p.face_patch[g] != q) ++shared[q][p.face_patch[g]];
    }
  }
  std::vector<std::uint32_t> target(np, kNoPatch);
  std::vector<bool> absorbs(np, false);
  for (std::uint32_t q = 0; q < np; ++q) {
    if (candidates[q].size() >= 3 || shared[q].empty()) continue;
    std::uint32_t best = kNoPatch, count = 0;
    for (const auto& [r, c] : shared[q])
      if (c > count) {
        best = r;
        count = c;
      }
    if (absorbs[q] || target[best] != kNoPatch) continue;
    target[q] = best;
    absorbs[best] = true;
  }
  return target;
}

// The whole pass, from the reference steps (the loop of sample_mesh, written plainly).
SamplingResult ref_sample(const Mesh& m, const GaussSphere& g, const SamplerOptions& o, std::size_t& ambiguous) {
  const MeshAdjacency a = ref_adjacency(m);
  const FaceNormals n = ref_normals(m, a, o.smooth_iterations);
  std::vector<std::uint32_t> optimized = compute_face_labels(n, g);
  const RefLabels rl = ref_labels(n, g, optimized);
  ambiguous += rl.ambiguous;
  std::vector<std::uint32_t> labels = rl.label;
  std::vector<std::uint8_t> feature = ref_feature(m, labels);
  const std::uint32_t nv = static_cast<std::uint32_t>(m.positions.size());
  const bool exact = o.sample_test == SampleTest::kExact;
  std::map<std::uint32_t, VertexRecord> records;
  for (const VertexRecord& r : ref_vertices(m, a, n, labels, feature, g, exact, 0, nv)) records[r.vertex] = r;
  SamplingResult res;
  res.stats.degenerate_faces = n.degenerate_count;
  res.stats.unlabelled_faces = static_cast<std::size_t>(std::count(labels.begin(), labels.end(), kNoLabel));
  res.stats.break_edges = a.break_edges;
  for (const auto& [v, r] : records) {
    res.stats.candidates_initial += r.is_candidate;
    res.stats.exact_samples += r.is_exact_sample;
  }
  auto candidate_flags = [&] {
    std::vector<std::uint8_t> c(nv, 0);
    for (const auto& [v, r] : records) c[v] = r.is_candidate;
    return c;
  };
  std::vector<std::uint8_t> is_candidate = candidate_flags();
  Patches p = ref_patches(a, labels, feature, &m);
  for (int round = 0; round < 64; ++round) {
    const std::vector<std::uint32_t> plan = ref_plan(m, a, p, feature, is_candidate);
    std::set<std::uint32_t> touched;
    for (std::uint32_t f = 0; f < m.triangles.size(); ++f) {
      if (plan[p.face_patch[f]] == kNoPatch) continue;
      labels[f] = p.patch_label[plan[p.face_patch[f]]];
      touched.insert(m.triangles[f].v, m.triangles[f].v + 3);
    }
    if (touched.empty()) break;
    res.stats.merged_patches += static_cast<std::size_t>(std::count_if(plan.begin(), plan.end(), [](std::uint32_t t) { return t != kNoPatch; }));
    feature = ref_feature(m, labels);
    for (std::uint32_t v : touched) {
      auto old = records.find(v);
      const auto fresh = ref_vertices(m, a, n, labels, feature, g, false, v, v + 1);
      if (!fresh.empty()) {
        VertexRecord r = fresh[0];
        if (old != records.end()) {  // exact verdicts do not depend on labels
          r.is_exact_sample = old->second.is_exact_sample;
          r.enclosed = old->second.enclosed;
          r.exact_gauss_vertex = old->second.exact_gauss_vertex;
          r.exact_winding = old->second.exact_winding;
          r.exact_characteristic = old->second.exact_characteristic;
        }
        records[v] = r;
      } else if (old != records.end()) {
        if (old->second.is_exact_sample) {
          old->second.is_candidate = false;
          old->second.is_tree = false;
          old->second.gauss_vertex = kNoGaussVertex;
          old->second.characteristic = Characteristic::kNone;
        } else {
          records.erase(old);
        }
      }
    }
    is_candidate = candidate_flags();
    p = ref_patches(a, labels, feature, &m);
  }
  res.face_label = labels;
  res.face_feature = feature;
  res.face_patch = p.face_patch;
  res.patch_label = p.patch_label;
  res.patch_count = p.patch_label.size();
  std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::uint32_t f = 0; f < m.triangles.size(); ++f)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t h = a.edge_neighbor[3 * f + i];
      if (h != MeshAdjacency::kNoFace && p.face_patch[f] < p.face_patch[h]) pairs.insert({p.face_patch[f], p.face_patch[h]});
    }
  res.patch_adjacency.assign(pairs.begin(), pairs.end());
  for (const auto& [v, r] : records)
    if (r.is_candidate) res.candidates.push_back(r);
  if (exact) {
    for (const auto& [v, r] : records)
      if (r.is_exact_sample) res.samples.push_back({v, r.exact_gauss_vertex, r.exact_characteristic});
  } else {
    std::vector<NoisyFilterInput> survivors;
    for (const VertexRecord& r : res.candidates) {
      if (r.is_tree) {
        ++res.stats.tree_filtered;
      } else if (o.drop_unwinding_candidates && r.gauss_vertex != kNoGaussVertex && r.characteristic == Characteristic::kNone) {
        ++res.stats.unwinding_filtered;
      } else {
        survivors.push_back({r.vertex, r.gauss_vertex, static_cast<std::uint8_t>(r.characteristic), r.cover_mask});
      }
    }
    // Candidate adjacency along feature chains (plain walk over the reference adjacency).
    std::set<std::pair<std::uint32_t, std::uint32_t>> chain_pairs;
    auto feature_neighbors = [&](std::uint32_t v) {
      std::vector<std::uint32_t> out;
      for (std::uint32_t s = a.star_begin(v); s < a.star_end(v); ++s) {
        const std::uint32_t c = a.vertex_corners[s], f = c / 3, i = c % 3;
        if (res.face_feature[f] >> i & 1) out.push_back(m.triangles[f].v[(i + 1) % 3]);
        if (a.edge_neighbor[3 * f + (i + 2) % 3] == MeshAdjacency::kNoFace) out.push_back(m.triangles[f].v[(i + 2) % 3]);
      }
      return out;
    };
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (!is_candidate[v]) continue;
      for (std::uint32_t first : feature_neighbors(v)) {
        std::uint32_t prev = v, cur = first;
        for (std::size_t steps = 0; steps <= nv; ++steps) {
          if (is_candidate[cur]) {
            if (cur != v) chain_pairs.insert({std::min(v, cur), std::max(v, cur)});
            break;
          }
          const auto step = feature_neighbors(cur);
          if (step.size() != 2) break;
          const std::uint32_t next = step[0] == prev ? step[1] : step[0];
          prev = cur;
          cur = next;
        }
      }
    }
    const std::vector<std::pair<std::uint32_t, std::uint32_t>> pair_list(chain_pairs.begin(), chain_pairs.end());
    const auto keep = noisy_sample_filter(survivors, pair_list);  // the tiny exhaustive cover
    for (std::size_t k = 0; k < survivors.size(); ++k) {
      if (!keep[k]) ++res.stats.noisy_filtered;
      else res.samples.push_back({survivors[k].vertex, survivors[k].gauss_vertex, static_cast<Characteristic>(survivors[k].characteristic)});
    }
  }
  return res;
}

// ---- The O(mesh)-per-round merge (reference for the patch-graph merge) ------------------------

// sample_mesh with the merge run on the mesh instead of the patch graph: every round plans over
// all faces (plan_untriangulatable_merges), relabels the merged faces, updates their feature bits,
// re-evaluates every vertex of a merged face and runs find_patches again. Built from the
// public steps (which the tests above check against their own references).
SamplingResult mesh_round_sample(const Mesh& m, const GaussSphere& g, const SamplerOptions& o) {
  const MeshAdjacency a = build_mesh_adjacency(m.view()).value();
  const FaceNormals n = compute_face_normals(m.view(), a, o.smooth_iterations);
  std::vector<std::uint32_t> labels = compute_face_labels(n, g);
  std::vector<std::uint8_t> feature = compute_feature_edges(a, labels);
  const std::uint32_t nv = static_cast<std::uint32_t>(m.positions.size());
  const bool exact = o.sample_test == SampleTest::kExact;
  std::vector<VertexRecord> first;
  evaluate_vertices(m.view(), a, n, labels, feature, g, exact, 0, nv, first);
  std::map<std::uint32_t, VertexRecord> records;
  for (const VertexRecord& r : first) records[r.vertex] = r;
  SamplingResult res;
  res.stats.degenerate_faces = n.degenerate_count;
  res.stats.unlabelled_faces = static_cast<std::size_t>(std::count(labels.begin(), labels.end(), kNoLabel));
  res.stats.break_edges = a.break_edges;
  std::vector<std::uint8_t> is_candidate(nv, 0);
  for (const auto& [v, r] : records) {
    res.stats.candidates_initial += r.is_candidate;
    res.stats.exact_samples += r.is_exact_sample;
    is_candidate[v] = r.is_candidate;
  }
  std::vector<std::uint64_t> keys;
  face_order_keys(m.view(), keys);
  Patches p = find_patches(a, labels, feature, keys);
  for (int round = 0; round < kMaxMergeRounds; ++round) {
    const std::vector<std::uint32_t> plan = plan_untriangulatable_merges(m.view(), a, p, feature, is_candidate);
    const auto merging =
        static_cast<std::size_t>(std::count_if(plan.begin(), plan.end(), [](std::uint32_t t) { return t != kNoPatch; }));
    if (merging == 0) break;
    res.stats.merged_patches += merging;
    ++res.stats.merge_rounds;
    std::set<std::uint32_t> touched;
    for (std::uint32_t f = 0; f < m.triangles.size(); ++f) {
      if (plan[p.face_patch[f]] == kNoPatch) continue;
      labels[f] = p.patch_label[plan[p.face_patch[f]]];
      touched.insert(m.triangles[f].v, m.triangles[f].v + 3);
    }
    feature = compute_feature_edges(a, labels);
    const std::vector<std::uint32_t> list(touched.begin(), touched.end());
    std::vector<VertexRecord> fresh;
    evaluate_vertex_list(m.view(), a, n, labels, feature, g, false, list, fresh);
    std::size_t k = 0;
    for (std::uint32_t v : list) {
      auto old = records.find(v);
      if (k < fresh.size() && fresh[k].vertex == v) {
        VertexRecord r = fresh[k++];
        if (old != records.end()) {
          r.is_exact_sample = old->second.is_exact_sample;
          r.enclosed = old->second.enclosed;
          r.exact_gauss_vertex = old->second.exact_gauss_vertex;
          r.exact_winding = old->second.exact_winding;
          r.exact_characteristic = old->second.exact_characteristic;
        }
        records[v] = r;
        is_candidate[v] = r.is_candidate;
      } else {
        is_candidate[v] = 0;
        if (old == records.end()) continue;
        if (old->second.is_exact_sample) {
          old->second.is_candidate = false;
          old->second.is_tree = false;
          old->second.gauss_vertex = kNoGaussVertex;
          old->second.characteristic = Characteristic::kNone;
        } else {
          records.erase(old);
        }
      }
    }
    p = find_patches(a, labels, feature, keys);
  }
  res.face_label = labels;
  res.face_feature = feature;
  res.face_patch = p.face_patch;
  res.patch_label = p.patch_label;
  res.patch_count = p.patch_label.size();
  std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::uint32_t f = 0; f < m.triangles.size(); ++f)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t h = a.edge_neighbor[3 * f + i];
      if (h != MeshAdjacency::kNoFace && p.face_patch[f] < p.face_patch[h]) pairs.insert({p.face_patch[f], p.face_patch[h]});
    }
  res.patch_adjacency.assign(pairs.begin(), pairs.end());
  for (const auto& [v, r] : records)
    if (r.is_candidate) res.candidates.push_back(r);
  if (exact) {
    for (const auto& [v, r] : records)
      if (r.is_exact_sample) res.samples.push_back({v, r.exact_gauss_vertex, r.exact_characteristic});
  } else {
    std::vector<NoisyFilterInput> survivors;
    for (const VertexRecord& r : res.candidates) {
      if (r.is_tree) {
        ++res.stats.tree_filtered;
      } else if (o.drop_unwinding_candidates && r.gauss_vertex != kNoGaussVertex && r.characteristic == Characteristic::kNone) {
        ++res.stats.unwinding_filtered;
      } else {
        survivors.push_back({r.vertex, r.gauss_vertex, static_cast<std::uint8_t>(r.characteristic), r.cover_mask});
      }
    }
    const auto keep = noisy_sample_filter(survivors, find_candidate_adjacency(m.view(), a, res.face_feature, is_candidate));
    for (std::size_t k = 0; k < survivors.size(); ++k) {
      if (!keep[k]) ++res.stats.noisy_filtered;
      else res.samples.push_back({survivors[k].vertex, survivors[k].gauss_vertex, static_cast<Characteristic>(survivors[k].characteristic)});
    }
  }
  return res;
}

// ---- Comparisons ---------------------------------------------------------------------------

bool same_record(const VertexRecord& a, const VertexRecord& b) {
  return a.vertex == b.vertex && a.gauss_vertex == b.gauss_vertex && a.characteristic == b.characteristic &&
         a.winding == b.winding && a.feature_edges == b.feature_edges && a.is_candidate == b.is_candidate &&
         a.is_tree == b.is_tree && a.is_exact_sample == b.is_exact_sample && a.enclosed == b.enclosed &&
         a.exact_gauss_vertex == b.exact_gauss_vertex && a.exact_winding == b.exact_winding &&
         a.exact_characteristic == b.exact_characteristic && a.cover_mask == b.cover_mask;
}

void expect_same_records(const std::vector<VertexRecord>& got, const std::vector<VertexRecord>& want, const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  std::size_t bad = 0;
  for (std::size_t k = 0; k < got.size(); ++k)
    if (!same_record(got[k], want[k]) && bad++ < 5) ADD_FAILURE() << what << ": record of vertex " << want[k].vertex;
  EXPECT_EQ(bad, 0u) << what;
}

struct Case {
  std::string name;
  Mesh mesh;
};

// A noisy torus with defects: holes (boundaries), collapsed faces, a duplicated face
// (non-manifold edges) and a flipped face (inconsistent orientation).
Mesh defective_torus(std::size_t vertices, double noise) {
  testing::ShapeOptions o;
  o.vertices = vertices;
  o.noise = noise;
  o.seed = 7;
  o.rotation = testing::random_rotation(11);
  Mesh m = testing::make_torus(1, 0.4, o);
  Mesh out;
  out.positions = m.positions;
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    Triangle t = m.triangles[f];
    if (f % 97 == 5) continue;                // hole
    if (f % 211 == 7) t.v[2] = t.v[0];        // collapsed
    if (f % 307 == 9) std::swap(t.v[1], t.v[2]);  // flipped
    out.triangles.push_back(t);
    if (f % 401 == 11) out.triangles.push_back(t);  // duplicated: non-manifold edges
  }
  // A zero-area (degenerate, not collapsed) face: three collinear new vertices.
  const auto base = static_cast<format::VertexIndex>(out.positions.size());
  out.positions.push_back({5, 5, 5});
  out.positions.push_back({6, 6, 6});
  out.positions.push_back({7, 7, 7});
  out.triangles.push_back({{base, base + 1, base + 2}});
  return out;
}

// Two cones of 60 triangles sharing their apex (a non-manifold vertex of degree > 100), one
// with a missing and a duplicated triangle: the adjacency's large-star path.
Mesh double_cone() {
  Mesh m;
  m.positions.push_back({0, 0, 0});
  const std::uint32_t n = 60;
  for (int side : {1, -1})
    for (std::uint32_t k = 0; k < n; ++k) {
      const double a = 2 * 3.14159265358979 * k / n;
      m.positions.push_back({float(std::cos(a)), float(std::sin(a)), float(side * (0.5 + 0.05 * std::sin(7.0 * k)))});
    }
  for (std::uint32_t cone = 0; cone < 2; ++cone)
    for (std::uint32_t k = 0; k < n; ++k) {
      const std::uint32_t a = 1 + cone * n + k, b = 1 + cone * n + (k + 1) % n;
      if (cone == 1 && k == 3) continue;
      if (cone == 0) m.triangles.push_back({{0, b, a}});
      else m.triangles.push_back({{0, a, b}});
      if (cone == 1 && k == 9) m.triangles.push_back(m.triangles.back());
    }
  return m;
}

const std::vector<Case>& cases() {
  static const std::vector<Case> all = [] {
    std::vector<Case> c;
    for (const char* name : {"bunny-lowres.ply", "cow.off", "fandisk.off", "homer.off", "knot1.off",
                             "mech-holes-shark.off", "mushroom.off"}) {
      auto mesh = load_mesh(testing::fixture(std::string("real/") + name));
      EXPECT_TRUE(mesh.is_ok()) << name;
      if (mesh.is_ok()) c.push_back({name, std::move(mesh).value()});
    }
    c.push_back({"noisy defective torus", defective_torus(6000, 2e-3)});
    c.push_back({"double cone", double_cone()});
    testing::ShapeOptions o;
    o.vertices = 4000;
    o.noise = 1e-3;
    o.seed = 5;
    c.push_back({"noisy dented sphere", testing::make_dented_sphere(0.4, o)});
    return c;
  }();
  return all;
}

GaussSphere sphere(std::uint32_t f, std::uint64_t seed) {
  GaussSphereOptions o;
  o.frequency = f;
  o.rotation = gauss_rotation_from_seed(seed);
  return GaussSphere::create(o).value();
}

TEST(SamplerRegression, AdjacencyEqualsMapReference) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    const MeshAdjacency got = build_mesh_adjacency(c.mesh.view()).value();
    const MeshAdjacency want = ref_adjacency(c.mesh);
    EXPECT_EQ(got.vertex_offsets, want.vertex_offsets);
    EXPECT_EQ(got.vertex_corners, want.vertex_corners);
    EXPECT_EQ(got.slot_flags, want.slot_flags);
    EXPECT_EQ(got.edge_neighbor, want.edge_neighbor);
    EXPECT_EQ(got.collapsed_faces, want.collapsed_faces);
    EXPECT_EQ(got.break_edges, want.break_edges);
  }
}

TEST(SamplerRegression, StepsEqualReference) {
  std::size_t ambiguous = 0, faces = 0;
  for (const Case& c : cases()) {
    const MeshAdjacency adj = build_mesh_adjacency(c.mesh.view()).value();
    const std::uint32_t nv = static_cast<std::uint32_t>(c.mesh.positions.size());
    for (std::uint32_t smooth : {0u, 2u}) {
      const FaceNormals got_n = compute_face_normals(c.mesh.view(), adj, smooth);
      const FaceNormals want_n = ref_normals(c.mesh, adj, smooth);
      ASSERT_EQ(got_n.degenerate, want_n.degenerate) << c.name;
      EXPECT_EQ(got_n.degenerate_count, want_n.degenerate_count);
      std::size_t bad = 0;
      for (std::size_t f = 0; f < got_n.normal.size(); ++f)
        bad += std::memcmp(&got_n.normal[f], &want_n.normal[f], sizeof(Vec3f)) != 0;
      ASSERT_EQ(bad, 0u) << c.name << " smooth " << smooth << ": normals differ";
      for (std::uint32_t f : {2u, 4u, 8u}) {
        SCOPED_TRACE(c.name + " smooth " + std::to_string(smooth) + " f " + std::to_string(f));
        const GaussSphere g = sphere(f, 1 + f);
        const auto labels = compute_face_labels(got_n, g);
        const RefLabels want_l = ref_labels(want_n, g, labels);
        ambiguous += want_l.ambiguous;
        faces += labels.size();
        ASSERT_EQ(labels, want_l.label);
        const auto feature = compute_feature_edges(adj, labels);
        ASSERT_EQ(feature, ref_feature(c.mesh, labels));
        for (bool exact : {false, true}) {
          std::vector<VertexRecord> got;
          evaluate_vertices(c.mesh.view(), adj, got_n, labels, feature, g, exact, 0, nv, got);
          expect_same_records(got, ref_vertices(c.mesh, adj, want_n, labels, feature, g, exact, 0, nv),
                              exact ? "exact" : "paper");
        }
        const Patches p = find_patches(adj, labels, feature);
        const Patches q = ref_patches(adj, labels, feature);
        EXPECT_EQ(p.face_patch, q.face_patch);
        EXPECT_EQ(p.patch_label, q.patch_label);
        EXPECT_EQ(p.patch_size, q.patch_size);
      }
    }
  }
  std::printf("labels on a cell boundary to double rounding: %zu of %zu\n", ambiguous, faces);
  EXPECT_LE(ambiguous * 10000, faces);
}

TEST(SamplerRegression, WholePassEqualsReference) {
  std::size_t ambiguous = 0;
  for (const Case& c : cases()) {
    for (std::uint32_t f : {2u, 4u, 8u})
      for (std::uint32_t smooth : {0u, 2u})
        for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) {
          SCOPED_TRACE(c.name + " f " + std::to_string(f) + " smooth " + std::to_string(smooth) + " " + sample_test_name(test));
          const GaussSphere g = sphere(f, 20 + f);
          SamplerOptions o;
          o.smooth_iterations = smooth;
          o.sample_test = test;
          const SamplingResult got = sample_mesh(c.mesh.view(), g, o).value();
          const SamplingResult want = ref_sample(c.mesh, g, o, ambiguous);
          EXPECT_EQ(got.face_label, want.face_label);
          EXPECT_EQ(got.face_feature, want.face_feature);
          EXPECT_EQ(got.face_patch, want.face_patch);
          EXPECT_EQ(got.patch_label, want.patch_label);
          EXPECT_EQ(got.patch_count, want.patch_count);
          EXPECT_EQ(got.patch_adjacency, want.patch_adjacency);
          expect_same_records(got.candidates, want.candidates, "candidates");
          ASSERT_EQ(got.samples.size(), want.samples.size());
          for (std::size_t k = 0; k < got.samples.size(); ++k) {
            EXPECT_EQ(got.samples[k].vertex, want.samples[k].vertex);
            EXPECT_EQ(got.samples[k].gauss_vertex, want.samples[k].gauss_vertex);
            EXPECT_EQ(got.samples[k].characteristic, want.samples[k].characteristic);
          }
          const SamplingStats& a = got.stats;
          const SamplingStats& b = want.stats;
          EXPECT_EQ(a.degenerate_faces, b.degenerate_faces);
          EXPECT_EQ(a.unlabelled_faces, b.unlabelled_faces);
          EXPECT_EQ(a.break_edges, b.break_edges);
          EXPECT_EQ(a.candidates_initial, b.candidates_initial);
          EXPECT_EQ(a.merged_patches, b.merged_patches);
          EXPECT_EQ(a.tree_filtered, b.tree_filtered);
          EXPECT_EQ(a.unwinding_filtered, b.unwinding_filtered);
          EXPECT_EQ(a.noisy_filtered, b.noisy_filtered);
          EXPECT_EQ(a.exact_samples, b.exact_samples);
        }
  }
}

// Every field of two results (the patch graph consumes all of them).
void expect_same_result(const SamplingResult& got, const SamplingResult& want) {
  EXPECT_EQ(got.face_label, want.face_label);
  EXPECT_EQ(got.face_feature, want.face_feature);
  EXPECT_EQ(got.face_patch, want.face_patch);
  EXPECT_EQ(got.patch_label, want.patch_label);
  EXPECT_EQ(got.patch_count, want.patch_count);
  EXPECT_EQ(got.patch_adjacency, want.patch_adjacency);
  expect_same_records(got.candidates, want.candidates, "candidates");
  ASSERT_EQ(got.samples.size(), want.samples.size());
  std::size_t bad = 0;
  for (std::size_t k = 0; k < got.samples.size(); ++k)
    bad += got.samples[k].vertex != want.samples[k].vertex || got.samples[k].gauss_vertex != want.samples[k].gauss_vertex ||
           got.samples[k].characteristic != want.samples[k].characteristic;
  EXPECT_EQ(bad, 0u) << "samples differ";
  const SamplingStats& a = got.stats;
  const SamplingStats& b = want.stats;
  EXPECT_EQ(a.degenerate_faces, b.degenerate_faces);
  EXPECT_EQ(a.unlabelled_faces, b.unlabelled_faces);
  EXPECT_EQ(a.break_edges, b.break_edges);
  EXPECT_EQ(a.candidates_initial, b.candidates_initial);
  EXPECT_EQ(a.merged_patches, b.merged_patches);
  EXPECT_EQ(a.merge_rounds, b.merge_rounds);
  EXPECT_EQ(a.tree_filtered, b.tree_filtered);
  EXPECT_EQ(a.unwinding_filtered, b.unwinding_filtered);
  EXPECT_EQ(a.noisy_filtered, b.noisy_filtered);
  EXPECT_EQ(a.exact_samples, b.exact_samples);
}

// The merge on the patch graph (sample_mesh) against the previous merge over the mesh, round
// by round (mesh_round_sample): the same decisions everywhere — on every real fixture in eight
// orientations of G at f = 4 and 8, and on noisy generated shapes (many patches merge, over
// many rounds, and candidates lose their candidacy), both sample tests, with and without
// smoothing. One workspace is reused throughout, as --orientations does.
TEST(SamplerRegression, GraphMergeEqualsMergeRoundsOverTheMesh) {
  SamplerWorkspace ws;
  SamplingResult got;
  struct Totals {
    std::size_t runs = 0, merged = 0, max_rounds = 0, dropped = 0;
  };
  auto check = [&](const std::string& name, const Mesh& m, std::uint32_t f, std::uint64_t seed, std::uint32_t smooth,
                   SampleTest test, Totals& t) {
    SCOPED_TRACE(name + " f " + std::to_string(f) + " seed " + std::to_string(seed) + " smooth " +
                 std::to_string(smooth) + " " + sample_test_name(test));
    const GaussSphere g = sphere(f, seed);
    SamplerOptions o;
    o.smooth_iterations = smooth;
    o.sample_test = test;
    ASSERT_TRUE(sample_mesh(m.view(), g, o, ws, got).is_ok());
    const SamplingResult want = mesh_round_sample(m, g, o);
    expect_same_result(got, want);
    ++t.runs;
    t.merged += want.stats.merged_patches;
    t.max_rounds = std::max(t.max_rounds, want.stats.merge_rounds);
    t.dropped += want.stats.candidates_initial - want.candidates.size();
  };
  Totals fixtures;
  for (const Case& c : cases()) {
    if (c.name.find(".off") == std::string::npos && c.name.find(".ply") == std::string::npos) continue;
    Totals one;
    for (std::uint64_t seed = 1; seed <= 8; ++seed)
      for (std::uint32_t f : {4u, 8u})
        for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) check(c.name, c.mesh, f, seed, 0, test, one);
    EXPECT_GT(one.merged, 0u) << c.name << ": no merge in any orientation";
    fixtures.merged += one.merged;
    fixtures.max_rounds = std::max(fixtures.max_rounds, one.max_rounds);
    fixtures.dropped += one.dropped;
    fixtures.runs += one.runs;
  }
  EXPECT_EQ(fixtures.runs, 7u * 8 * 2 * 2);

  std::vector<std::pair<std::string, Mesh>> noisy;
  testing::ShapeOptions o;
  o.vertices = 12000;
  o.noise = 2e-3;
  o.seed = 3;
  o.rotation = testing::random_rotation(5);
  noisy.emplace_back("noisy torus", testing::make_torus(1, 0.35, o));
  noisy.emplace_back("noisy sphere", testing::make_sphere(o));
  noisy.emplace_back("noisy rounded cube", testing::make_rounded_cube(6, o));
  noisy.emplace_back("noisy genus 2", testing::make_genus2(o));
  o.noise = 5e-4;
  noisy.emplace_back("dented sphere, light noise", testing::make_dented_sphere(0.4, o));
  noisy.emplace_back("noisy defective torus", defective_torus(12000, 2e-3));
  Totals shapes;
  for (const auto& [name, m] : noisy) {
    Totals one;
    for (std::uint32_t f : {2u, 4u, 8u})
      for (std::uint32_t smooth : {0u, 1u})
        for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) check(name, m, f, 40 + f, smooth, test, one);
    EXPECT_GT(one.merged, 0u) << name;
    EXPECT_GT(one.dropped, 0u) << name;
    shapes.merged += one.merged;
    shapes.max_rounds = std::max(shapes.max_rounds, one.max_rounds);
  }
  std::printf("fixtures: %zu runs, %zu patches merged, up to %zu rounds, %zu candidates dropped; noisy shapes: %zu "
              "merged, up to %zu rounds\n",
              fixtures.runs, fixtures.merged, fixtures.max_rounds, fixtures.dropped, shapes.merged, shapes.max_rounds);
  EXPECT_GE(fixtures.max_rounds, 3u);
  EXPECT_GE(shapes.max_rounds, 5u);
}

// Enough candidates touched in one round (> 32768: 37403 in the first round here) for the
// re-evaluation during the merge to run in parallel blocks (reading labels from the patch
// graph, concurrently): still the decisions of the merge over the mesh.
TEST(SamplerRegression, ParallelReevaluationDuringTheMergeEqualsMergeRoundsOverTheMesh) {
  testing::ShapeOptions o;
  o.vertices = 400000;
  o.noise = 4e-5;
  o.seed = 9;
  o.rotation = testing::random_rotation(3);
  const Mesh m = testing::make_torus(1, 0.4, o);
  const GaussSphere g = sphere(8, 7);
  for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) {
    SCOPED_TRACE(sample_test_name(test));
    SamplerOptions so;
    so.sample_test = test;
    const SamplingResult got = sample_mesh(m.view(), g, so).value();
    const SamplingResult want = mesh_round_sample(m, g, so);
    expect_same_result(got, want);
    std::printf("%s: %zu candidates, %zu patches merged in %zu rounds, %zu candidates left\n", sample_test_name(test),
                want.stats.candidates_initial, want.stats.merged_patches, want.stats.merge_rounds, want.candidates.size());
    EXPECT_GT(want.stats.merged_patches, 32768u);
  }
}

// The sampler's orientation sign (a static filter in front of the exact predicate) against the
// exact predicate alone: random unit vectors, nearly coplanar triples, exactly coplanar ones,
// and tiny and huge magnitudes.
TEST(SamplerRegression, FilteredOrientationSignEqualsExact) {
  std::uint64_t state = 777;
  auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return double(state >> 11) * 0x1.0p-53 * 2 - 1;
  };
  for (int k = 0; k < 300000; ++k) {
    Vec3d a{next(), next(), next()}, b{next(), next(), next()}, c{next(), next(), next()};
    switch (k % 5) {
      case 1: c = 0.3 * a + 0.7 * b + 1e-15 * c; break;       // nearly coplanar
      case 2: c = 0.5 * a + 0.25 * b; break;                  // coplanar up to rounding
      case 3: c = a; break;                                   // exactly degenerate
      case 4: {
        const double scale = k % 2 ? 1e-160 : 1e160;          // outside the filter's range
        a = scale * a;
        break;
      }
      default: break;
    }
    ASSERT_EQ(orientation_sign(a, b, c), ref_orient(a, b, c)) << "case " << k;
  }
}

// locate() against brute-force exact containment on random directions, on every base, with
// directions concentrated near base-face boundaries too (where the base-face choice is close).
TEST(SamplerRegression, LocateEqualsBruteForceContainment) {
  std::uint64_t state = 12345;
  auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return double(state >> 11) * 0x1.0p-53 * 2 - 1;
  };
  std::size_t ambiguous = 0, total = 0;
  for (GaussBase base : {GaussBase::kTetrahedron, GaussBase::kOctahedron, GaussBase::kIcosahedron})
    for (std::uint32_t f : {1u, 3u}) {
      GaussSphereOptions o;
      o.base = base;
      o.frequency = f;
      o.rotation = gauss_rotation_from_seed(f + 7);
      const GaussSphere g = GaussSphere::create(o).value();
      for (int k = 0; k < 40000; ++k) {
        Vec3d n{next(), next(), next()};
        if (k % 2) {
          // Near the great circle through two Gaussian vertices (an edge of G or beyond).
          const Vec3d& a = g.vertex(static_cast<std::uint32_t>((k / 2) % g.vertex_count()));
          const Vec3d& b = g.vertex(static_cast<std::uint32_t>((k / 3) % g.vertex_count()));
          const double t = 0.5 + 0.5 * next();
          n = t * a + (1 - t) * b + 1e-9 * n;
        }
        if (dot(n, n) < 1e-12) continue;
        ++total;
        const std::uint32_t got = g.locate(n);
        const Containment c = contain(g, n);
        if (c.holders.size() == 1 && !c.near_boundary) {
          ASSERT_EQ(got, c.holders[0]) << "direction " << n.x << " " << n.y << " " << n.z;
        } else {
          ++ambiguous;
          const auto& tv = g.triangle_vertices(got);
          double worst = 0;
          for (int i = 0; i < 3; ++i) worst = std::min(worst, dot(cross(g.vertex(tv[i]), g.vertex(tv[(i + 1) % 3])), n));
          EXPECT_GT(worst, -1e-12 * std::sqrt(dot(n, n)));
        }
      }
    }
  std::printf("locate: %zu of %zu directions within rounding of a cell boundary\n", ambiguous, total);
}

// Large enough (> 16384 faces, > 32768 vertices) for the parallel per-face and per-vertex paths
// and the parallel adjacency, with noise so that many patches merge.
TEST(SamplerRegression, LargeMeshTakesParallelPathsWithSameDecisions) {
  const Mesh m = defective_torus(40000, 1e-3);
  ASSERT_GT(m.positions.size(), 32768u);
  const MeshAdjacency adj = build_mesh_adjacency(m.view()).value();
  const MeshAdjacency ref = ref_adjacency(m);
  EXPECT_EQ(adj.vertex_corners, ref.vertex_corners);
  EXPECT_EQ(adj.slot_flags, ref.slot_flags);
  EXPECT_EQ(adj.edge_neighbor, ref.edge_neighbor);
  EXPECT_EQ(adj.break_edges, ref.break_edges);
  std::size_t ambiguous = 0;
  for (SampleTest test : {SampleTest::kExact, SampleTest::kPaper}) {
    const GaussSphere g = sphere(4, 3);
    SamplerOptions o;
    o.smooth_iterations = 1;
    o.sample_test = test;
    const SamplingResult got = sample_mesh(m.view(), g, o).value();
    const SamplingResult want = ref_sample(m, g, o, ambiguous);
    EXPECT_EQ(got.face_label, want.face_label);
    EXPECT_EQ(got.face_feature, want.face_feature);
    EXPECT_EQ(got.face_patch, want.face_patch);
    EXPECT_EQ(got.patch_adjacency, want.patch_adjacency);
    expect_same_records(got.candidates, want.candidates, "candidates");
    EXPECT_EQ(got.stats.merged_patches, want.stats.merged_patches);
    EXPECT_GT(got.stats.merged_patches, 0u);
    ASSERT_EQ(got.samples.size(), want.samples.size());
    for (std::size_t k = 0; k < got.samples.size(); ++k) EXPECT_EQ(got.samples[k].vertex, want.samples[k].vertex);
  }
}

}  // namespace
}  // namespace gaussmesh::stream
