#include "stream/finish/quadric_decimation.h"

#include "stream/core/openmesh_include.h"

#include <algorithm>
#include <cmath>

namespace gaussmesh::stream {
namespace {

struct Traits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::PrevHalfedge);
  FaceAttributes(OpenMesh::Attributes::Status);
};
using QMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;
using OpenMesh::Vec3d;

Vec3dq to_q(const Vec3d& p) { return {p[0], p[1], p[2]}; }
Vec3d to_om(const Vec3dq& p) { return Vec3d(p.x, p.y, p.z); }

struct Candidate {
  double cost;
  std::uint32_t edge;
  bool before(const Candidate& o) const { return cost != o.cost ? cost < o.cost : edge < o.edge; }
};

// A 4-ary min-heap of (cost, edge) with at most one entry per edge, whose cost can be updated:
// the collapses pop it several million times on a large input, and a heap of stale entries
// (std::priority_queue with lazy deletion) spent most of the run in cache misses.
class EdgeHeap {
 public:
  explicit EdgeHeap(std::size_t edges) : pos_(edges, kAbsent) {}
  bool empty() const { return heap_.empty(); }
  const Candidate& top() const { return heap_.front(); }
  void set(std::uint32_t edge, double cost) {
    if (pos_[edge] == kAbsent) {
      pos_[edge] = std::uint32_t(heap_.size());
      heap_.push_back({cost, edge});
      up(heap_.size() - 1);
    } else {
      const std::size_t i = pos_[edge];
      const bool lower = cost < heap_[i].cost;
      heap_[i].cost = cost;
      lower ? up(i) : down(i);
    }
  }
  void pop() {
    pos_[heap_.front().edge] = kAbsent;
    heap_.front() = heap_.back();
    heap_.pop_back();
    if (!heap_.empty()) {
      pos_[heap_.front().edge] = 0;
      down(0);
    }
  }

 private:
  static constexpr std::uint32_t kAbsent = UINT32_MAX;
  static constexpr std::size_t kArity = 4;
  void place(std::size_t i, const Candidate& c) {
    heap_[i] = c;
    pos_[c.edge] = std::uint32_t(i);
  }
  void up(std::size_t i) {
    const Candidate c = heap_[i];
    while (i > 0) {
      const std::size_t parent = (i - 1) / kArity;
      if (!c.before(heap_[parent])) break;
      place(i, heap_[parent]);
      i = parent;
    }
    place(i, c);
  }
  void down(std::size_t i) {
    const Candidate c = heap_[i];
    for (;;) {
      const std::size_t first = kArity * i + 1;
      if (first >= heap_.size()) break;
      std::size_t best = first;
      const std::size_t last = std::min(first + kArity, heap_.size());
      for (std::size_t k = first + 1; k < last; ++k)
        if (heap_[k].before(heap_[best])) best = k;
      if (!heap_[best].before(c)) break;
      place(i, heap_[best]);
      i = best;
    }
    place(i, c);
  }
  std::vector<Candidate> heap_;
  std::vector<std::uint32_t> pos_;
};

class Decimator {
 public:
  Decimator(QMesh& mesh, std::vector<Quadric> quadrics, std::span<const std::uint8_t> locked, const QuadricFrame& frame,
            std::span<const Vec3f> input)
      : m_(mesh), q_(std::move(quadrics)), heap_(mesh.n_edges()), locked_(locked), stamp_(mesh.n_vertices(), 0),
        frame_(frame), position_(input.begin(), input.end()) {
    target_.resize(m_.n_edges());
  }
  const std::vector<Quadric>& quadrics() const { return q_; }
  // Each vertex's output position: its input's, or where its last collapse put it.
  const std::vector<Vec3f>& positions() const { return position_; }

  // x moved to the nearest point the output can hold (float input coordinates), so that the
  // geometry tests see the faces as they will be written: a face thin enough to lose its area
  // to that rounding is refused, not written.
  Vec3d to_output(const Vec3d& x, Vec3f& out) const {
    out = {float(frame_.origin.x + x[0] * frame_.scale), float(frame_.origin.y + x[1] * frame_.scale),
           float(frame_.origin.z + x[2] * frame_.scale)};
    return to_om(frame_.to_frame(out.x, out.y, out.z));
  }

  bool locked(QMesh::VertexHandle v) const { return !locked_.empty() && locked_[v.idx()]; }

  // The placement and cost of collapsing edge e.
  bool evaluate(QMesh::EdgeHandle e, Vec3d& x, double& cost) const {
    const auto h = m_.halfedge_handle(e, 0);
    const auto v0 = m_.from_vertex_handle(h), v1 = m_.to_vertex_handle(h);
    Quadric q = q_[v0.idx()];
    q += q_[v1.idx()];
    const Vec3d p0 = m_.point(v0), p1 = m_.point(v1), mid = (p0 + p1) * 0.5;
    if (locked(v0) || locked(v1)) {  // onto the locked end, if only one is
      if (locked(v0) && locked(v1)) return false;
      x = locked(v0) ? p0 : p1;
      cost = q.error(to_q(x));
      return std::isfinite(cost);
    }
    Vec3dq best;
    const double length = (p1 - p0).norm();
    // The minimiser, unless it lies far from the edge (an ill-conditioned quadric).
    if (!q.minimiser(best) || (to_om(best) - mid).norm() > 2 * length) {
      best = to_q(mid);
      double e_best = q.error(best);
      for (const Vec3d& c : {p0, p1}) {
        const double ec = q.error(to_q(c));
        if (ec < e_best) e_best = ec, best = to_q(c);
      }
    }
    x = to_om(best);
    cost = q.error(best);
    return std::isfinite(cost);
  }

  // Whether moving the faces around v0 and v1 (not those on edge h) to x keeps them facing the
  // same way and non-degenerate.
  bool geometry_ok(QMesh::HalfedgeHandle h, const Vec3d& x) const {
    const auto v0 = m_.from_vertex_handle(h), v1 = m_.to_vertex_handle(h);
    const double cos_limit = std::cos((relaxed_ ? kRelaxedTurnDegrees : kMaxTurnDegrees) * M_PI / 180.0);
    for (auto v : {v0, v1}) {
      // Every face here holds v; those holding both ends vanish with the edge.
      for (auto f : m_.vf_range(v)) {
        QMesh::VertexHandle vs[3];
        int k = 0, ends = 0;
        for (auto fv : m_.fv_range(f)) vs[k++] = fv;
        for (int i = 0; i < 3; ++i) ends += vs[i] == v0 || vs[i] == v1;
        if (ends == 2) continue;
        Vec3d p[3];
        for (int i = 0; i < 3; ++i) p[i] = vs[i] == v0 || vs[i] == v1 ? x : m_.point(vs[i]);
        const Vec3d old_n = (m_.point(vs[1]) - m_.point(vs[0])) % (m_.point(vs[2]) - m_.point(vs[0]));
        const Vec3d new_n = (p[1] - p[0]) % (p[2] - p[0]);
        const double old_len = old_n.norm(), new_len = new_n.norm();
        const double e2 = (p[1] - p[0]).sqrnorm() + (p[2] - p[1]).sqrnorm() + (p[0] - p[2]).sqrnorm();
        if (!(new_len > 1e-8 * e2)) return false;  // degenerate (aspect ratio over ~10^8)
        if (old_len > 0 && (old_n | new_n) < cos_limit * old_len * new_len) return false;
      }
    }
    return true;
  }

  // OpenMesh's link condition for collapsing h (from → to), as TriConnectivity::is_collapse_ok
  // states it, with its one-ring test on a stamp array of our own: the library's own version
  // spent most of its time looking up its status property.
  bool link_ok(QMesh::HalfedgeHandle v0v1) {
    const auto v1v0 = m_.opposite_halfedge_handle(v0v1);
    const auto v0 = m_.to_vertex_handle(v1v0), v1 = m_.to_vertex_handle(v0v1);
    const bool v0v1_boundary = m_.is_boundary(v0v1), v1v0_boundary = m_.is_boundary(v1v0);
    QMesh::VertexHandle vl, vr;
    // The edges v1-vl and vl-v0 must not both be boundary edges; nor v0-vr and vr-v1.
    if (!v0v1_boundary) {
      const auto h1 = m_.next_halfedge_handle(v0v1), h2 = m_.next_halfedge_handle(h1);
      vl = m_.to_vertex_handle(h1);
      if (m_.is_boundary(m_.opposite_halfedge_handle(h1)) && m_.is_boundary(m_.opposite_halfedge_handle(h2))) return false;
    }
    if (!v1v0_boundary) {
      const auto h1 = m_.next_halfedge_handle(v1v0), h2 = m_.next_halfedge_handle(h1);
      vr = m_.to_vertex_handle(h1);
      if (m_.is_boundary(m_.opposite_halfedge_handle(h1)) && m_.is_boundary(m_.opposite_halfedge_handle(h2))) return false;
    }
    if (vl == vr) return false;  // equal, or both invalid
    // The one-rings of v0 and v1 meet only at vl and vr.
    if (++epoch_ == 0) std::fill(stamp_.begin(), stamp_.end(), 0), epoch_ = 1;
    for (auto w : m_.vv_range(v1)) stamp_[w.idx()] = epoch_;
    for (auto w : m_.vv_range(v0))
      if (stamp_[w.idx()] == epoch_ && w != vl && w != vr) return false;
    // An edge between two boundary vertices must be a boundary edge.
    return !(m_.is_boundary(v0) && m_.is_boundary(v1) && !v0v1_boundary && !v1v0_boundary);
  }

  // Collapsing free vertex a onto locked b (h: a → b) joins every neighbour of a to b. A locked
  // neighbour may already be joined to b by faces this mesh does not hold (another piece's), and
  // the link condition cannot see those: so no locked neighbour of a but b and the two vertices
  // across the edge, whose joins to b are this mesh's own.
  bool locked_neighbours_ok(QMesh::HalfedgeHandle h) const {
    const auto a = m_.from_vertex_handle(h), b = m_.to_vertex_handle(h);
    QMesh::VertexHandle across[2];
    int n = 0;
    if (!m_.is_boundary(h)) across[n++] = m_.to_vertex_handle(m_.next_halfedge_handle(h));
    const auto o = m_.opposite_halfedge_handle(h);
    if (!m_.is_boundary(o)) across[n++] = m_.to_vertex_handle(m_.next_halfedge_handle(o));
    for (auto w : m_.vv_range(a)) {
      if (w == b || !locked(w)) continue;
      bool ok = false;
      for (int i = 0; i < n; ++i) ok = ok || across[i] == w;
      if (!ok) return false;
    }
    return true;
  }

  void push(QMesh::EdgeHandle e) {
    if (m_.status(e).deleted()) return;
    Vec3d x;
    double cost;
    if (!evaluate(e, x, cost)) return;
    target_[e.idx()] = x;
    heap_.set(std::uint32_t(e.idx()), cost);
  }

  DecimationResult run(const DecimationOptions& options, std::uint64_t faces) {
    DecimationResult r;
    for (auto e : m_.edges()) push(e);
    while (options.target_faces == 0 || faces > options.target_faces) {
      if (heap_.empty()) {
        // Short of the face target with every remaining collapse refused: once more with the
        // turn limit relaxed to "no flipped face", then the topology is what stops it.
        if (relaxed_ || options.target_faces == 0 || !options.relax_turn_limit) break;
        relaxed_ = true;
        for (auto e : m_.edges()) push(e);
        continue;
      }
      const Candidate c = heap_.top();
      heap_.pop();  // made or refused, it comes back only when a neighbour's collapse re-queues it
      const QMesh::EdgeHandle e(int(c.edge));
      if (m_.status(e).deleted()) continue;
      Vec3f written;
      const Vec3d x = to_output(target_[c.edge], written);
      auto h = m_.halfedge_handle(e, 0);
      Quadric q = q_[m_.from_vertex_handle(h).idx()];
      q += q_[m_.to_vertex_handle(h).idx()];
      const double error = decimation_error(q, to_q(x));
      if (error > options.max_error) {  // it stays until a neighbour's collapse re-queues it
        ++r.over_error;
        continue;
      }
      if (locked(m_.from_vertex_handle(h)) || locked(m_.to_vertex_handle(h))) {
        if (locked(m_.from_vertex_handle(h))) h = m_.halfedge_handle(e, 1);  // the locked end is kept
        if (!link_ok(h) || !locked_neighbours_ok(h)) {
          ++r.refused;
          continue;
        }
      } else if (!link_ok(h)) {
        h = m_.halfedge_handle(e, 1);
        if (!link_ok(h)) {
          ++r.refused;
          continue;
        }
      }
      if (!geometry_ok(h, x)) {
        ++r.refused;
        continue;
      }
      const bool boundary = m_.is_boundary(e);
      const auto kept = m_.to_vertex_handle(h);
      m_.collapse(h);
      m_.set_point(kept, x);
      position_[kept.idx()] = written;
      q_[kept.idx()] = q;
      faces -= boundary ? 1 : 2;
      ++r.collapses;
      r.estimated_error = std::max(r.estimated_error, error);
      for (auto ve : m_.ve_range(kept)) push(ve);
    }
    r.reached_target = options.target_faces == 0 || faces <= options.target_faces;
    return r;
  }

 private:
  QMesh& m_;
  std::vector<Quadric> q_;
  std::vector<Vec3d> target_;
  EdgeHeap heap_;
  std::span<const std::uint8_t> locked_;
  std::vector<std::uint32_t> stamp_;  // link_ok's one-ring marks
  std::uint32_t epoch_ = 0;
  const QuadricFrame& frame_;
  std::vector<Vec3f> position_;
  bool relaxed_ = false;
};

}  // namespace

double decimation_error(const Quadric& q, const Vec3dq& p) {
  return q.weight > 0 ? std::sqrt(q.error(p) / q.weight) : 0;
}

Quadric boundary_constraint(const Vec3dq& a, const Vec3dq& b, const Vec3dq& n) {
  const Vec3d pa = to_om(a), pb = to_om(b);
  Vec3d m = (pb - pa) % to_om(n);
  const double length = m.norm();
  if (!(length > 0)) return Quadric{};
  m /= length;
  Quadric c = Quadric::plane(to_q(m), -(m | pa), kBoundaryWeight * (pb - pa).sqrnorm());
  c.weight = 0;
  return c;
}

format::Result<DecimationResult> decimate(MeshView approximation, const std::vector<FixedQuadric>& sums,
                                          const QuadricFrame& frame, const DecimationOptions& options) {
  if (sums.size() != approximation.positions.size()) {
    return format::Status::error(format::Code::kProcessing, "finish", "one quadric per vertex expected");
  }
  std::vector<Quadric> quadrics(sums.size());
  for (std::size_t v = 0; v < sums.size(); ++v) quadrics[v] = sums[v].to_double();
  return decimate(approximation, std::move(quadrics), frame, options);
}

format::Result<DecimationResult> decimate(MeshView approximation, std::vector<Quadric> quadrics,
                                          const QuadricFrame& frame, const DecimationOptions& options) {
  if (quadrics.size() != approximation.positions.size() ||
      (!options.locked.empty() && options.locked.size() != approximation.positions.size())) {
    return format::Status::error(format::Code::kProcessing, "finish", "one quadric per vertex expected");
  }
  // A face OpenMesh refuses is our error to report (below), not a line of its own on stderr.
  omerr().disable();
  QMesh mesh;
  mesh.reserve(approximation.positions.size(), 3 * approximation.triangles.size() / 2,
               approximation.triangles.size());
  for (const auto& p : approximation.positions) mesh.add_vertex(to_om(frame.to_frame(p.x, p.y, p.z)));
  for (const auto& t : approximation.triangles) {
    const auto f = mesh.add_face(QMesh::VertexHandle(int(t.v[0])), QMesh::VertexHandle(int(t.v[1])),
                                 QMesh::VertexHandle(int(t.v[2])));
    if (!f.is_valid()) {
      return format::Status::error(format::Code::kProcessing, "finish",
                                   "the approximation is not an oriented manifold (face " +
                                       std::to_string(&t - approximation.triangles.data()) + ")");
    }
  }
  // Boundary constraints: a plane through each boundary edge, at right angles to its face.
  for (auto e : mesh.edges()) {
    if (!options.boundary_constraints || !mesh.is_boundary(e)) continue;
    auto h = mesh.halfedge_handle(e, 0);
    if (mesh.is_boundary(h)) h = mesh.opposite_halfedge_handle(h);
    const auto f = mesh.face_handle(h);
    const Vec3d a = mesh.point(mesh.from_vertex_handle(h)), b = mesh.point(mesh.to_vertex_handle(h));
    Vec3d fv[3];
    int k = 0;
    for (auto v : mesh.fv_range(f)) fv[k++] = mesh.point(v);
    const Quadric c = boundary_constraint(to_q(a), to_q(b), to_q((fv[1] - fv[0]) % (fv[2] - fv[0])));
    quadrics[mesh.from_vertex_handle(h).idx()] += c;
    quadrics[mesh.to_vertex_handle(h).idx()] += c;
  }

  Decimator decimator(mesh, std::move(quadrics), options.locked, frame, approximation.positions);
  DecimationResult result = decimator.run(options, approximation.triangles.size());
  // Each vertex's index before the garbage collection, which moves vertices into the holes.
  OpenMesh::VPropHandleT<int> source;
  mesh.add_property(source);
  for (auto v : mesh.vertices()) mesh.property(source, v) = v.idx();
  mesh.garbage_collection();
  result.mesh.positions.reserve(mesh.n_vertices());
  result.source.reserve(mesh.n_vertices());
  result.quadrics.reserve(mesh.n_vertices());
  for (auto v : mesh.vertices()) {
    const int from = mesh.property(source, v);
    result.source.push_back(std::uint32_t(from));
    result.quadrics.push_back(decimator.quadrics()[from]);
    result.mesh.positions.push_back(decimator.positions()[from]);
  }
  result.mesh.triangles.reserve(mesh.n_faces());
  for (auto f : mesh.faces()) {
    format::Triangle t;
    int k = 0;
    for (auto v : mesh.fv_range(f)) t.v[k++] = std::uint32_t(v.idx());
    result.mesh.triangles.push_back(t);
  }
  return result;
}

}  // namespace gaussmesh::stream
