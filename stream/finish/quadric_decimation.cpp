#include "stream/finish/quadric_decimation.h"

#include "stream/core/canonical_order.h"
#include "stream/core/morton.h"
#include "stream/finish/collapse_mesh.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace gaussmesh::stream {
namespace {

// The cost of moving the regions of the two ends of an edge, with quadrics a and b (q = a + b), to
// x: the geometric mean of the merged region's mean squared distance to its planes and the worse
// of the two regions' own. The summed quadric E(x) alone (Garland & Heckbert) ranks a collapse by
// area times mean squared distance, so a small, sharply curved region goes early and whole into a
// large flat one beside it (its distances diluted by the other's area), and a few long edges end
// up across the curves. The worse end's mean alone (meshoptimizer's rule) and the merged mean
// alone did worse on the refined 1M-triangle cows and tori (docs/finish.md).
double collapse_cost(const Quadric& q, const Quadric& a, const Quadric& b, const Vec3dq& x) {
  return std::sqrt(q.mean_error(x) * std::max(a.mean_error(x), b.mean_error(x)));
}

// The point of segment p0-p1 where q is least (q restricted to the line is a parabola in t).
Vec3dq along_edge(const Quadric& q, const Vec3dq& p0, const Vec3dq& p1) {
  const auto& a = q.q;
  const Vec3dq d = sub(p1, p0);
  const Vec3dq ad{a[0] * d.x + a[1] * d.y + a[2] * d.z, a[1] * d.x + a[3] * d.y + a[4] * d.z,
                  a[2] * d.x + a[4] * d.y + a[5] * d.z};
  const Vec3dq gradient{a[0] * p0.x + a[1] * p0.y + a[2] * p0.z + a[6], a[1] * p0.x + a[3] * p0.y + a[4] * p0.z + a[7],
                        a[2] * p0.x + a[4] * p0.y + a[5] * p0.z + a[8]};
  const double curvature = dot(d, ad);
  if (!(curvature > 0)) return p0;
  return add(p0, scale(d, std::clamp(-dot(gradient, d) / curvature, 0.0, 1.0)));
}

// Equal costs (a flat region's collapses all cost nothing) go by edge number, but an edge whose two
// ends have more than kCrowdedDegrees edges between them waits behind the others, fewest first:
// otherwise the collapses of a flat region keep merging into one vertex, whose fan grows with
// every one, and each collapse and link test walks it.
inline constexpr std::uint32_t kCrowdedDegrees = 32;
struct Candidate {
  double cost;
  std::uint32_t edge;
  std::uint32_t crowding;  // the ends' edges when more than kCrowdedDegrees, else 0
  bool before(const Candidate& o) const {
    if (cost != o.cost) return cost < o.cost;
    return crowding != o.crowding ? crowding < o.crowding : edge < o.edge;
  }
};

// A 4-ary min-heap of (cost, edge) with at most one entry per edge, whose cost can be updated:
// the collapses pop it several million times on a large input, and a heap of stale entries
// (std::priority_queue with lazy deletion) spent most of the run in cache misses.
class EdgeHeap {
 public:
  explicit EdgeHeap(std::size_t edges) : pos_(edges, kAbsent) {}
  bool empty() const { return heap_.empty(); }
  const Candidate& top() const { return heap_.front(); }
  void set(std::uint32_t edge, double cost, std::uint32_t crowding) {
    const Candidate c{cost, edge, crowding};
    if (pos_[edge] == kAbsent) {
      pos_[edge] = std::uint32_t(heap_.size());
      heap_.push_back(c);
      up(heap_.size() - 1);
    } else {
      const std::size_t i = pos_[edge];
      const bool lower = c.before(heap_[i]);
      heap_[i] = c;
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

// A vertex's place with respect to the seams: with one wedge (its values the same in all its
// faces, also at the end of a seam edge whose values differ only at its other end), on one seam
// (two seam edges, two wedges), or fixed (where seams meet, or meet a boundary).
constexpr std::uint8_t kFree = 0, kSeam = 1, kFixed = 2;

class Decimator {
 public:
  Decimator(CollapseMesh& mesh, std::vector<Vec3dq> points, std::vector<Quadric> quadrics,
            std::span<const std::uint8_t> locked, const QuadricFrame& frame, std::vector<Vec3f> input)
      : m_(mesh), p_(std::move(points)), q_(std::move(quadrics)), heap_(mesh.edge_count()), locked_(locked),
        stamp_(mesh.vertex_count(), 0), frame_(frame), position_(std::move(input)) {
    target_.resize(m_.edge_count());
  }
  const std::vector<Quadric>& quadrics() const { return q_; }
  // Each vertex's output position: its input's, or where its last collapse put it.
  const std::vector<Vec3f>& positions() const { return position_; }
  void track_regions() { parent_.assign(m_.vertex_count(), CollapseMesh::kNone); }

  // x moved to the nearest point the output can hold (float input coordinates), so that the
  // geometry tests see the faces as they will be written: a face thin enough to lose its area
  // to that rounding is refused, not written.
  Vec3dq to_output(const Vec3dq& x, Vec3f& out) const {
    out = {to_float(frame_.origin.x + x.x * frame_.scale), to_float(frame_.origin.y + x.y * frame_.scale),
           to_float(frame_.origin.z + x.z * frame_.scale)};
    return frame_.to_frame(out.x, out.y, out.z);
  }

  bool locked(std::uint32_t v) const { return !locked_.empty() && locked_[v]; }

  void set_colours(std::vector<ColourSum> colours) { c_ = std::move(colours); }
  // Vertex v's quadric as the collapses weigh it (with its colour error, ColourSum::effective):
  // q_[v] itself without colours, else `scratch` filled with it (no copy on the plain path, which
  // runs this for every edge and every vertex of every sweep).
  const Quadric& weighed(std::uint32_t v, std::optional<Quadric>& scratch) const {
    if (c_.empty()) return q_[v];
    return scratch.emplace(c_[v].effective(q_[v]));
  }
  // The same for the region of v0 and v1 together (q: their summed quadric).
  const Quadric& weighed(const Quadric& q, std::uint32_t v0, std::uint32_t v1, std::optional<Quadric>& scratch) const {
    if (c_.empty()) return q;
    ColourSum c = c_[v0];
    c += c_[v1];
    return scratch.emplace(c.effective(q));
  }
  // After collapsing `from` onto `to`: `to` holds both ends' colour sums.
  void merge_colours(std::uint32_t from, std::uint32_t to) {
    if (!c_.empty()) c_[to] += c_[from];
  }

  // Seams (DecimationOptions::corner_wedges): `wedges` per corner of the mesh's faces, `kinds`
  // per vertex, `seam_edges` per edge (seam_kinds).
  void set_seams(std::vector<std::uint32_t> wedges, std::vector<std::uint8_t> kinds, std::vector<std::uint8_t> seam_edges) {
    wedge_ = std::move(wedges);
    kind_ = std::move(kinds);
    seam_edge_ = std::move(seam_edges);
  }
  bool seams() const { return !wedge_.empty(); }
  const std::vector<std::uint32_t>& wedges() const { return wedge_; }
  // Per vertex: the vertex it was collapsed onto (kNone while it lives).
  const std::vector<std::uint32_t>& parents() const { return parent_; }

  // Which end of edge e (v0-v1) a collapse removes and which it keeps, when seams decide it
  // (DecimationOptions::corner_wedges); false when they forbid it. `placed`: the kept end stays
  // where it is (it is on a seam). Without seams, or with both ends off them, placed is false and
  // the caller decides.
  bool seam_choice(std::uint32_t e, std::uint32_t v0, std::uint32_t v1, std::uint32_t& from, std::uint32_t& to,
                   bool& placed) const {
    placed = false;
    if (!seams()) return true;
    const std::uint8_t k0 = kind_[v0], k1 = kind_[v1];
    if (seam_edge_[e]) {  // only a seam vertex goes along its seam
      if (k0 != kSeam && k1 != kSeam) return false;
      to = k0 != kSeam ? v0 : k1 != kSeam ? v1 : locked(v0) ? v0 : locked(v1) ? v1 : std::min(v0, v1);
    } else {
      if (k0 == kFree && k1 == kFree) return true;
      if (k0 != kFree && k1 != kFree) return false;  // it would join two seams
      to = k0 != kFree ? v0 : v1;
    }
    placed = true;
    from = to == v0 ? v1 : v0;
    return !locked(from);
  }

  // A seam vertex goes along its seam only when the seam's next vertex is not across the edge
  // (then a face would hold two of its seam edges, and the seam would run along a merged edge).
  bool seam_across_ok(std::uint32_t from, const CollapseMesh::Across& across) {
    if (!seams() || kind_[from] != kSeam) return true;
    bool ok = true;
    m_.for_each_edge(from, [&](std::uint32_t e, std::uint32_t w) {
      if (seam_edge_[e] && (w == across.vertex[0] || w == across.vertex[1])) ok = false;
    });
    return ok;
  }

  // m_.collapse(from, to), keeping the corners' wedges: a face that keeps its `from` corner takes
  // for it the wedge `to` has in the face on the edge on the same side (the one whose `from`
  // corner had the same wedge).
  int collapse(std::uint32_t from, std::uint32_t to) {
    if (seams()) {
      std::uint32_t old_w[2], new_w[2];
      int mapped = 0;
      moved_.clear();
      m_.for_each_face(from, [&](std::uint32_t f) {
        const auto& t = m_.face(f);
        int kf = 0, kt = -1;
        for (int k = 0; k < 3; ++k) {
          if (t.v[k] == from) kf = k;
          if (t.v[k] == to) kt = k;
        }
        if (kt < 0) {
          moved_.push_back(f * 3 + std::uint32_t(kf));
        } else if (mapped < 2) {
          old_w[mapped] = wedge_[f * 3 + kf];
          new_w[mapped] = wedge_[f * 3 + std::uint32_t(kt)];
          ++mapped;
        }
      });
      for (const std::uint32_t c : moved_)
        for (int i = 0; i < mapped; ++i)
          if (wedge_[c] == old_w[i]) {
            wedge_[c] = new_w[i];
            break;
          }
    }
    if (!parent_.empty()) parent_[from] = to;
    return m_.collapse(from, to);
  }

  // The placement and cost of collapsing edge e.
  // Compiled twice (kColours), so that the plain path, which runs for every edge many times, pays
  // nothing for colours.
  bool evaluate(std::uint32_t e, Vec3dq& x, double& cost) const {
    return c_.empty() ? evaluate_as<false>(e, x, cost) : evaluate_as<true>(e, x, cost);
  }
  template <bool kColours>
  bool evaluate_as(std::uint32_t e, Vec3dq& x, double& cost) const {
    const std::uint32_t v0 = m_.edge(e).v[0], v1 = m_.edge(e).v[1];
    Quadric sum = q_[v0];
    sum += q_[v1];
    std::optional<Quadric> merged, e0, e1;
    const Quadric& q = kColours ? weighed(sum, v0, v1, merged) : sum;
    const Quadric& q0 = kColours ? weighed(v0, e0) : q_[v0];
    const Quadric& q1 = kColours ? weighed(v1, e1) : q_[v1];
    const Vec3dq p0 = p_[v0], p1 = p_[v1], mid = scale(add(p0, p1), 0.5);
    std::uint32_t from = v0, to = v1;
    bool placed = false;
    if (!seam_choice(e, v0, v1, from, to, placed)) return false;
    if (placed) {  // onto the seam end, which stays
      x = p_[to];
      cost = collapse_cost(q, q0, q1, x);
      return std::isfinite(cost);
    }
    if (locked(v0) || locked(v1)) {  // onto the locked end, if only one is
      if (locked(v0) && locked(v1)) return false;
      x = locked(v0) ? p0 : p1;
      cost = collapse_cost(q, q0, q1, x);
      return std::isfinite(cost);
    }
    Vec3dq best;
    const double length = norm(sub(p1, p0));
    // The minimiser, unless it lies far from the edge (an ill-conditioned quadric); then the
    // best of the edge's own points: its ends, its midpoint, and the minimiser along it.
    if (!q.minimiser(best) || norm(sub(best, mid)) > 2 * length) {
      best = mid;
      double e_best = q.error(best);
      for (const Vec3dq& c : {p0, p1, along_edge(q, p0, p1)}) {
        const double ec = q.error(c);
        if (ec < e_best) e_best = ec, best = c;
      }
    }
    x = best;
    cost = collapse_cost(q, q0, q1, best);
    return std::isfinite(cost);
  }

  // Whether moving the faces around `from` and `to` (not those on their edge) to x keeps them
  // facing the same way and non-degenerate. A face that is degenerate already (an input's
  // zero-area faces: coincident or collinear corners) may stay so, and has no way to face: were
  // it refused, a mesh with many such faces could not collapse at all.
  bool geometry_ok(std::uint32_t from, std::uint32_t to, const Vec3dq& x) {
    const double cos_limit = relaxed_ ? cos_relaxed_ : cos_strict_;
    bool ok = true;
    for (const std::uint32_t v : {from, to}) {
      // Every face here holds v; those holding both ends vanish with the edge.
      m_.for_each_face(v, [&](std::uint32_t f) {
        if (!ok) return;
        const auto& t = m_.face(f);
        Vec3dq old_p[3], p[3];
        int ends = 0;
        for (int i = 0; i < 3; ++i) {
          const bool end = t.v[i] == from || t.v[i] == to;
          ends += end;
          old_p[i] = p_[t.v[i]];
          p[i] = end ? x : old_p[i];
        }
        if (ends == 2) return;
        const Vec3dq old_n = cross(sub(old_p[1], old_p[0]), sub(old_p[2], old_p[0]));
        const Vec3dq new_n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        const double old_len = norm(old_n), new_len = norm(new_n);
        const double e2 = norm2(sub(p[1], p[0])) + norm2(sub(p[2], p[1])) + norm2(sub(p[0], p[2]));
        const double old_e2 = norm2(sub(old_p[1], old_p[0])) + norm2(sub(old_p[2], old_p[1])) + norm2(sub(old_p[0], old_p[2]));
        if (!(old_len > 1e-8 * old_e2)) return;  // degenerate (aspect ratio over ~10^8) already
        if (!(new_len > 1e-8 * e2)) ok = false;   // would become degenerate
        else if (dot(old_n, new_n) < cos_limit * old_len * new_len) ok = false;
      });
      if (!ok) return false;
    }
    return true;
  }

  // Collapsing free vertex a onto locked b joins every neighbour of a to b. A locked neighbour
  // may already be joined to b by faces this mesh does not hold (another piece's), and the link
  // condition cannot see those: so no locked neighbour of a but b and the two vertices across
  // the edge, whose joins to b are this mesh's own.
  bool locked_neighbours_ok(std::uint32_t a, std::uint32_t b, const CollapseMesh::Across& across) {
    bool ok = true;
    m_.for_each_edge(a, [&](std::uint32_t, std::uint32_t w) {
      if (w != b && locked(w) && w != across.vertex[0] && w != across.vertex[1]) ok = false;
    });
    return ok;
  }

  void push(std::uint32_t e) {
    Vec3dq x;
    double cost;
    if (!evaluate(e, x, cost)) return;
    target_[e] = x;
    const std::uint32_t degrees = degree_[m_.edge(e).v[0]] + degree_[m_.edge(e).v[1]];
    heap_.set(e, cost, degrees > kCrowdedDegrees ? degrees : 0);
  }
  void push_all() {
    degree_.assign(m_.vertex_count(), 0);
    for (std::uint32_t e = 0; e < m_.edge_count(); ++e)
      if (m_.edge_alive(e)) ++degree_[m_.edge(e).v[0]], ++degree_[m_.edge(e).v[1]];
    for (std::uint32_t e = 0; e < m_.edge_count(); ++e)
      if (m_.edge_alive(e)) push(e);
  }

  // The neighbour of free vertex v that it joins most cheaply (collapse_cost with v moved onto
  // it), leaving out those that took a collapse in this sweep; kNone when there is none.
  std::uint32_t cheapest_neighbour(std::uint32_t v, double& cost) {
    return c_.empty() ? cheapest_neighbour_as<false>(v, cost) : cheapest_neighbour_as<true>(v, cost);
  }
  template <bool kColours>
  std::uint32_t cheapest_neighbour_as(std::uint32_t v, double& cost) {
    std::uint32_t best = CollapseMesh::kNone;
    cost = std::numeric_limits<double>::infinity();
    std::optional<Quadric> own;
    const Quadric& a = kColours ? weighed(v, own) : q_[v];
    m_.for_each_edge(v, [&](std::uint32_t e, std::uint32_t w) {
      if (swept_[w] == sweep_) return;
      // With seams: a vertex off them joins a neighbour across an edge that is not a seam, one on
      // a seam goes along it (seam_choice).
      if (seams() && (kind_[v] == kSeam) != bool(seam_edge_[e])) return;
      // collapse_cost at p_w from the two ends' own errors there, w's cached.
      const double ea = a.error(p_[w]), eb = own_error_[w];
      const double wa = a.weight, wb = q_[w].weight, wq = wa + wb;
      // With colours the merged region's error is not the sum of its parts' (the best colour
      // for both is another): it is weighed whole.
      double em = ea + eb;
      if constexpr (kColours) {
        Quadric sum = q_[v];
        sum += q_[w];
        std::optional<Quadric> scratch;
        em = weighed(sum, v, w, scratch).error(p_[w]);
      }
      const double merged = wq > 0 ? em / wq : em;
      const double worse = std::max(wa > 0 ? ea / wa : ea, wb > 0 ? eb / wb : eb);
      const double c = std::sqrt(merged * worse);
      if (std::isfinite(c) && (best == CollapseMesh::kNone || c < cost || (c == cost && w < best))) best = w, cost = c;
    });
    return best;
  }

  // Sweeps of collapses onto neighbours (DecimationOptions::sweep_to_faces) down to about `goal`
  // faces: they stop within kSweepRest of it, or when one makes few collapses, and the queue
  // takes the rest (a sweep costs a pass over every vertex, however few it collapses).
  void sweep(const DecimationOptions& options, std::uint64_t goal, std::uint64_t& faces, DecimationResult& r) {
    swept_.assign(m_.vertex_count(), 0);
    own_error_.assign(m_.vertex_count(), 0);
    choice_.assign(m_.vertex_count(), CollapseMesh::kNone);
    std::vector<std::pair<double, std::uint32_t>> candidates;
    while (faces > goal && double(faces - goal) > kSweepRest * double(faces)) {
      ++sweep_;
      candidates.clear();
      for (std::uint32_t v = 0; v < m_.vertex_count(); ++v) {
        if (!m_.vertex_alive(v)) continue;
        std::optional<Quadric> scratch;
        own_error_[v] = weighed(v, scratch).error(p_[v]);
      }
      for (std::uint32_t v = 0; v < m_.vertex_count(); ++v) {
        double cost;
        if (!m_.vertex_alive(v) || locked(v) || (seams() && kind_[v] == kFixed)) continue;
        choice_[v] = cheapest_neighbour(v, cost);
        if (choice_[v] != CollapseMesh::kNone) candidates.push_back({cost, v});
      }
      // Each collapse takes two faces (one on a boundary): the cost at the rank of the last one
      // needed, with slack for those that will be blocked or refused.
      const std::size_t needed = std::size_t((faces - goal + 1) / 2);
      if (needed < candidates.size()) {
        std::nth_element(candidates.begin(), candidates.begin() + std::ptrdiff_t(needed), candidates.end());
        const double limit = kSweepSlack * candidates[needed].first;
        candidates.erase(std::partition(candidates.begin(), candidates.end(),
                                        [&](const auto& c) { return c.first <= limit; }),
                         candidates.end());
      }
      std::sort(candidates.begin(), candidates.end());
      const double limit = candidates.empty() ? 0 : candidates.back().first;
      std::uint64_t made = 0;
      for (const auto& [ignored, v] : candidates) {
        if (faces <= goal) break;
        if (!m_.vertex_alive(v) || swept_[v] == sweep_) continue;
        // The choice stands while it is alive and took no collapse: v's quadric and its other
        // free neighbours' are as they were, and any new neighbour took one. Else choose again.
        std::uint32_t w = choice_[v];
        if (!m_.vertex_alive(w) || swept_[w] == sweep_) {
          double cost;
          w = cheapest_neighbour(v, cost);
          if (w == CollapseMesh::kNone || cost > limit) continue;
        }
        Quadric q = q_[v];
        q += q_[w];
        std::optional<Quadric> scratch;
        const double error = decimation_error(weighed(q, v, w, scratch), p_[w]);
        if (error > options.max_error) {
          ++r.over_error;
          continue;
        }
        CollapseMesh::Across across;
        if (!m_.link_ok(v, w, stamp_, epoch_, across) || (locked(w) && !locked_neighbours_ok(v, w, across)) ||
            !seam_across_ok(v, across) || !geometry_ok(v, w, p_[w])) {
          ++r.refused;
          continue;
        }
        faces -= std::uint64_t(collapse(v, w));
        q_[w] = q;
        merge_colours(v, w);
        own_error_[w] = weighed(w, scratch).error(p_[w]);
        swept_[w] = sweep_;
        ++made;
        ++r.collapses;
        ++r.swept;
        r.estimated_error = std::max(r.estimated_error, error);
      }
      if (made == 0 || made < needed / 16) break;
    }
  }

  DecimationResult run(const DecimationOptions& options, std::uint64_t faces) {
    DecimationResult r;
    if (options.sweep_to_faces > options.target_faces && options.target_faces > 0)
      sweep(options, options.sweep_to_faces, faces, r);
    push_all();
    while (options.target_faces == 0 || faces > options.target_faces) {
      if (heap_.empty()) {
        // Short of the face target with every remaining collapse refused: once more with the
        // turn limit relaxed to "no flipped face", then the topology is what stops it.
        if (relaxed_ || options.target_faces == 0 || !options.relax_turn_limit) break;
        relaxed_ = true;
        push_all();
        continue;
      }
      const Candidate c = heap_.top();
      heap_.pop();  // made or refused, it comes back only when a neighbour's collapse re-queues it
      if (!m_.edge_alive(c.edge)) continue;
      Vec3f written;
      const Vec3dq x = to_output(target_[c.edge], written);
      const std::uint32_t v0 = m_.edge(c.edge).v[0], v1 = m_.edge(c.edge).v[1];
      Quadric q = q_[v0];
      q += q_[v1];
      std::optional<Quadric> scratch;
      const double error = decimation_error(weighed(q, v0, v1, scratch), x);
      if (error > options.max_error) {  // it stays until a neighbour's collapse re-queues it
        ++r.over_error;
        continue;
      }
      // The kept vertex: the seam end (seam_choice), else the locked end if there is one, else the
      // one that appears first in the faces.
      // An entry whose edge a collapse nearby made one it may not collapse (two locked ends, or
      // what the seams forbid) stays in the queue, as push() leaves it: it is dropped here.
      if (locked(v0) && locked(v1)) continue;
      std::uint32_t to = locked(v0) ? v0 : locked(v1) ? v1 : std::min(v0, v1);
      std::uint32_t from = to == v0 ? v1 : v0;
      bool placed = false;
      if (!seam_choice(c.edge, v0, v1, from, to, placed)) continue;
      CollapseMesh::Across across;
      if (!m_.link_ok(from, to, stamp_, epoch_, across) || (locked(to) && !locked_neighbours_ok(from, to, across)) ||
          !seam_across_ok(from, across) || !geometry_ok(from, to, x)) {
        ++r.refused;
        continue;
      }
      faces -= std::uint64_t(collapse(from, to));
      merge_colours(from, to);
      if (!placed) {  // a seam end keeps its input position exactly
        p_[to] = x;
        position_[to] = written;
      }
      q_[to] = q;
      ++r.collapses;
      r.estimated_error = std::max(r.estimated_error, error);
      // `to` takes `from`'s edges but the one between them and those to the vertices across,
      // which merge with its own (the link condition leaves no other common neighbour).
      degree_[to] += degree_[from] - 2 - std::uint32_t(across.count);
      for (int i = 0; i < across.count; ++i) --degree_[across.vertex[i]];
      m_.for_each_edge(to, [&](std::uint32_t e, std::uint32_t) { push(e); });
    }
    r.reached_target = options.target_faces == 0 || faces <= options.target_faces;
    return r;
  }

 private:
  CollapseMesh& m_;
  std::vector<Vec3dq> p_;  // positions in the frame
  std::vector<Quadric> q_;
  std::vector<ColourSum> c_;  // per vertex, with colours (DecimationOptions::colours)
  std::vector<Vec3dq> target_;
  EdgeHeap heap_;
  std::span<const std::uint8_t> locked_;
  std::vector<std::uint32_t> stamp_;  // link_ok's one-ring marks
  std::vector<std::uint32_t> swept_;  // per vertex: the last sweep that collapsed onto it
  std::vector<double> own_error_;     // per vertex: its quadric's error at its own place
  std::vector<std::uint32_t> choice_; // per vertex: the neighbour this sweep chose for it
  std::vector<std::uint32_t> degree_; // per vertex: its edges, for the queue's ties (Candidate)
  std::uint32_t sweep_ = 0;
  std::uint32_t epoch_ = 0;
  const QuadricFrame& frame_;
  std::vector<Vec3f> position_;
  // Seams: per corner its wedge, per vertex its kind, per edge whether it is a seam (set_seams);
  // per vertex the vertex it was collapsed onto; collapse's scratch.
  std::vector<std::uint32_t> wedge_;
  std::vector<std::uint8_t> kind_;
  std::vector<std::uint8_t> seam_edge_;
  std::vector<std::uint32_t> parent_;
  std::vector<std::uint32_t> moved_;
  bool relaxed_ = false;
  const double cos_strict_ = std::cos(kMaxTurnDegrees * M_PI / 180.0);
  const double cos_relaxed_ = std::cos(kRelaxedTurnDegrees * M_PI / 180.0);
};

// The vertices in Morton order of their positions over their bounding box, ties by position
// (and positions that are not finite, last, by id).
std::vector<std::uint32_t> spatial_order(std::span<const Vec3f> positions) {
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool first = true;
  for (const auto& p : positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const float c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = first ? c[a] : std::min(lo[a], c[a]);
      hi[a] = first ? c[a] : std::max(hi[a], c[a]);
    }
    first = false;
  }
  const double extent = std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]});
  const double scale = extent > 0 ? double((1u << 21) - 1) / extent : 0;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(positions.size());
  for (std::uint32_t v = 0; v < positions.size(); ++v) {
    const auto& p = positions[v];
    std::uint64_t code = ~std::uint64_t{0};
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      const float c[3] = {p.x, p.y, p.z};
      code = 0;
      for (int a = 0; a < 3; ++a) code |= spread21(std::uint64_t((double(c[a]) - lo[a]) * scale)) << a;
    }
    keys[v] = {code, v};
  }
  // Within a cell by position, so that the order (and the collapses) do not follow the ids.
  std::sort(keys.begin(), keys.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    return position_key(positions[a.second], a.second) < position_key(positions[b.second], b.second);
  });
  std::vector<std::uint32_t> order(positions.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = keys[i].second;
  return order;
}

// The seams of `mesh` (faces in its order, `wedges` per corner): an edge is a seam when its two
// faces take different wedges at one of its ends; a vertex is kFree with one wedge, kSeam with
// two seam edges, two wedges and no boundary, else kFixed.
void seam_kinds(CollapseMesh& mesh, std::span<const format::Triangle> faces, std::span<const std::uint32_t> wedges,
                std::vector<std::uint8_t>& kinds, std::vector<std::uint8_t>& seam_edges) {
  constexpr std::uint32_t kNone = CollapseMesh::kNone;
  const std::size_t n = mesh.vertex_count();
  seam_edges.assign(mesh.edge_count(), 0);
  std::vector<std::array<std::uint32_t, 2>> seen(mesh.edge_count(), {kNone, kNone});
  std::vector<std::uint32_t> first(n, kNone), second(n, kNone);
  std::vector<std::uint8_t> more(n, 0), degree(n, 0);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = faces[f].v[k], b = faces[f].v[(k + 1) % 3];
      const std::uint32_t wa = wedges[3 * f + k], wb = wedges[3 * f + (k + 1) % 3];
      if (first[a] == kNone || first[a] == wa) first[a] = wa;
      else if (second[a] == kNone || second[a] == wa) second[a] = wa;
      else more[a] = 1;
      const std::uint32_t e = mesh.find_edge(a, b);
      if (e == kNone) continue;
      const bool flipped = mesh.edge(e).v[0] != a;
      const std::array<std::uint32_t, 2> w = flipped ? std::array{wb, wa} : std::array{wa, wb};
      if (seen[e][0] == kNone) seen[e] = w;
      else if (seen[e] != w) seam_edges[e] = 1;
    }
  }
  for (std::uint32_t e = 0; e < seam_edges.size(); ++e)
    if (seam_edges[e])
      for (const std::uint32_t v : mesh.edge(e).v) degree[v] = std::uint8_t(std::min(degree[v] + 1, 3));
  kinds.assign(n, kFree);
  for (std::uint32_t v = 0; v < n; ++v) {
    const int distinct = first[v] == kNone ? 0 : second[v] == kNone ? 1 : more[v] ? 3 : 2;
    if (distinct <= 1) kinds[v] = kFree;
    else if (degree[v] == 2 && distinct == 2 && !mesh.is_boundary_vertex(v)) kinds[v] = kSeam;
    else kinds[v] = kFixed;
  }
}

}  // namespace

double sweep_share_of_faces(std::uint64_t faces, std::uint64_t target) {
  if (faces == 0 || target == 0) return 0;
  const double share = kSweepShare * double(target) / double(faces);
  return share <= kSweepMaxShareOfFaces ? share : 0;
}

double decimation_error(const Quadric& q, const Vec3dq& p) {
  return q.weight > 0 ? std::sqrt(q.error(p) / q.weight) : 0;
}

Quadric boundary_constraint(const Vec3dq& a, const Vec3dq& b, const Vec3dq& n) {
  Vec3dq m = cross(sub(b, a), n);
  const double length = norm(m);
  if (!(length > 0)) return Quadric{};
  m = scale(m, 1 / length);
  Quadric c = Quadric::plane(m, -dot(m, a), kBoundaryWeight * norm2(sub(b, a)));
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
      (!options.locked.empty() && options.locked.size() != approximation.positions.size()) ||
      (!options.corner_wedges.empty() && options.corner_wedges.size() != 3 * approximation.triangles.size()) ||
      (!options.colours.empty() && options.colours.size() != approximation.positions.size())) {
    return format::Status::error(format::Code::kProcessing, "finish", "one quadric per vertex expected");
  }
  // The collapses work on a copy in spatial order: vertices by the Morton code of their position,
  // faces by their corners' new numbers. Neighbours then sit close in memory whatever the
  // input's order, and a shuffled copy of the same mesh collapses the same way.
  const std::size_t n = approximation.positions.size();
  std::vector<std::uint32_t> order = spatial_order(approximation.positions), rank(n);
  for (std::uint32_t i = 0; i < n; ++i) rank[order[i]] = i;
  const std::size_t nf = approximation.triangles.size();
  std::vector<format::Triangle> faces(nf);
  std::vector<std::uint32_t> wedges(options.corner_wedges.empty() ? 0 : 3 * nf);
  {
    // Each face from its lowest new number on (the same orientation), sorted by its three.
    std::vector<std::pair<std::uint64_t, std::uint64_t>> keys(nf);
    for (std::uint32_t f = 0; f < nf; ++f) {
      const auto& t = approximation.triangles[f];
      std::uint32_t r[3];
      for (int k = 0; k < 3; ++k) r[k] = t.v[k] < n ? rank[t.v[k]] : CollapseMesh::kNone;
      const int first = r[0] <= r[1] && r[0] <= r[2] ? 0 : r[1] <= r[2] ? 1 : 2;
      faces[f] = {{r[first], r[(first + 1) % 3], r[(first + 2) % 3]}};
      if (!wedges.empty())
        for (int k = 0; k < 3; ++k) wedges[3 * f + k] = options.corner_wedges[3 * f + (first + k) % 3];
      keys[f] = {(std::uint64_t(faces[f].v[0]) << 32) | std::max(faces[f].v[1], faces[f].v[2]),
                 (std::uint64_t(std::min(faces[f].v[1], faces[f].v[2])) << 32) | f};
    }
    std::sort(keys.begin(), keys.end());
    std::vector<format::Triangle> sorted(nf);
    std::vector<std::uint32_t> sorted_wedges(wedges.size());
    for (std::uint32_t i = 0; i < nf; ++i) {
      const auto f = std::uint32_t(keys[i].second);
      sorted[i] = faces[f];
      if (!wedges.empty())
        for (int k = 0; k < 3; ++k) sorted_wedges[3 * i + k] = wedges[3 * f + k];
    }
    faces = std::move(sorted);
    wedges = std::move(sorted_wedges);
  }
  std::string problem;
  auto built = CollapseMesh::build(n, faces, problem);
  if (!built) {
    return format::Status::error(format::Code::kProcessing, "finish",
                                 "the approximation is not an oriented manifold (" + problem + ")");
  }
  CollapseMesh& mesh = *built;
  std::vector<std::uint8_t> kinds, seam_edges;
  if (!wedges.empty()) seam_kinds(mesh, faces, wedges, kinds, seam_edges);
  faces = {};
  std::vector<Vec3dq> points(n);
  std::vector<Vec3f> positions(n);
  std::vector<Quadric> ranked(n);
  std::vector<std::uint8_t> locked(options.locked.empty() ? 0 : n);
  std::vector<ColourSum> colours(options.colours.empty() ? 0 : n);
  for (std::uint32_t i = 0; i < n; ++i) {
    if (!colours.empty()) colours[i] = options.colours[order[i]];
    const Vec3f& p = approximation.positions[order[i]];
    positions[i] = p;
    points[i] = frame.to_frame(p.x, p.y, p.z);
    ranked[i] = quadrics[order[i]];
    if (!locked.empty()) locked[i] = options.locked[order[i]];
  }
  quadrics = {};
  // Boundary constraints: a plane through each boundary edge, at right angles to its face (an
  // edge runs v[0] → v[1] in its face).
  if (options.boundary_constraints) {
    for (std::uint32_t e = 0; e < mesh.edge_count(); ++e) {
      if (!mesh.is_boundary_edge(e)) continue;
      const std::uint32_t v0 = mesh.edge(e).v[0], v1 = mesh.edge(e).v[1];
      const std::uint32_t o = mesh.across(v0, v1).vertex[0];
      const Vec3dq normal = cross(sub(points[v1], points[v0]), sub(points[o], points[v0]));
      const Quadric c = boundary_constraint(points[v0], points[v1], normal);
      ranked[v0] += c;
      ranked[v1] += c;
    }
    // Seam edges likewise, one plane for each of their two faces.
    for (std::uint32_t e = 0; e < seam_edges.size(); ++e) {
      if (!seam_edges[e] || !mesh.edge_alive(e)) continue;
      const std::uint32_t v0 = mesh.edge(e).v[0], v1 = mesh.edge(e).v[1];
      const CollapseMesh::Across across = mesh.across(v0, v1);
      for (int i = 0; i < across.count; ++i) {
        const Vec3dq normal = cross(sub(points[v1], points[v0]), sub(points[across.vertex[i]], points[v0]));
        const Quadric c = boundary_constraint(points[v0], points[v1], normal);
        ranked[v0] += c;
        ranked[v1] += c;
      }
    }
  }

  Decimator decimator(mesh, std::move(points), std::move(ranked), locked, frame, std::move(positions));
  if (!colours.empty()) decimator.set_colours(std::move(colours));
  if (!wedges.empty()) {
    decimator.set_seams(std::move(wedges), std::move(kinds), std::move(seam_edges));
    decimator.track_regions();
  }
  DecimationResult result = decimator.run(options, approximation.triangles.size());
  // Survivors and live faces in the copy's order: the output is then the same for every
  // numbering of the same mesh.
  std::vector<std::uint32_t> index(n, CollapseMesh::kNone);
  for (std::uint32_t i = 0; i < n; ++i) {
    if (!mesh.vertex_alive(i)) continue;
    index[i] = std::uint32_t(result.mesh.positions.size());
    result.source.push_back(order[i]);
    result.quadrics.push_back(decimator.quadrics()[i]);
    result.mesh.positions.push_back(decimator.positions()[i]);
  }
  for (std::uint32_t i = 0; i < nf; ++i) {
    if (!mesh.face_alive(i)) continue;
    const auto& t = mesh.face(i);
    result.mesh.triangles.push_back({{index[t.v[0]], index[t.v[1]], index[t.v[2]]}});
    if (decimator.seams())
      for (int k = 0; k < 3; ++k) result.corner_wedges.push_back(decimator.wedges()[3 * i + k]);
  }
  if (decimator.seams()) {
    // Each input vertex's region: the survivor at the end of its chain of collapses.
    std::vector<std::uint32_t> root(decimator.parents());
    auto find = [&](std::uint32_t v) {
      std::uint32_t r = v;
      while (root[r] != CollapseMesh::kNone) r = root[r];
      while (root[v] != CollapseMesh::kNone) {
        const std::uint32_t next = root[v];
        root[v] = r;
        v = next;
      }
      return r;
    };
    result.region.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) result.region[order[i]] = index[find(i)];
  }
  return result;
}

}  // namespace gaussmesh::stream
