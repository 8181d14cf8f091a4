#include "stream/finish/collapse_mesh.h"

#include <algorithm>
#include <utility>

namespace gaussmesh::stream {
namespace {

bool contains(const format::Triangle& t, std::uint32_t v) { return t.v[0] == v || t.v[1] == v || t.v[2] == v; }

}  // namespace

std::optional<CollapseMesh> CollapseMesh::build(std::size_t vertices, std::span<const format::Triangle> faces,
                                                std::string& error) {
  if (vertices >= kNone || faces.size() >= kNone / 3) {
    error = "too many vertices or faces";
    return std::nullopt;
  }
  CollapseMesh m;
  m.faces_.assign(faces.begin(), faces.end());
  m.face_alive_.assign(faces.size(), 1);
  m.corner_next_.assign(3 * faces.size(), kNone);
  m.vertex_face_.assign(vertices, kNone);
  m.vertex_edge_.assign(vertices, kNone);
  m.vertex_alive_.assign(vertices, 1);
  m.edges_.reserve(faces.size() * 3 / 2 + 16);
  // Each vertex's list in face order: built backwards, each corner in front.
  for (std::size_t f = faces.size(); f-- > 0;) {
    const auto& t = faces[f];
    for (int k = 0; k < 3; ++k) {
      if (t.v[k] >= vertices || t.v[k] == t.v[(k + 1) % 3]) {
        error = "face " + std::to_string(f) + (t.v[k] >= vertices ? " has a corner out of range" : " repeats a corner");
        return std::nullopt;
      }
      const std::uint32_t c = std::uint32_t(3 * f + k);
      m.corner_next_[c] = m.vertex_face_[t.v[k]];
      m.vertex_face_[t.v[k]] = c;
    }
  }
  // Edges in order of their first face; an edge runs v[0] → v[1] in its first face.
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& t = faces[f];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = t.v[k], w = t.v[(k + 1) % 3];
      const std::uint32_t e = m.find_edge(u, w);
      if (e == kNone) {
        const std::uint32_t id = std::uint32_t(m.edges_.size());
        m.edges_.push_back({{u, w}, {m.vertex_edge_[u], m.vertex_edge_[w]}, 1});
        m.vertex_edge_[u] = 2 * id;
        m.vertex_edge_[w] = 2 * id + 1;
      } else if (m.edges_[e].faces == 2 || m.edges_[e].v[0] == u) {
        error = "face " + std::to_string(f) + (m.edges_[e].faces == 2 ? " puts a third face on an edge"
                                                                       : " runs an edge the way another face does");
        return std::nullopt;
      } else {
        m.edges_[e].faces = 2;
      }
    }
  }
  // The fans around each vertex: one, or several open ones (a piece of a larger mesh may touch
  // itself at a vertex on its border, as a half-edge mesh allows too). Walking on from each fan's
  // first face (one whose previous corner starts no face here) must reach every face around the
  // vertex; with no such face the one closed fan must.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_previous;  // (previous corner, next corner)
  std::vector<std::uint32_t> nexts;
  for (std::uint32_t v = 0; v < vertices; ++v) {
    by_previous.clear();
    nexts.clear();
    for (std::uint32_t c = m.vertex_face_[v]; c != kNone; c = m.corner_next_[c]) {
      const auto& t = m.faces_[c / 3];
      const int k = int(c % 3);
      by_previous.push_back({t.v[(k + 2) % 3], t.v[(k + 1) % 3]});
      nexts.push_back(t.v[(k + 1) % 3]);
    }
    if (by_previous.size() < 2) continue;
    std::sort(by_previous.begin(), by_previous.end());
    std::sort(nexts.begin(), nexts.end());
    const auto walk = [&](std::size_t start) {  // faces of the fan from `start` on
      std::size_t reached = 1;
      for (std::size_t i = start;;) {
        const auto it = std::lower_bound(by_previous.begin(), by_previous.end(),
                                         std::pair<std::uint32_t, std::uint32_t>{by_previous[i].second, 0});
        if (it == by_previous.end() || it->first != by_previous[i].second) break;
        i = std::size_t(it - by_previous.begin());
        if (i == start || ++reached > by_previous.size()) break;
      }
      return reached;
    };
    std::size_t reached = 0, fans = 0;
    for (std::size_t i = 0; i < by_previous.size(); ++i) {
      if (!std::binary_search(nexts.begin(), nexts.end(), by_previous[i].first)) reached += walk(i), ++fans;
    }
    if (fans == 0) reached = walk(0);
    if (reached != by_previous.size()) {
      error = "vertex " + std::to_string(v) + " has a closed fan of faces and more";
      return std::nullopt;
    }
  }
  return m;
}

bool CollapseMesh::is_boundary_vertex(std::uint32_t v) {
  bool boundary = false;
  for_each_edge(v, [&](std::uint32_t e, std::uint32_t) { boundary = boundary || edges_[e].faces == 1; });
  return boundary;
}

std::uint32_t CollapseMesh::find_edge(std::uint32_t a, std::uint32_t b) {
  std::uint32_t found = kNone;
  for_each_edge(a, [&](std::uint32_t e, std::uint32_t other) {
    if (other == b) found = e;
  });
  return found;
}

CollapseMesh::Across CollapseMesh::across(std::uint32_t a, std::uint32_t b) {
  Across r;
  for_each_face(a, [&](std::uint32_t f) {
    const auto& t = faces_[f];
    if (!contains(t, b) || r.count == 2) return;
    for (int k = 0; k < 3; ++k)
      if (t.v[k] != a && t.v[k] != b) r.vertex[r.count++] = t.v[k];
  });
  return r;
}

bool CollapseMesh::link_ok(std::uint32_t from, std::uint32_t to, std::vector<std::uint32_t>& stamp,
                           std::uint32_t& epoch, Across& ac) {
  // Each end's edges once: (other end, faces).
  const auto ring = [&](std::uint32_t v, std::vector<std::pair<std::uint32_t, std::uint32_t>>& out) {
    out.clear();
    bool boundary = false;
    for_each_edge(v, [&](std::uint32_t e, std::uint32_t w) {
      out.push_back({w, edges_[e].faces});
      boundary = boundary || edges_[e].faces == 1;
    });
    return boundary;
  };
  const auto faces_to = [](const std::vector<std::pair<std::uint32_t, std::uint32_t>>& r, std::uint32_t w) {
    for (const auto& [other, faces] : r)
      if (other == w) return faces;
    return 0u;
  };
  const bool from_boundary = ring(from, ring_from_), to_boundary = ring(to, ring_to_);
  const std::uint32_t edge_faces = faces_to(ring_from_, to);
  if (edge_faces == 0) return false;
  ac = across(from, to);
  if (ac.count != int(edge_faces)) return false;
  if (ac.count == 2 && ac.vertex[0] == ac.vertex[1]) return false;
  // No face on the edge with its two other edges on the boundary (the collapse would leave an
  // edge with no face).
  for (int i = 0; i < ac.count; ++i) {
    const std::uint32_t a = faces_to(ring_from_, ac.vertex[i]), b = faces_to(ring_to_, ac.vertex[i]);
    if (a == 0 || b == 0 || (a == 1 && b == 1)) return false;
  }
  // The one-rings meet only across the edge.
  if (++epoch == 0) std::fill(stamp.begin(), stamp.end(), 0), epoch = 1;
  for (const auto& entry : ring_to_) stamp[entry.first] = epoch;
  for (const auto& entry : ring_from_) {
    const std::uint32_t w = entry.first;
    if (stamp[w] == epoch && w != to && w != ac.vertex[0] && w != ac.vertex[1]) return false;
  }
  // Nor do their links share an edge: with faces from-c-d and to-c-d (c, d the corners across),
  // the collapse would leave c-d-to twice, back to back. On a manifold that is a tetrahedron.
  if (ac.count == 2) {
    const Across cd = across(ac.vertex[0], ac.vertex[1]);
    const auto has = [&](std::uint32_t v) { return cd.vertex[0] == v || cd.vertex[1] == v; };
    if (has(from) && has(to)) return false;
  }
  // An edge inside the surface between two boundary vertices would pinch it.
  return !(edge_faces == 2 && from_boundary && to_boundary);
}

int CollapseMesh::collapse(std::uint32_t from, std::uint32_t to) {
  Across ac;
  int removed = 0;
  // Faces: those on the edge die, the others take `to` for `from`; the list joins to's.
  std::uint32_t prev = kNone;
  for (std::uint32_t c = vertex_face_[from]; c != kNone;) {
    const std::uint32_t next = corner_next_[c], f = c / 3;
    if (face_alive_[f] && contains(faces_[f], to)) {
      face_alive_[f] = 0;
      ++removed;
      for (int k = 0; k < 3 && ac.count < 2; ++k)
        if (faces_[f].v[k] != from && faces_[f].v[k] != to) ac.vertex[ac.count++] = faces_[f].v[k];
    }
    if (!face_alive_[f]) {
      (prev == kNone ? vertex_face_[from] : corner_next_[prev]) = next;
    } else {
      faces_[f].v[c % 3] = to;
      prev = c;
    }
    c = next;
  }
  if (prev != kNone) {
    corner_next_[prev] = vertex_face_[to];
    vertex_face_[to] = vertex_face_[from];
  }
  // Edges: from-to dies; from-w for a vertex w across the edge merges into to-w (which keeps the
  // faces of both but the dead one); every other edge of from moves to `to`.
  prev = kNone;
  for (std::uint32_t s = vertex_edge_[from]; s != kNone;) {
    Edge& e = edges_[s >> 1];
    const std::uint32_t next = e.next[s & 1], w = e.v[(s & 1) ^ 1];
    if (e.faces != 0) {
      if (w == to) {
        e.faces = 0;
      } else if (w == ac.vertex[0] || w == ac.vertex[1]) {
        const std::uint32_t kept = find_edge(to, w);
        if (kept != kNone) edges_[kept].faces = edges_[kept].faces + e.faces - 2;
        e.faces = 0;
      } else {
        e.v[s & 1] = to;
      }
    }
    if (e.faces == 0) {
      (prev == kNone ? vertex_edge_[from] : edges_[prev >> 1].next[prev & 1]) = next;
    } else {
      prev = s;
    }
    s = next;
  }
  if (prev != kNone) {
    edges_[prev >> 1].next[prev & 1] = vertex_edge_[to];
    vertex_edge_[to] = vertex_edge_[from];
  }
  vertex_face_[from] = vertex_edge_[from] = kNone;
  vertex_alive_[from] = 0;
  return removed;
}

}  // namespace gaussmesh::stream
