#include "stream/finish/finish_pieces.h"

#include <algorithm>
#include <numeric>

#include "stream/finish/quadric_finish.h"

namespace gaussmesh::stream {
namespace {

bool repeated(const format::Triangle& t) { return t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]; }

// Spreads the low 10 bits of x to every third bit.
std::uint32_t spread10(std::uint32_t x) {
  x &= 0x3ff;
  x = (x | (x << 16)) & 0x30000ff;
  x = (x | (x << 8)) & 0x300f00f;
  x = (x | (x << 4)) & 0x30c30c3;
  x = (x | (x << 2)) & 0x9249249;
  return x;
}

}  // namespace

PieceResult decimate_piece(Piece piece, const QuadricFrame& frame, DecimationOptions options) {
  PieceResult r;
  const std::size_t n = piece.vertices.size();
  Mesh mesh;
  mesh.positions.reserve(n);
  std::vector<Quadric> quadrics;
  quadrics.reserve(n);
  std::vector<std::uint8_t> locked(n);
  for (std::size_t v = 0; v < n; ++v) {
    mesh.positions.push_back(piece.vertices[v].position);
    quadrics.push_back(piece.vertices[v].quadric.to_double());
    locked[v] = piece.vertices[v].locked;
  }
  mesh.triangles = piece.faces;
  options.locked = locked;
  options.boundary_constraints = false;
  options.relax_turn_limit = false;
  auto decimated = decimate(mesh.view(), std::move(quadrics), frame, options);
  if (!decimated) {  // not an oriented manifold (CollapseMesh::build): the piece stays as it is
    r.manifold = false;
    r.piece = std::move(piece);
    return r;
  }
  r.collapses = decimated->collapses;
  r.refused = decimated->refused;
  r.over_error = decimated->over_error;
  r.estimated_error = decimated->estimated_error;
  // Survivors in ascending id (the collapses keep the order of their sources' ids).
  const std::size_t m = decimated->mesh.positions.size();
  std::vector<std::uint32_t> order(m);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return decimated->source[a] < decimated->source[b];
  });
  std::vector<std::uint32_t> index(m);
  r.piece.vertices.reserve(m);
  for (std::uint32_t k = 0; k < m; ++k) {
    const std::uint32_t out = order[k], from = decimated->source[out];
    index[out] = k;
    PieceVertex v = piece.vertices[from];
    // A locked vertex keeps its input bits (the frame's round trip may not); a free one takes
    // the collapses' position and quadric.
    if (!v.locked) v.position = decimated->mesh.positions[out];
    v.quadric = FixedQuadric::from(decimated->quadrics[out]);
    r.piece.vertices.push_back(v);
  }
  r.piece.faces.reserve(decimated->mesh.triangles.size());
  for (const auto& t : decimated->mesh.triangles) r.piece.faces.push_back({{index[t.v[0]], index[t.v[1]], index[t.v[2]]}});
  return r;
}

std::vector<Piece> chunk_pieces(const ChunkMesh& chunk, const QuadricFrame& frame, std::uint64_t max_piece_faces) {
  const std::size_t nv = chunk.positions.size(), nf = chunk.triangles.size();
  // Faces around each vertex (those with a repeated corner left out, as the input finish does).
  std::vector<std::uint32_t> first(nv + 1, 0);
  for (const auto& t : chunk.triangles)
    if (!repeated(t))
      for (auto v : t.v) ++first[v + 1];
  for (std::size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
  std::vector<std::uint32_t> around(first[nv]);
  {
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      if (!repeated(chunk.triangles[f]))
        for (auto v : chunk.triangles[f].v) around[fill[v]++] = std::uint32_t(f);
  }
  std::vector<std::uint32_t> owned;
  for (std::size_t f = 0; f < nf; ++f)
    if (chunk.owned_face[f] && !repeated(chunk.triangles[f])) owned.push_back(std::uint32_t(f));
  if (owned.empty()) return {};

  // Pieces of nearby faces: the owned faces in Morton order of their first corner within the
  // chunk's box, cut into equal runs.
  const std::uint64_t pieces = std::max<std::uint64_t>(1, (owned.size() + max_piece_faces - 1) / std::max<std::uint64_t>(max_piece_faces, 1));
  if (pieces > 1) {
    format::Vec3f lo = chunk.positions[chunk.triangles[owned[0]].v[0]], hi = lo;
    for (auto f : owned)
      for (auto v : chunk.triangles[f].v) {
        const auto& p = chunk.positions[v];
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
      }
    auto cell = [](float x, float a, float b) {
      const double t = b > a ? (double(x) - a) / (double(b) - a) * 1023.0 : 0;
      return std::uint32_t(t >= 0 ? std::min(t, 1023.0) : 0);
    };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> keyed;
    keyed.reserve(owned.size());
    for (auto f : owned) {
      const auto& p = chunk.positions[chunk.triangles[f].v[0]];
      keyed.push_back({spread10(cell(p.x, lo.x, hi.x)) | spread10(cell(p.y, lo.y, hi.y)) << 1 |
                           spread10(cell(p.z, lo.z, hi.z)) << 2,
                       f});
    }
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t i = 0; i < owned.size(); ++i) owned[i] = keyed[i].second;
  }
  constexpr std::uint32_t kNone = UINT32_MAX;
  std::vector<std::uint32_t> piece_of(nf, kNone);
  for (std::size_t i = 0; i < owned.size(); ++i) piece_of[owned[i]] = std::uint32_t(i * pieces / owned.size());

  std::vector<Piece> out(pieces);
  std::vector<std::uint32_t> local(nv, kNone);
  std::size_t begin = 0;
  for (std::uint32_t p = 0; p < pieces; ++p) {
    std::size_t end = begin;
    while (end < owned.size() && piece_of[owned[end]] == p) ++end;
    // Its vertices in ascending id (chunk order is ascending id): each once, marked in `local`
    // as it is first met, so that only the distinct ones are sorted.
    std::vector<std::uint32_t> vertices;
    for (std::size_t i = begin; i < end; ++i)
      for (auto v : chunk.triangles[owned[i]].v)
        if (local[v] == kNone) local[v] = 0, vertices.push_back(v);
    std::sort(vertices.begin(), vertices.end());
    Piece& piece = out[p];
    piece.vertices.resize(vertices.size());
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const std::uint32_t v = vertices[k];
      local[v] = std::uint32_t(k);
      PieceVertex& pv = piece.vertices[k];
      pv.id = chunk.global_vertex[v];
      pv.position = chunk.positions[v];
      for (std::uint32_t i = first[v]; i < first[v + 1] && !pv.locked; ++i) pv.locked = piece_of[around[i]] != p;
    }
    for (std::size_t i = begin; i < end; ++i) {
      const auto& t = chunk.triangles[owned[i]];
      piece.faces.push_back({{local[t.v[0]], local[t.v[1]], local[t.v[2]]}});
      Vec3dq q[3];
      for (int c = 0; c < 3; ++c) {
        const auto& x = chunk.positions[t.v[c]];
        q[c] = frame.to_frame(x.x, x.y, x.z);
      }
      FixedQuadric plane;
      if (own_face_quadric(q[0], q[1], q[2], plane))
        for (int c = 0; c < 3; ++c) piece.vertices[local[t.v[c]]].quadric += plane;
      // An edge no other face of the input holds is on its boundary: its constraint plane, once.
      const Vec3dq e1{q[1].x - q[0].x, q[1].y - q[0].y, q[1].z - q[0].z};
      const Vec3dq e2{q[2].x - q[0].x, q[2].y - q[0].y, q[2].z - q[0].z};
      const Vec3dq n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t a = t.v[c], b = t.v[(c + 1) % 3];
        int holders = 0;
        for (std::uint32_t i2 = first[a]; i2 < first[a + 1]; ++i2) {
          const auto& u = chunk.triangles[around[i2]].v;
          holders += u[0] == b || u[1] == b || u[2] == b;
        }
        if (holders != 1) continue;
        const FixedQuadric constraint = FixedQuadric::from(boundary_constraint(q[c], q[(c + 1) % 3], n));
        piece.vertices[local[a]].quadric += constraint;
        piece.vertices[local[b]].quadric += constraint;
      }
    }
    for (auto v : vertices) local[v] = kNone;
    begin = end;
  }
  return out;
}

}  // namespace gaussmesh::stream
