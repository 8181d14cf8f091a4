// find_seams against a plain reference (ordered maps, vertex by vertex): on random meshes whose
// vertices share positions (in groups of one to many, -0 and +0 among them) and values, with and
// without each kind of value, it welds the same positions, numbers positions and wedges in the
// order of their first vertex, and keeps the same faces and corner wedges.
#include <gtest/gtest.h>

#include <array>
#include <map>
#include <random>

#include "stream/attributes/seams.h"
#include "stream/core/canonical_order.h"

namespace gaussmesh::stream {
namespace {

using format::Color;
using format::Vec2f;
using Words = std::array<std::uint32_t, 9>;

Words values_of(MeshView m, std::uint32_t v) {
  Words w{};
  if (!m.normals.empty()) w[0] = ordered_bits(m.normals[v].x), w[1] = ordered_bits(m.normals[v].y), w[2] = ordered_bits(m.normals[v].z);
  if (!m.colors.empty()) w[3] = ordered_bits(m.colors[v].r), w[4] = ordered_bits(m.colors[v].g), w[5] = ordered_bits(m.colors[v].b), w[6] = ordered_bits(m.colors[v].a);
  if (!m.texcoords.empty()) w[7] = ordered_bits(m.texcoords[v].u), w[8] = ordered_bits(m.texcoords[v].v);
  return w;
}

// The rule as docs/attributes.md states it, one vertex at a time.
std::optional<Seams> reference_seams(MeshView m) {
  if ((m.normals.empty() && m.colors.empty() && m.texcoords.empty()) || m.triangles.empty()) return std::nullopt;
  const std::size_t n = m.positions.size();
  std::vector<bool> used(n, false);
  for (const auto& t : m.triangles)
    for (const auto v : t.v) used[v] = true;
  std::map<std::array<std::uint32_t, 3>, std::uint32_t> positions;
  std::map<std::pair<std::uint32_t, Words>, std::uint32_t> wedges;
  std::vector<std::uint32_t> by_position(n), wedge(n), wedge_count, first_vertex;
  Seams s;
  for (std::uint32_t v = 0; v < n; ++v) {
    if (!used[v]) continue;
    const auto& p = m.positions[v];
    auto [at, added] = positions.try_emplace({ordered_bits(p.x), ordered_bits(p.y), ordered_bits(p.z)}, std::uint32_t(positions.size()));
    by_position[v] = at->second;
    if (added) wedge_count.push_back(0), first_vertex.push_back(v);
    auto [w, new_wedge] = wedges.try_emplace({at->second, values_of(m, v)}, std::uint32_t(wedges.size()));
    wedge[v] = w->second;
    if (new_wedge) s.wedge_vertex.push_back(v), ++wedge_count[at->second];
  }
  for (const auto c : wedge_count) s.seam_vertices += c > 1;
  if (s.seam_vertices == 0) return std::nullopt;
  // Positions numbered by first vertex among those the kept faces use.
  std::vector<Triangle> kept;
  std::vector<bool> in_kept(first_vertex.size(), false);
  for (const auto& t : m.triangles) {
    const auto a = by_position[t.v[0]], b = by_position[t.v[1]], c = by_position[t.v[2]];
    if (a == b || b == c || a == c) continue;
    kept.push_back(t);
    in_kept[a] = in_kept[b] = in_kept[c] = true;
  }
  std::map<std::uint32_t, std::uint32_t> by_first;  // first vertex -> position
  for (std::uint32_t p = 0; p < first_vertex.size(); ++p)
    if (in_kept[p]) by_first[first_vertex[p]] = p;
  std::vector<std::uint32_t> index(first_vertex.size());
  for (const auto& [v, p] : by_first) {
    index[p] = std::uint32_t(s.welded.positions.size());
    s.welded.positions.push_back(m.positions[v]);
  }
  for (const auto& t : kept) {
    s.welded.triangles.push_back({{index[by_position[t.v[0]]], index[by_position[t.v[1]]], index[by_position[t.v[2]]]}});
    for (const auto v : t.v) s.corner_wedges.push_back(wedge[v]);
  }
  return s;
}

Mesh random_mesh(std::mt19937& rng, std::size_t vertices, std::size_t faces, int kinds) {
  Mesh m;
  std::uniform_int_distribution<int> place(0, int(vertices / 3)), value(0, 2), any(0, int(vertices) - 1);
  for (std::size_t v = 0; v < vertices; ++v) {
    const int p = place(rng);
    // Signed zeros: -0 and +0 are one position.
    const float zero = (rng() & 1) ? -0.0f : 0.0f;
    m.positions.push_back({p % 3 == 0 ? zero : float(p % 7), float(p / 7), zero});
    const float a = float(value(rng)), b = float(value(rng));
    if (kinds & 1) m.normals.push_back({a, 0, b == 0 ? zero : 1.0f});
    if (kinds & 2) m.colors.push_back(Color{a / 2, b / 2, 0.5f, 1.0f});
    if (kinds & 4) m.texcoords.push_back(Vec2f{a, b});
  }
  for (std::size_t f = 0; f < faces; ++f)
    m.triangles.push_back({{std::uint32_t(any(rng)), std::uint32_t(any(rng)), std::uint32_t(any(rng))}});
  return m;
}

TEST(Seams, FindSeamsNumbersAsTheReferenceDoes) {
  std::mt19937 rng(11);
  int compared = 0;
  for (int round = 0; round < 200; ++round) {
    const int kinds = 1 + round % 7;
    const std::size_t vertices = 3 + rng() % 300, faces = 1 + rng() % 400;
    const Mesh m = random_mesh(rng, vertices, faces, kinds);
    const auto want = reference_seams(m.view());
    const auto got = find_seams(m.view());
    ASSERT_EQ(got.has_value(), want.has_value()) << "round " << round;
    if (!want) continue;
    ++compared;
    EXPECT_EQ(got->seam_vertices, want->seam_vertices) << "round " << round;
    EXPECT_EQ(got->wedge_vertex, want->wedge_vertex) << "round " << round;
    EXPECT_EQ(got->welded.positions, want->welded.positions) << "round " << round;
    EXPECT_EQ(got->welded.triangles, want->welded.triangles) << "round " << round;
    EXPECT_EQ(got->corner_wedges, want->corner_wedges) << "round " << round;
  }
  EXPECT_GT(compared, 150);  // most rounds have seams to compare
}

TEST(Seams, NoSharedPositionOrNoValueMeansNoSeams) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{{0, 1, 2}}};
  EXPECT_FALSE(find_seams(m.view()).has_value());  // no values
  m.texcoords = {{0, 0}, {1, 0}, {0, 1}};
  EXPECT_FALSE(find_seams(m.view()).has_value());  // no two vertices at one place
  m.positions.push_back({1, 0, 0});
  m.texcoords.push_back({1, 0});
  m.triangles.push_back({{0, 3, 2}});
  EXPECT_FALSE(find_seams(m.view()).has_value());  // one place, the same values
  m.texcoords.back() = {0.5f, 0};
  const auto s = find_seams(m.view());
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->seam_vertices, 1u);
  EXPECT_EQ(s->welded.positions.size(), 3u);
}

}  // namespace
}  // namespace gaussmesh::stream
