// The collapse mesher, the polygon mesher's fallback (collapse_mesher.h says when it runs):
// per-patch shape approximation (paper §5, "Shape Approximation") by edge collapses.
//
// The mesher works on the input mesh itself (OpenMesh half-edges) and only ever collapses
// edges, so every intermediate mesh is a manifold triangulation of the same topology:
//   1. patch graph: feature edges (boundary, or faces of different patches), their degree at
//      each vertex, corners (branching points and candidates), chains between corners, and
//      closed feature loops;
//   2. topology guards: a closed loop keeps at least three vertices, and of several chains
//      joining the same two corners all but one keep their middle vertex, so that no two
//      chains land on one edge and no patch degenerates;
//   3. phase 1: every other vertex goes — patch-interior vertices into any neighbour, chain
//      vertices along their chain — so each chain becomes straight edges between kept
//      vertices and each patch becomes a triangulation of its boundary polygon; the patch
//      keeps its orientation (no new face may turn away from the patch's mean normal);
//   4. each patch polygon is re-triangulated in the plane of its Gaussian triangle with exact
//      predicates and Delaunay flips (stream/meshing/polygon_triangulation.h), never creating an
//      edge that already exists outside the patch; where that is impossible the collapse result
//      stays;
//   5. phase 2: non-sample corners are collapsed along a feature edge where that keeps the
//      mesh manifold (OpenMesh's link-condition test) and flips no face.
// Every collapse moves no position: output vertices are input vertices ("birth" indices).
#include "stream/meshing/collapse_mesher.h"

#include "stream/core/openmesh_include.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <string>
#include <utility>

#include "stream/meshing/polygon_triangulation.h"

namespace gaussmesh::stream {
namespace {

struct Traits : public OpenMesh::DefaultTraits {
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::PrevHalfedge);
  FaceAttributes(OpenMesh::Attributes::Status);
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;
using VH = OMesh::VertexHandle;
using HH = OMesh::HalfedgeHandle;
using FH = OMesh::FaceHandle;
using EH = OMesh::EdgeHandle;

// What a vertex may become.
enum class Keep : std::uint8_t {
  kRemove = 0,   // phase 1 removes it
  kCorner = 1,   // kept through phase 1, removed in phase 2 if a legal collapse exists
  kGuard = 2,    // kept: protects topology (loop or duplicate-chain guard)
  kSample = 3,   // kept: a sample
};

using Vec = OMesh::Point;

Vec cross3(const Vec& a, const Vec& b) {
  return Vec(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]);
}
double dot3(const Vec& a, const Vec& b) {
  return double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
}

class Mesher {
 public:
  explicit Mesher(const PatchMesherInput& input) : input_(input) {}

  format::Result<PatchMesherResult> run() {
    build();
    find_patch_graph();
    if (input_.corners_only) {
      phase_two();
      return extract();
    }
    guard_topology();
    phase_one();
    retriangulate_patches();
    phase_two();
    return extract();
  }

 private:
  void build() {
    ::omerr().disable();  // rejected faces are counted, not printed
    const auto& positions = input_.mesh.positions;
    // Room for every element up front: the property arrays grow once instead of doubling.
    const std::size_t faces = input_.mesh.triangles.size();
    mesh_.reserve(positions.size(), faces + faces / 2 + 64, faces);
    for (size_t i = 0; i < positions.size(); ++i) {
      mesh_.add_vertex(Vec(positions[i].x, positions[i].y, positions[i].z));
    }
    mesh_.add_property(patch_);
    for (size_t f = 0; f < input_.mesh.triangles.size(); ++f) {
      const auto& t = input_.mesh.triangles[f];
      if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) {
        ++result_.skipped_input_faces;
        continue;
      }
      FH fh = mesh_.add_face(VH(int(t.v[0])), VH(int(t.v[1])), VH(int(t.v[2])));
      if (!fh.is_valid()) {
        ++result_.skipped_input_faces;
        continue;
      }
      mesh_.property(patch_, fh) = input_.face_patch[f];
    }
    ::omerr().enable();
    // Patch ids made dense (0 .. patches-1, in order of id), then the mean normal of every
    // patch, for the orientation guard.
    std::vector<std::uint32_t> ids(input_.face_patch.begin(), input_.face_patch.end());
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    for (FH fh : mesh_.faces()) {
      auto& id = mesh_.property(patch_, fh);
      id = static_cast<std::uint32_t>(std::lower_bound(ids.begin(), ids.end(), id) - ids.begin());
    }
    patch_normal_.assign(ids.size(), Vec(0, 0, 0));
    patch_ids_ = ids;
    for (FH fh : mesh_.faces()) patch_normal_[mesh_.property(patch_, fh)] += face_cross(fh);
    keep_.assign(mesh_.n_vertices(), Keep::kRemove);
  }

  Vec face_cross(FH fh) const {
    auto it = mesh_.cfv_iter(fh);
    Vec a = mesh_.point(*it), b = mesh_.point(*(++it)), c = mesh_.point(*(++it));
    return cross3(b - a, c - a);
  }

  bool is_feature(EH eh) const {
    if (mesh_.is_boundary(eh)) return true;
    HH h0 = mesh_.halfedge_handle(eh, 0), h1 = mesh_.halfedge_handle(eh, 1);
    return mesh_.property(patch_, mesh_.face_handle(h0)) != mesh_.property(patch_, mesh_.face_handle(h1));
  }

  int feature_degree(VH vh) const {
    int degree = 0;
    for (auto eh : mesh_.ve_range(vh)) degree += is_feature(eh) ? 1 : 0;
    return degree;
  }

  // A boundary vertex where the boundary turns by more than kBoundaryTurnDegrees. Normals
  // cannot see a boundary's curvature within its surface (paper §5, "Handling Meshes with
  // Boundaries": such curves are otherwise filled); without this a flat square would become a
  // triangle. A decision of the vertex and its two boundary neighbours only.
  bool is_boundary_turn(VH vh) const {
    static constexpr double kBoundaryTurnDegrees = 30;
    if (!mesh_.is_boundary(vh)) return false;
    HH out = mesh_.halfedge_handle(vh);  // OpenMesh keeps a boundary half-edge here
    if (!mesh_.is_boundary(out)) return false;
    Vec a = mesh_.point(vh) - mesh_.point(mesh_.from_vertex_handle(mesh_.prev_halfedge_handle(out)));
    Vec b = mesh_.point(mesh_.to_vertex_handle(out)) - mesh_.point(vh);
    double la = std::sqrt(dot3(a, a)), lb = std::sqrt(dot3(b, b));
    if (la == 0 || lb == 0) return false;
    return dot3(a, b) < std::cos(kBoundaryTurnDegrees * 3.14159265358979323846 / 180) * la * lb;
  }

  void find_patch_graph() {
    for (EH eh : mesh_.edges()) result_.graph.feature_edges += is_feature(eh) ? 1 : 0;
    for (VH vh : mesh_.vertices()) {
      if (mesh_.is_isolated(vh)) continue;
      VertexRole role = input_.vertex_role[vh.idx()];
      int degree = feature_degree(vh);
      if (role == VertexRole::kSample) {
        keep_[vh.idx()] = Keep::kSample;
      } else if (role == VertexRole::kGuard || (input_.corners_only && role == VertexRole::kNone)) {
        keep_[vh.idx()] = Keep::kGuard;
      } else if (role == VertexRole::kCorner || degree >= 3 || degree == 1 || is_boundary_turn(vh)) {
        keep_[vh.idx()] = Keep::kCorner;
      }
      if (degree >= 3 || (degree > 0 && role != VertexRole::kNone)) ++result_.graph.corners;
    }
  }

  // Walks the feature graph into chains and closed loops, and marks guard vertices.
  void guard_topology() {
    std::vector<char> visited(mesh_.n_edges(), 0);
    std::map<std::pair<int, int>, int> chains_between;  // corner pair -> chains seen
    auto is_stop = [&](VH vh) { return keep_[vh.idx()] != Keep::kRemove || feature_degree(vh) != 2; };
    auto next_feature = [&](VH at, EH came) -> EH {
      for (EH eh : mesh_.ve_range(at)) {
        if (eh != came && is_feature(eh)) return eh;
      }
      return EH();
    };
    auto other = [&](EH eh, VH vh) {
      HH h = mesh_.halfedge_handle(eh, 0);
      VH a = mesh_.from_vertex_handle(h), b = mesh_.to_vertex_handle(h);
      return a == vh ? b : a;
    };
    // Chains start at stop vertices.
    for (VH start : mesh_.vertices()) {
      if (mesh_.is_isolated(start) || !is_stop(start) || feature_degree(start) == 0) continue;
      for (auto first : mesh_.ve_range(start)) {
        if (!is_feature(first) || visited[first.idx()]) continue;
        std::vector<VH> path{start};
        EH eh = first;
        VH at = start;
        for (;;) {
          visited[eh.idx()] = 1;
          at = other(eh, at);
          path.push_back(at);
          if (is_stop(at)) break;
          eh = next_feature(at, eh);
          if (!eh.is_valid() || visited[eh.idx()]) break;
        }
        ++result_.graph.chains;
        VH end = path.back();
        size_t inner = path.size() - 2;
        if (start == end) {
          // A loop through one corner: two more vertices make it a triangle.
          guard(path, 3);
        } else {
          // Not std::minmax: it would return references to the temporaries idx() makes.
          const std::pair<int, int> key{std::min(start.idx(), end.idx()), std::max(start.idx(), end.idx())};
          if (chains_between[key]++ > 0 && inner > 0) guard(path, 2);
        }
      }
    }
    // What is left are closed loops of chain vertices with no corner at all.
    for (EH eh : mesh_.edges()) {
      if (visited[eh.idx()] || !is_feature(eh)) continue;
      VH start = mesh_.from_vertex_handle(mesh_.halfedge_handle(eh, 0));
      std::vector<VH> path{start};
      VH at = start;
      EH e = eh;
      for (;;) {
        visited[e.idx()] = 1;
        at = other(e, at);
        if (at == start) break;
        path.push_back(at);
        e = next_feature(at, e);
        if (!e.is_valid() || visited[e.idx()]) break;
      }
      ++result_.graph.closed_loops;
      path.push_back(start);
      guard(path, 4);
    }
    std::vector<char> seen(mesh_.n_halfedges(), 0);
    for (HH h : mesh_.halfedges()) {
      if (!mesh_.is_boundary(h) || seen[h.idx()]) continue;
      ++result_.graph.boundary_loops;
      for (HH g = h; !seen[g.idx()]; g = mesh_.next_halfedge_handle(g)) seen[g.idx()] = 1;
    }
  }

  // Keeps evenly spaced inner vertices of path so that it has `vertices` points in all
  // (counting both ends, which may be the same vertex).
  void guard(const std::vector<VH>& path, size_t vertices) {
    if (path.size() < 3) return;
    size_t inner = path.size() - 2;
    size_t wanted = std::min(inner, vertices - 2);
    for (size_t k = 1; k <= wanted; ++k) {
      size_t index = k * (path.size() - 1) / (wanted + 1);
      VH vh = path[std::clamp<size_t>(index, 1, path.size() - 2)];
      if (keep_[vh.idx()] == Keep::kRemove || keep_[vh.idx()] == Keep::kCorner) {
        keep_[vh.idx()] = Keep::kGuard;
      }
    }
  }

  // True when collapsing h (from -> to) keeps the mesh manifold, flips no face, creates no
  // zero-area face and keeps every patch facing its mean normal.
  bool collapse_ok(HH h) {
    if (!mesh_.is_collapse_ok(h)) return false;
    VH from = mesh_.from_vertex_handle(h), to = mesh_.to_vertex_handle(h);
    Vec target = mesh_.point(to);
    for (FH fh : mesh_.vf_range(from)) {
      std::array<Vec, 3> p;
      bool has_to = false;
      int i = 0;
      for (VH vh : mesh_.fv_range(fh)) {
        if (vh == to) has_to = true;
        p[i++] = vh == from ? target : mesh_.point(vh);
      }
      if (has_to) continue;  // this face disappears
      Vec before = face_cross(fh);
      Vec after = cross3(p[1] - p[0], p[2] - p[0]);
      double after_sq = dot3(after, after);
      double scale = dot3(before, before);
      // Relative to the face before, so that the answer does not depend on the mesh's scale.
      if (after_sq == 0 || after_sq <= 1e-24 * scale) return false;
      if (scale > 0 && dot3(before, after) <= 0) return false;
      if (max_turn_cos_ > -1 && dot3(before, after) < max_turn_cos_ * std::sqrt(scale * after_sq)) return false;
      const Vec& mean = patch_normal_[mesh_.property(patch_, fh)];
      if (dot3(mean, after) <= 0) return false;
    }
    return true;
  }

  // Tries every allowed target of vh, shortest edge first.
  bool try_remove(VH vh, bool along_features_only) { return try_remove_to(vh, along_features_only).is_valid(); }
  // The same, returning the vertex vh went into (invalid when none).
  VH try_remove_to(VH vh, bool along_features_only) {
    std::vector<std::pair<double, HH>>& options = options_;
    options.clear();
    for (HH h : mesh_.voh_range(vh)) {
      if (along_features_only && !is_feature(mesh_.edge_handle(h))) continue;
      Vec d = mesh_.point(mesh_.to_vertex_handle(h)) - mesh_.point(vh);
      options.emplace_back(dot3(d, d), h);
    }
    std::sort(options.begin(), options.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    for (auto& [length, h] : options) {
      if (collapse_ok(h)) {
        const VH to = mesh_.to_vertex_handle(h);
        mesh_.collapse(h);
        return to;
      }
    }
    return VH();
  }

  void phase_one() {
    for (bool progress = true; progress;) {
      progress = false;
      for (VH vh : mesh_.vertices()) {
        if (mesh_.status(vh).deleted() || mesh_.is_isolated(vh) || keep_[vh.idx()] != Keep::kRemove) continue;
        int degree = feature_degree(vh);
        if (try_remove(vh, degree > 0)) progress = true;
      }
    }
  }

  // The loops of boundary half-edges of the faces of patch p (inner side), as vertex lists.
  // Returns false when the patch still has a vertex off its boundary.
  bool patch_loops(std::uint32_t p, const std::vector<FH>& faces, std::vector<std::vector<VH>>& loops) {
    auto in_patch = [&](HH h) { return !mesh_.is_boundary(h) && mesh_.property(patch_, mesh_.face_handle(h)) == p; };
    std::vector<HH> boundary;
    for (FH fh : faces) {
      for (HH h : mesh_.fh_range(fh)) {
        if (!in_patch(mesh_.opposite_halfedge_handle(h))) boundary.push_back(h);
      }
    }
    for (FH fh : faces) {
      for (VH vh : mesh_.fv_range(fh)) {
        bool on_boundary = false;
        for (HH h : boundary) on_boundary = on_boundary || mesh_.from_vertex_handle(h) == vh;
        if (!on_boundary) return false;
      }
    }
    std::sort(boundary.begin(), boundary.end(), [](HH a, HH b) { return a.idx() < b.idx(); });
    std::vector<char> used(boundary.size(), 0);
    auto index_of = [&](HH h) {
      auto it = std::lower_bound(boundary.begin(), boundary.end(), h, [](HH a, HH b) { return a.idx() < b.idx(); });
      return it != boundary.end() && *it == h ? static_cast<std::ptrdiff_t>(it - boundary.begin()) : -1;
    };
    for (size_t start = 0; start < boundary.size(); ++start) {
      if (used[start]) continue;
      std::vector<VH> loop;
      HH h = boundary[start];
      for (size_t guard = 0; guard <= boundary.size(); ++guard) {
        auto at = index_of(h);
        if (at < 0 || used[at]) break;
        used[at] = 1;
        loop.push_back(mesh_.from_vertex_handle(h));
        // Next boundary half-edge: turn around to_vertex(h) through the patch's faces.
        HH next = mesh_.next_halfedge_handle(h);
        for (size_t turns = 0; in_patch(mesh_.opposite_halfedge_handle(next)) && turns < 1024; ++turns) {
          next = mesh_.next_halfedge_handle(mesh_.opposite_halfedge_handle(next));
        }
        h = next;
      }
      if (h != boundary[start]) return false;  // a loop that does not close: leave the patch
      loops.push_back(std::move(loop));
    }
    return true;
  }

  void retriangulate_patches() {
    std::vector<std::vector<FH>> faces_of(patch_normal_.size());
    for (FH fh : mesh_.faces()) {
      if (!mesh_.status(fh).deleted()) faces_of[mesh_.property(patch_, fh)].push_back(fh);
    }
    // A patch id may cover several edge-connected pieces: each is a polygon of its own.
    std::vector<char> seen(mesh_.n_faces(), 0);
    std::vector<FH> piece, stack;
    for (std::uint32_t p = 0; p < faces_of.size(); ++p) {
      for (FH seed : faces_of[p]) {
        if (seen[seed.idx()]) continue;
        piece.clear();
        stack.assign(1, seed);
        seen[seed.idx()] = 1;
        while (!stack.empty()) {
          FH fh = stack.back();
          stack.pop_back();
          piece.push_back(fh);
          for (HH h : mesh_.fh_range(fh)) {
            HH o = mesh_.opposite_halfedge_handle(h);
            if (mesh_.is_boundary(o)) continue;
            FH g = mesh_.face_handle(o);
            // Faces added by earlier pieces' triangulations have indices past the start.
            if (static_cast<size_t>(g.idx()) >= seen.size()) seen.resize(mesh_.n_faces(), 0);
            if (!seen[g.idx()] && mesh_.property(patch_, g) == p) {
              seen[g.idx()] = 1;
              stack.push_back(g);
            }
          }
        }
        if (retriangulate(p, piece)) {
          ++result_.planar_patches;
        } else {
          ++result_.collapse_patches;
        }
      }
    }
  }

  bool retriangulate(std::uint32_t p, const std::vector<FH>& faces) {
    std::vector<std::vector<VH>> loops;
    if (!patch_loops(p, faces, loops) || loops.empty()) return false;
    Vec normal = patch_normal_[p];
    std::uint32_t original_id = patch_ids_[p];
    if (original_id < input_.patch_plane_normal.size()) {
      const auto& n = input_.patch_plane_normal[original_id];
      normal = Vec(n.x, n.y, n.z);
    }
    if (dot3(normal, normal) <= 0) return false;
    // Local points; the outer loop is the one of largest area seen from the normal.
    std::vector<VH> local_to_vertex;
    std::vector<PolygonPoint3> points;
    std::vector<std::vector<std::uint32_t>> local_loops;
    std::vector<double> area;
    for (const auto& loop : loops) {
      std::vector<std::uint32_t> local;
      Vec newell(0, 0, 0);
      for (size_t i = 0; i < loop.size(); ++i) {
        auto it = std::find(local_to_vertex.begin(), local_to_vertex.end(), loop[i]);
        std::uint32_t id;
        if (it == local_to_vertex.end()) {
          id = static_cast<std::uint32_t>(local_to_vertex.size());
          local_to_vertex.push_back(loop[i]);
          const auto& q = mesh_.point(loop[i]);
          points.push_back({double(q[0]), double(q[1]), double(q[2])});
        } else {
          id = static_cast<std::uint32_t>(it - local_to_vertex.begin());
        }
        local.push_back(id);
        newell += cross3(mesh_.point(loop[i]), mesh_.point(loop[(i + 1) % loop.size()]));
      }
      local_loops.push_back(std::move(local));
      area.push_back(dot3(newell, normal));
    }
    size_t outer = std::max_element(area.begin(), area.end()) - area.begin();
    if (area[outer] <= 0) return false;
    std::swap(local_loops[0], local_loops[outer]);
    auto forbidden = [&](std::uint32_t u, std::uint32_t v) {
      HH h = mesh_.find_halfedge(local_to_vertex[u], local_to_vertex[v]);
      if (!h.is_valid()) return false;
      HH o = mesh_.opposite_halfedge_handle(h);
      bool both_inside = !mesh_.is_boundary(h) && !mesh_.is_boundary(o) &&
                         mesh_.property(patch_, mesh_.face_handle(h)) == p &&
                         mesh_.property(patch_, mesh_.face_handle(o)) == p;
      return !both_inside;
    };
    auto triangles = triangulate_polygon(points, local_loops, {double(normal[0]), double(normal[1]), double(normal[2])},
                                         forbidden);
    if (!triangles) return false;
    // Replace the patch's faces; on any refusal put the old ones back.
    std::vector<std::array<VH, 3>> old;
    for (FH fh : faces) {
      std::array<VH, 3> t;
      int i = 0;
      for (VH vh : mesh_.fv_range(fh)) t[i++] = vh;
      old.push_back(t);
      mesh_.delete_face(fh, false);
    }
    std::vector<FH> added;
    bool ok = true;
    for (const auto& t : *triangles) {
      FH fh = mesh_.add_face(local_to_vertex[t[0]], local_to_vertex[t[1]], local_to_vertex[t[2]]);
      if (!fh.is_valid()) {
        ok = false;
        break;
      }
      mesh_.property(patch_, fh) = p;
      added.push_back(fh);
    }
    if (!ok) {
      for (FH fh : added) mesh_.delete_face(fh, false);
      for (const auto& t : old) {
        FH fh = mesh_.add_face(t[0], t[1], t[2]);
        if (fh.is_valid()) mesh_.property(patch_, fh) = p;
      }
    }
    return ok;
  }

  void phase_two() {
    // A corner collapse may turn no remaining face by more than this: without a limit a single
    // collapse at a crease junction can move the surface by several percent of the diagonal
    // (fandisk), while 45° keeps only a few more faces (docs/meshing.md).
    static constexpr double kMaxTurnDegrees = 45;
    max_turn_cos_ = std::cos(kMaxTurnDegrees * 3.14159265358979323846 / 180);
    // Corners go in the order of their shortest feature edge, shortest first (the collapse that
    // moves the surface least), each along its shortest allowed feature edge; a corner that
    // cannot go now is tried again when a collapse changes its star (it is next to the vertex
    // collapsed into). The order is the geometry's, not the vertex numbering's (ties aside): a
    // sweep in index order made the result follow the numbering, and a sweep in position order
    // strings collapses along a feature line one after the other (docs/meshing.md).
    auto eligible = [&](VH vh) {
      return !mesh_.status(vh).deleted() && !mesh_.is_isolated(vh) && keep_[vh.idx()] == Keep::kCorner && !mesh_.is_boundary(vh);
    };
    auto shortest = [&](VH vh) {
      double best = std::numeric_limits<double>::infinity();
      for (HH h : mesh_.voh_range(vh)) {
        if (!is_feature(mesh_.edge_handle(h))) continue;
        const Vec d = mesh_.point(mesh_.to_vertex_handle(h)) - mesh_.point(vh);
        best = std::min(best, dot3(d, d));
      }
      return best;
    };
    // One live entry per vertex: queued[v] is its length (NaN: none), so that a corner is not
    // tried again until something around it changed.
    using Entry = std::pair<double, int>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    std::vector<double> queued(mesh_.n_vertices(), std::numeric_limits<double>::quiet_NaN());
    auto push = [&](VH vh) {
      if (!eligible(vh)) return;
      const double length = shortest(vh);
      if (queued[vh.idx()] == length) return;
      queued[vh.idx()] = length;
      queue.push({length, vh.idx()});
    };
    for (VH vh : mesh_.vertices()) push(vh);
    while (!queue.empty()) {
      const auto [length, index] = queue.top();
      queue.pop();
      if (!(queued[index] == length)) continue;  // a later entry replaced it
      queued[index] = std::numeric_limits<double>::quiet_NaN();
      const VH vh(index);
      if (!eligible(vh)) continue;
      if (shortest(vh) != length) {
        push(vh);
        continue;
      }
      const VH to = try_remove_to(vh, true);
      if (!to.is_valid()) continue;
      push(to);
      for (VH w : mesh_.vv_range(to)) push(w);
    }
  }

  format::Result<PatchMesherResult> extract() {
    std::vector<std::int64_t> new_index(mesh_.n_vertices(), -1);
    Mesh& out = result_.mesh;
    for (VH vh : mesh_.vertices()) {
      if (mesh_.status(vh).deleted() || mesh_.is_isolated(vh)) continue;
      new_index[vh.idx()] = static_cast<std::int64_t>(out.positions.size());
      out.positions.push_back(input_.mesh.positions[vh.idx()]);
      result_.birth.push_back(static_cast<std::uint32_t>(vh.idx()));
      switch (keep_[vh.idx()]) {
        case Keep::kSample: ++result_.kept_samples; break;
        case Keep::kCorner: ++result_.kept_corners; break;
        case Keep::kGuard: ++result_.kept_chain_vertices; break;
        case Keep::kRemove:
          if (feature_degree(vh) > 0) {
            ++result_.kept_chain_vertices;
          } else {
            ++result_.kept_interior_vertices;
          }
          break;
      }
    }
    for (FH fh : mesh_.faces()) {
      if (mesh_.status(fh).deleted()) continue;
      format::Triangle t;
      int i = 0;
      for (VH vh : mesh_.fv_range(fh)) t.v[i++] = static_cast<format::VertexIndex>(new_index[vh.idx()]);
      out.triangles.push_back(t);
    }
    return std::move(result_);
  }

  const PatchMesherInput& input_;
  OMesh mesh_;
  OpenMesh::FPropHandleT<std::uint32_t> patch_;
  std::vector<Vec> patch_normal_;  // by dense patch index
  std::vector<std::uint32_t> patch_ids_;  // dense index -> input patch id
  std::vector<Keep> keep_;
  std::vector<std::pair<double, HH>> options_;  // scratch of try_remove
  double max_turn_cos_ = -2;  // collapse_ok: least cos(turn) of a remaining face; -2: no limit
  PatchMesherResult result_;
};

}  // namespace

format::Result<PatchMesherResult> mesh_patches_by_collapse(const PatchMesherInput& input) {
  const size_t vertices = input.mesh.positions.size();
  if (input.face_patch.size() != input.mesh.triangles.size()) {
    return format::Status::error(format::Code::kProcessing, "patch mesher",
                                 "face_patch has " + std::to_string(input.face_patch.size()) +
                                     " entries for " + std::to_string(input.mesh.triangles.size()) + " faces");
  }
  if (input.vertex_role.size() != vertices) {
    return format::Status::error(format::Code::kProcessing, "patch mesher",
                                 "vertex_role has " + std::to_string(input.vertex_role.size()) +
                                     " entries for " + std::to_string(vertices) + " vertices");
  }
  if (vertices > 0x7FFFFFFFu) {
    return format::Status::error(format::Code::kResources, "patch mesher",
                                 "in-core mesher takes at most 2^31 - 1 vertices");
  }
  for (size_t f = 0; f < input.mesh.triangles.size(); ++f) {
    for (auto v : input.mesh.triangles[f].v) {
      if (v >= vertices) {
        return format::Status::error(format::Code::kProcessing, "patch mesher",
                                     "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) +
                                         " of " + std::to_string(vertices));
      }
    }
  }
  Mesher mesher(input);
  return mesher.run();
}

}  // namespace gaussmesh::stream
