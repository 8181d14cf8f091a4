// The connectivity the quadric finish collapses edges on: an indexed triangle mesh in flat
// arrays, with each vertex's faces and edges in singly linked lists through its corners and edge
// ends. A collapse hands the removed vertex's lists to the kept one and rewrites the corners; the
// faces and edges it kills stay in the lists until the next walk over them unlinks them. That
// keeps a collapse at the cost of the two vertices' degrees, with no allocation, which is most of
// the finish's time on large inputs (a half-edge library spent it on handle checks and status
// look-ups).
//
// Holds oriented manifolds only (the topology guarantee depends on it): every edge has one or two
// faces, two faces on an edge run it in opposite directions, and a vertex's faces form one fan, or
// only open ones (the border of a piece cut from a larger mesh may touch itself at a vertex).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "format/mesh_types.h"

namespace gaussmesh::stream {

class CollapseMesh {
 public:
  static constexpr std::uint32_t kNone = UINT32_MAX;

  struct Edge {
    std::array<std::uint32_t, 2> v;     // its ends
    std::array<std::uint32_t, 2> next;  // the next edge end in each end's list (edge * 2 + side)
    std::uint32_t faces;                // 1: on the boundary, 2: inside; 0: dead
  };

  // The faces across an edge: the third corner of each of its one or two faces.
  struct Across {
    std::uint32_t vertex[2] = {kNone, kNone};
    int count = 0;
  };

  // Builds the connectivity of `faces` over `vertices` vertices. The error names the first face
  // or vertex that breaks the manifold rules above (a corner out of range or repeated, an edge
  // with a third face or run twice the same way, a vertex with a closed fan and more).
  static std::optional<CollapseMesh> build(std::size_t vertices, std::span<const format::Triangle> faces,
                                           std::string& error);

  std::size_t vertex_count() const { return vertex_face_.size(); }
  std::size_t face_count() const { return faces_.size(); }
  std::size_t edge_count() const { return edges_.size(); }
  bool face_alive(std::uint32_t f) const { return face_alive_[f] != 0; }
  bool vertex_alive(std::uint32_t v) const { return vertex_alive_[v] != 0; }
  const format::Triangle& face(std::uint32_t f) const { return faces_[f]; }
  const Edge& edge(std::uint32_t e) const { return edges_[e]; }
  bool edge_alive(std::uint32_t e) const { return edges_[e].faces != 0; }
  bool is_boundary_edge(std::uint32_t e) const { return edges_[e].faces == 1; }
  bool is_boundary_vertex(std::uint32_t v);

  // Calls f(face) for each live face around v.
  template <class F>
  void for_each_face(std::uint32_t v, F&& f) {
    std::uint32_t prev = kNone;
    for (std::uint32_t c = vertex_face_[v]; c != kNone;) {
      const std::uint32_t next = corner_next_[c];
      if (!face_alive_[c / 3]) {
        (prev == kNone ? vertex_face_[v] : corner_next_[prev]) = next;
      } else {
        f(c / 3);
        prev = c;
      }
      c = next;
    }
  }
  // Calls f(edge, other end) for each live edge at v.
  template <class F>
  void for_each_edge(std::uint32_t v, F&& f) {
    std::uint32_t prev = kNone;
    for (std::uint32_t s = vertex_edge_[v]; s != kNone;) {
      const Edge& e = edges_[s >> 1];
      const std::uint32_t next = e.next[s & 1];
      if (e.faces == 0) {
        (prev == kNone ? vertex_edge_[v] : edges_[prev >> 1].next[prev & 1]) = next;
      } else {
        f(s >> 1, e.v[(s & 1) ^ 1]);
        prev = s;
      }
      s = next;
    }
  }

  // The edge from a to b, or kNone.
  std::uint32_t find_edge(std::uint32_t a, std::uint32_t b);
  // The third corners of the faces on edge a-b.
  Across across(std::uint32_t a, std::uint32_t b);

  // The link condition for collapsing `from` onto `to` (Dey et al.; OpenMesh's is_collapse_ok):
  // their one-rings meet only across the edge and their links share no edge (no faces from-c-d
  // and to-c-d for the corners c, d across), no face on the edge has its two other edges on the
  // boundary, and an edge between two boundary vertices is a boundary edge. On an oriented
  // manifold, a collapse that passes keeps the genus, the closedness and the boundary loops.
  // `stamp` holds one entry per vertex for the one-ring test; `across` receives the edge's
  // third corners.
  bool link_ok(std::uint32_t from, std::uint32_t to, std::vector<std::uint32_t>& stamp, std::uint32_t& epoch,
               Across& across);

  // Collapses edge `from`-`to` onto `to`; returns the number of faces removed (1 or 2).
  int collapse(std::uint32_t from, std::uint32_t to);

 private:
  std::vector<format::Triangle> faces_;
  std::vector<std::uint8_t> face_alive_;
  std::vector<std::uint32_t> corner_next_;  // per corner (face * 3 + k): the next at its vertex
  std::vector<std::uint32_t> vertex_face_;  // per vertex: its first corner
  std::vector<Edge> edges_;
  std::vector<std::uint32_t> vertex_edge_;  // per vertex: its first edge end
  std::vector<std::uint8_t> vertex_alive_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ring_from_, ring_to_;  // link_ok's scratch
};

}  // namespace gaussmesh::stream
