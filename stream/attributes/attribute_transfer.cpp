// Attribute transfer by nearest surface point (attribute_transfer.h): one pass over the input's
// triangles against a grid of the output's vertices, then each vertex's values from its winner.
#include "stream/attributes/attribute_transfer.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include "stream/analysis/mesh_distance.h"
#include "stream/core/canonical_order.h"

namespace gaussmesh::stream {
namespace {

using format::Color;
using format::Triangle;
using format::Vec2f;
using format::Vec3f;

constexpr std::uint64_t kNone = std::numeric_limits<std::uint64_t>::max();

// A vertex's nearest triangle so far, as one word: the squared distance's float bits above the
// triangle's index. Non-negative floats order as their bits, so the smallest word is the nearest
// triangle, the lowest index among equally near ones: the same winner in any order of the
// triangles and any split into threads.
std::uint64_t pack(double distance_squared, std::size_t triangle) {
  const float d = static_cast<float>(distance_squared);
  return (std::uint64_t{std::bit_cast<std::uint32_t>(d)} << 32) | static_cast<std::uint32_t>(triangle);
}

void lower(std::atomic<std::uint64_t>& slot, std::uint64_t word) {
  std::uint64_t seen = slot.load(std::memory_order_relaxed);
  while (word < seen && !slot.compare_exchange_weak(seen, word, std::memory_order_relaxed)) {
  }
}

// The chosen vertices of the output in cells of side `cell`: a triangle visits the cells its
// box, grown by the search radius, overlaps. The vertices are held cell after cell, and the
// occupied cells in an open-addressing table (about 18 bytes a vertex in all, 20 while it is
// built), since the out-of-core transfers hold the grid within the budget beside the output.
class VertexGrid {
 public:
  // Takes the chosen vertices (in any order) and keeps them, cell after cell: release_vertices()
  // hands them back.
  VertexGrid(const std::vector<Vec3f>& positions, std::vector<std::uint32_t> chosen, double cell) : cell_(cell) {
    lo_ = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
           std::numeric_limits<double>::infinity()};
    for (std::uint32_t v : chosen) {
      const Vec3f& p = positions[v];
      lo_ = {std::min(lo_.x, double(p.x)), std::min(lo_.y, double(p.y)), std::min(lo_.z, double(p.z))};
    }
    std::vector<std::uint64_t> keys;  // of the occupied cells, ascending
    {
      std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;
      keyed.reserve(chosen.size());
      for (std::uint32_t v : chosen) keyed.push_back({key(cell_of(positions[v])), v});
      std::vector<std::uint32_t>().swap(chosen);  // held once: as keyed, then as vertices_
      std::sort(keyed.begin(), keyed.end());
      vertices_.reserve(keyed.size());
      for (std::size_t i = 0; i < keyed.size(); ++i) {
        if (i == 0 || keyed[i].first != keyed[i - 1].first) keys.push_back(keyed[i].first), starts_.push_back(std::uint32_t(i));
        vertices_.push_back(keyed[i].second);
      }
    }
    starts_.push_back(std::uint32_t(vertices_.size()));
    std::size_t size = 16;
    while (size < 2 * keys.size()) size *= 2;
    table_keys_.assign(size, kEmpty);
    table_cells_.resize(size);
    for (std::uint32_t c = 0; c < keys.size(); ++c) {
      std::size_t i = slot(keys[c]);
      while (table_keys_[i] != kEmpty) i = (i + 1) & (size - 1);
      table_keys_[i] = keys[c];
      table_cells_[i] = c;
    }
  }

  std::vector<std::uint32_t> release_vertices() { return std::move(vertices_); }

  // The last cell looked up, per caller: neighbouring triangles mostly meet the same cell.
  struct Cursor {
    std::uint64_t key = ~std::uint64_t{0};
    std::pair<std::uint32_t, std::uint32_t> range{0, 0};
  };

  // Calls fn(v) for every chosen vertex in a cell that the box [lo, hi] grown by r overlaps;
  // every vertex when that box spans more cells than there are vertices.
  template <class Fn>
  void near(Vec3d lo, Vec3d hi, double r, Cursor& cursor, Fn&& fn) const {
    const std::array<std::int64_t, 3> a = cell_of(Vec3d{lo.x - r, lo.y - r, lo.z - r});
    const std::array<std::int64_t, 3> b = cell_of(Vec3d{hi.x + r, hi.y + r, hi.z + r});
    const double span = double(b[0] - a[0] + 1) * double(b[1] - a[1] + 1) * double(b[2] - a[2] + 1);
    if (span > double(vertices_.size())) {
      for (std::uint32_t v : vertices_) fn(v);
      return;
    }
    for (std::int64_t x = a[0]; x <= b[0]; ++x) {
      for (std::int64_t y = a[1]; y <= b[1]; ++y) {
        for (std::int64_t z = a[2]; z <= b[2]; ++z) {
          const std::uint64_t k = key({x, y, z});
          if (k != cursor.key) {
            cursor.key = k;
            cursor.range = find(k);
          }
          for (std::uint32_t i = cursor.range.first; i < cursor.range.second; ++i) fn(vertices_[i]);
        }
      }
    }
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no cell's key (those use 63 bits)

  std::size_t slot(std::uint64_t k) const { return (k * 0x9E3779B97F4A7C15ull >> 20) & (table_keys_.size() - 1); }
  // The range of vertices_ in cell k (empty when no chosen vertex is there).
  std::pair<std::uint32_t, std::uint32_t> find(std::uint64_t k) const {
    for (std::size_t i = slot(k);; i = (i + 1) & (table_keys_.size() - 1)) {
      if (table_keys_[i] == k) return {starts_[table_cells_[i]], starts_[table_cells_[i] + 1]};
      if (table_keys_[i] == kEmpty) return {0, 0};
    }
  }
  std::array<std::int64_t, 3> cell_of(const Vec3d& p) const {
    // Clamped to ±2^20 cells from the chosen vertices' corner: beyond that the box spans all.
    auto c = [&](double value, double origin) {
      return std::int64_t(std::clamp(std::floor((value - origin) / cell_), -1048576.0, 1048576.0));
    };
    return {c(p.x, lo_.x), c(p.y, lo_.y), c(p.z, lo_.z)};
  }
  std::array<std::int64_t, 3> cell_of(const Vec3f& p) const { return cell_of(Vec3d{p.x, p.y, p.z}); }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    return (std::uint64_t(c[0] + 1048576) << 42) | (std::uint64_t(c[1] + 1048576) << 21) | std::uint64_t(c[2] + 1048576);
  }

  double cell_;
  Vec3d lo_;
  std::vector<std::uint32_t> vertices_;    // the chosen vertices, cell after cell
  std::vector<std::uint32_t> starts_;      // each occupied cell's first entry in vertices_, then the end
  std::vector<std::uint64_t> table_keys_;  // open addressing: a cell's key, or kEmpty
  std::vector<std::uint32_t> table_cells_;  // its index in starts_
};

Vec3f normalised(double x, double y, double z) {
  const double length = std::sqrt(x * x + y * y + z * z);
  if (!(length > 0)) return {0, 0, 1};
  return {float(x / length), float(y / length), float(z / length)};
}

// Calls fn(v, d) for every vertex v of `grid` within `radius` of the triangle with corners `at`,
// d its squared distance. The box's distance first: most vertices of a cell are far from a
// triangle much smaller than the cell.
template <class Fn>
void within(const VertexGrid& grid, const std::vector<Vec3f>& positions, const std::array<Vec3d, 3>& at, double radius,
            VertexGrid::Cursor& cursor, Fn&& fn) {
  const Vec3d &a = at[0], &b = at[1], &c = at[2];
  const Vec3d lo{std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}), std::min({a.z, b.z, c.z})};
  const Vec3d hi{std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y}), std::max({a.z, b.z, c.z})};
  grid.near(lo, hi, radius, cursor, [&](std::uint32_t v) {
    const Vec3d p = to_d(positions[v]);
    const double bx = std::max({lo.x - p.x, p.x - hi.x, 0.0});
    const double by = std::max({lo.y - p.y, p.y - hi.y, 0.0});
    const double bz = std::max({lo.z - p.z, p.z - hi.z, 0.0});
    if (bx * bx + by * by + bz * bz > radius * radius) return;
    const double d = point_triangle_distance_squared(p, a, b, c);
    if (d <= radius * radius) fn(v, d);
  });
}

// Output vertices' cell size: about two output vertices per occupied cell, from the output's area.
double grid_cell(const std::vector<Vec3f>& positions, double area) { return search_cell(positions.size(), area); }

// Vertices left open after a round that the next round searches at any distance: each element
// of the input then tests each of them, which costs less than another pass per doubling.
constexpr std::size_t kFewOpen = 8;

// Rounds of a search from the output's vertices, each over the whole input with a search radius:
// round(grid, radius) visits the input against a grid of the vertices still open, and a vertex
// for which found(v) holds after a round is done. The first radius is a quarter of a grid cell
// (of about the output's vertex spacing): the input's elements then mostly meet one cell, and
// the output's distance to the input rarely passes it; each further round doubles it, or, when
// at most kFewOpen vertices are left, is infinite (the last round). A vertex's answer, its
// nearest element, does not depend on the radius that found it. With `left`, only the first
// round runs, and the vertices it left open go there.
template <class Round, class Found>
format::Status search_rounds(const std::vector<Vec3f>& positions, double area, Round&& round, Found&& found,
                             std::vector<std::uint32_t>* left = nullptr) {
  const double cell = grid_cell(positions, area);
  std::vector<std::uint32_t> open(positions.size());
  for (std::size_t v = 0; v < open.size(); ++v) open[v] = std::uint32_t(v);
  for (double radius = cell / 4; !open.empty() && std::isfinite(radius); radius *= 2) {
    const bool last = radius > cell / 4 && open.size() <= kFewOpen;
    if (last) radius = std::numeric_limits<double>::infinity();
    VertexGrid grid(positions, std::move(open), cell);
    GM_RETURN_IF_ERROR(round(grid, radius));
    open = grid.release_vertices();
    std::erase_if(open, found);
    if (left) break;
  }
  if (left) *left = std::move(open);
  return {};
}

// Writes the values found for each output vertex (normals already unit length) into its arrays:
// the kinds the input has, normals by `normals`.
void assign(const std::vector<format::VertexAttributes>& values, const format::AttributeKinds& kinds, NormalsMode normals,
            Mesh& output) {
  const bool take_normals = normals == NormalsMode::kKeep && kinds.normals;
  output.normals.clear();
  output.colors.clear();
  output.texcoords.clear();
  for (const format::VertexAttributes& a : values) {
    if (take_normals) output.normals.push_back(a.normal);
    if (kinds.colors) output.colors.push_back(a.color);
    if (kinds.texcoords) output.texcoords.push_back(a.texcoord);
  }
  if (normals == NormalsMode::kCompute) output.normals = vertex_normals(output.view());
}

// Barycentric weights of q, a point of triangle (a, b, c), by the sub-triangles' areas along
// the triangle's normal; a degenerate triangle gives its nearest corner all the weight.
std::array<double, 3> barycentric(const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d n = cross(b - a, c - a);
  const double area = dot(n, n);
  if (!(area > 0)) {
    const double d[3] = {dot(q - a, q - a), dot(q - b, q - b), dot(q - c, q - c)};
    const int k = d[0] <= d[1] && d[0] <= d[2] ? 0 : d[1] <= d[2] ? 1 : 2;
    std::array<double, 3> w{0, 0, 0};
    w[k] = 1;
    return w;
  }
  double wa = std::max(0.0, dot(cross(b - q, c - q), n) / area);
  double wb = std::max(0.0, dot(cross(c - q, a - q), n) / area);
  double wc = std::max(0.0, dot(cross(a - q, b - q), n) / area);
  const double sum = wa + wb + wc;
  return {wa / sum, wb / sum, wc / sum};
}

// The values at p's nearest point of the triangle with corners `at` and corner values `corner`:
// barycentric weights, the corners' values weighted in double, rounded once; normals
// renormalised. The kinds say which to take.
format::VertexAttributes interpolate(const std::array<Vec3f, 3>& at, const format::VertexAttributes* corner,
                                     const Vec3f& p, const format::AttributeKinds& kinds) {
  const Vec3d a = to_d(at[0]), b = to_d(at[1]), c = to_d(at[2]);
  Vec3d q;
  point_triangle_distance_squared(to_d(p), a, b, c, &q);
  const std::array<double, 3> w = barycentric(q, a, b, c);
  double sum[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    if (kinds.normals) {
      const Vec3f& m = corner[k].normal;
      sum[0] += w[k] * m.x, sum[1] += w[k] * m.y, sum[2] += w[k] * m.z;
    }
    if (kinds.colors) {
      const Color& m = corner[k].color;
      sum[3] += w[k] * m.r, sum[4] += w[k] * m.g, sum[5] += w[k] * m.b, sum[6] += w[k] * m.a;
    }
    if (kinds.texcoords) sum[7] += w[k] * corner[k].texcoord.u, sum[8] += w[k] * corner[k].texcoord.v;
  }
  return {normalised(sum[0], sum[1], sum[2]), {float(sum[3]), float(sum[4]), float(sum[5]), float(sum[6])},
          {float(sum[7]), float(sum[8])}};
}

// Each output vertex's nearest input triangle. A round takes only triangles within its radius of
// a vertex: a vertex that found one has its nearest (a nearer triangle is within the radius too,
// and its box grown by the radius holds the vertex).
std::vector<std::uint64_t> nearest_triangles(format::MeshView input, const Mesh& output) {
  const std::vector<Vec3f>& positions = output.positions;
  std::vector<std::atomic<std::uint64_t>> best(positions.size());
  for (auto& b : best) b.store(kNone, std::memory_order_relaxed);
  auto round = [&](const VertexGrid& grid, double radius) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, input.triangles.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        VertexGrid::Cursor cursor;
                        for (std::size_t f = range.begin(); f < range.end(); ++f) {
                          const Triangle& t = input.triangles[f];
                          within(grid, positions, {to_d(input.positions[t.v[0]]), to_d(input.positions[t.v[1]]),
                                                   to_d(input.positions[t.v[2]])},
                                 radius, cursor, [&](std::uint32_t v, double d) { lower(best[v], pack(d, f)); });
                        }
                      });
    return format::Status();
  };
  (void)search_rounds(positions, surface_area(output.positions, output.triangles), round,
                      [&](std::uint32_t v) { return best[v].load(std::memory_order_relaxed) != kNone; });
  std::vector<std::uint64_t> out(positions.size());
  for (std::size_t v = 0; v < out.size(); ++v) out[v] = best[v].load(std::memory_order_relaxed);
  return out;
}

}  // namespace

std::vector<Vec3f> vertex_normals(format::MeshView mesh) {
  std::vector<double> sum(3 * mesh.positions.size(), 0.0);
  for (const Triangle& t : mesh.triangles) {
    const Vec3d n = cross(to_d(mesh.positions[t.v[1]]) - to_d(mesh.positions[t.v[0]]),
                          to_d(mesh.positions[t.v[2]]) - to_d(mesh.positions[t.v[0]]));  // twice the area
    for (format::VertexIndex v : t.v) {
      sum[3 * v] += n.x;
      sum[3 * v + 1] += n.y;
      sum[3 * v + 2] += n.z;
    }
  }
  std::vector<Vec3f> normals(mesh.positions.size());
  for (std::size_t v = 0; v < normals.size(); ++v) normals[v] = normalised(sum[3 * v], sum[3 * v + 1], sum[3 * v + 2]);
  return normals;
}

double surface_area(const std::vector<Vec3f>& positions, std::span<const Triangle> triangles) {
  double area = 0;
  for (const Triangle& t : triangles) {
    const Vec3d a = to_d(positions[t.v[0]]);
    const Vec3d e = cross(to_d(positions[t.v[1]]) - a, to_d(positions[t.v[2]]) - a);
    area += 0.5 * std::sqrt(dot(e, e));
  }
  return area;
}

void add_face_normals(const std::vector<Vec3f>& positions, std::span<const Triangle> faces,
                      std::vector<format::VertexAttributes>& values) {
  for (const Triangle& t : faces) {
    const Vec3d n = cross(to_d(positions[t.v[1]]) - to_d(positions[t.v[0]]), to_d(positions[t.v[2]]) - to_d(positions[t.v[0]]));
    for (format::VertexIndex v : t.v) {
      Vec3f& sum = values[v].normal;
      sum = {sum.x + float(n.x), sum.y + float(n.y), sum.z + float(n.z)};
    }
  }
}

void normalise_normals(std::vector<format::VertexAttributes>& values) {
  for (format::VertexAttributes& a : values) a.normal = normalised(a.normal.x, a.normal.y, a.normal.z);
}

format::Result<std::vector<format::VertexAttributes>> nearest_vertex_values(const VertexPassFn& pass,
                                                                            const std::vector<Vec3f>& positions, double area,
                                                                            std::vector<std::uint32_t>* left) {
  std::vector<format::VertexAttributes> values(positions.size());
  std::vector<double> best(positions.size(), std::numeric_limits<double>::infinity());
  auto round = [&](const VertexGrid& grid, double radius) {
    VertexGrid::Cursor cursor;
    // Input order, strictly nearer only: the first among equally near input vertices wins.
    return pass([&](std::span<const Vec3f> points, std::span<const format::VertexAttributes> attributes) {
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Vec3d q = to_d(points[i]);
        grid.near(q, q, radius, cursor, [&](std::uint32_t v) {
          const Vec3d d = to_d(positions[v]) - q;
          const double d2 = dot(d, d);
          if (d2 <= radius * radius && d2 < best[v]) best[v] = d2, values[v] = attributes[i];
        });
      }
      return format::Status();
    });
  };
  GM_RETURN_IF_ERROR(search_rounds(positions, area, round, [&](std::uint32_t v) { return std::isfinite(best[v]); }, left));
  for (format::VertexAttributes& a : values) a.normal = normalised(a.normal.x, a.normal.y, a.normal.z);
  return values;
}

format::Status transfer_nearest_vertex(const VertexPassFn& pass, const format::AttributeKinds& kinds, Mesh& output,
                                       NormalsMode normals) {
  std::vector<format::VertexAttributes> values(output.positions.size());
  if (kinds.any()) {
    auto found = nearest_vertex_values(pass, output.positions, surface_area(output.positions, output.triangles));
    if (!found) return found.status();
    values = std::move(*found);
  }
  assign(values, kinds, normals, output);
  return {};
}

format::VertexAttributes values_at(format::MeshView input, const Triangle& t, const Vec3f& p,
                                   const format::AttributeKinds& kinds) {
  std::array<format::VertexAttributes, 3> corner;
  for (int k = 0; k < 3; ++k) {
    if (kinds.normals) corner[k].normal = input.normals[t.v[k]];
    if (kinds.colors) corner[k].color = input.colors[t.v[k]];
    if (kinds.texcoords) corner[k].texcoord = input.texcoords[t.v[k]];
  }
  return interpolate({input.positions[t.v[0]], input.positions[t.v[1]], input.positions[t.v[2]]}, corner.data(), p, kinds);
}

void assign_attributes(const std::vector<format::VertexAttributes>& values, const format::AttributeKinds& kinds,
                       NormalsMode normals, Mesh& output) {
  assign(values, kinds, normals, output);
}

void transfer_attributes(format::MeshView input, Mesh& output, NormalsMode normals) {
  const bool surface = !input.triangles.empty();
  const format::AttributeKinds kinds{surface && !input.normals.empty(), surface && !input.colors.empty(),
                                     surface && !input.texcoords.empty()};
  std::vector<format::VertexAttributes> values(output.positions.size());
  if (kinds.any()) {
    const std::vector<std::uint64_t> nearest = nearest_triangles(input, output);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, values.size(), 1024), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t v = range.begin(); v < range.end(); ++v)
        values[v] = values_at(input, input.triangles[static_cast<std::uint32_t>(nearest[v])], output.positions[v], kinds);
    });
  }
  assign(values, kinds, normals, output);
}

namespace {

// A position as a lookup key: canonical_order.h's bits of its coordinates (-0 as +0, as a weld
// takes them).
using PlaceKey = std::array<std::uint32_t, 3>;
PlaceKey place_key(const Vec3f& p) { return {ordered_bits(p.x), ordered_bits(p.y), ordered_bits(p.z)}; }

// The output's triangle corners by position: each distinct position once, with the corner slots
// (3 v + k) at it, and whether an input vertex has given them values yet.
class CornerLookup {
 public:
  explicit CornerLookup(const std::vector<std::array<Vec3f, 3>>& corners, const std::vector<std::uint8_t>& has) {
    for (std::uint32_t v = 0; v < corners.size(); ++v)
      if (has[v])
        for (std::uint32_t k = 0; k < 3; ++k) entries_.push_back({place_key(corners[v][k]), 3 * v + k});
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) {
      return a.key != b.key ? a.key < b.key : a.slot < b.slot;
    });
    for (std::uint32_t i = 0; i < entries_.size(); ++i)
      if (i == 0 || entries_[i].key != entries_[i - 1].key) starts_.push_back(i);
    starts_.push_back(std::uint32_t(entries_.size()));
    filled_.assign(starts_.size() - 1, 0);
    std::size_t size = 16;
    while (size < 2 * filled_.size()) size *= 2;
    table_.assign(size, kEmpty);
    for (std::uint32_t r = 0; r + 1 < starts_.size(); ++r) {
      const std::uint32_t slot = entries_[starts_[r]].slot;
      std::size_t i = position_hash(corners[slot / 3][slot % 3]) & (size - 1);
      while (table_[i] != kEmpty) i = (i + 1) & (size - 1);
      table_[i] = r;
    }
  }

  // The slots at p that no input vertex has given values yet (each position's first vertex in
  // input order gives them); marks them given.
  template <class Fn>
  void take(const Vec3f& p, Fn&& fn) {
    const PlaceKey key = place_key(p);
    for (std::size_t i = position_hash(p) & (table_.size() - 1); table_[i] != kEmpty; i = (i + 1) & (table_.size() - 1)) {
      const std::uint32_t r = table_[i];
      if (entries_[starts_[r]].key != key) continue;
      if (filled_[r]) return;
      filled_[r] = 1;
      for (std::uint32_t e = starts_[r]; e < starts_[r + 1]; ++e) fn(entries_[e].slot);
      return;
    }
  }
  bool all_given() const { return std::find(filled_.begin(), filled_.end(), 0) == filled_.end(); }

 private:
  struct Entry {
    PlaceKey key;
    std::uint32_t slot;
  };
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  std::vector<Entry> entries_;
  std::vector<std::uint32_t> starts_;  // first entry of each distinct position, then the end
  std::vector<std::uint8_t> filled_;   // per distinct position
  std::vector<std::uint32_t> table_;   // open addressing: distinct position index, or kEmpty
};

}  // namespace

format::Result<std::vector<format::VertexAttributes>> surface_values(const TrianglePassFn& triangles,
                                                                     const VertexPassFn& vertices,
                                                                     const format::AttributeKinds& kinds,
                                                                     const std::vector<Vec3f>& positions, double area) {
  const std::size_t n = positions.size();
  if (n == 0 || !kinds.any()) return std::vector<format::VertexAttributes>(n);
  // Each vertex's nearest triangle so far (as transfer_attributes' words) and that triangle's
  // corners, written together under one of the stripes' locks.
  std::vector<std::atomic<std::uint64_t>> best(n);
  for (auto& b : best) b.store(kNone, std::memory_order_relaxed);
  std::vector<std::array<Vec3f, 3>> corners(n);
  std::array<std::mutex, 64> stripes;
  std::atomic<bool> any_triangle{false};
  auto round = [&](const VertexGrid& grid, double radius) {
    return triangles([&](std::span<const IndexedTriangle> batch) {
      if (!batch.empty()) any_triangle.store(true, std::memory_order_relaxed);
      VertexGrid::Cursor cursor;
      for (const IndexedTriangle& t : batch) {
        const std::array<Vec3d, 3> at{to_d(t.corners[0]), to_d(t.corners[1]), to_d(t.corners[2])};
        within(grid, positions, at, radius, cursor, [&](std::uint32_t v, double d) {
          const std::uint64_t word = pack(d, t.index);
          if (word >= best[v].load(std::memory_order_relaxed)) return;
          std::lock_guard<std::mutex> lock(stripes[v % stripes.size()]);
          if (word >= best[v].load(std::memory_order_relaxed)) return;
          best[v].store(word, std::memory_order_relaxed);
          corners[v] = t.corners;
        });
      }
      return format::Status();
    });
  };
  // A pass without triangles would never find one: the rounds stop after the first.
  GM_RETURN_IF_ERROR(search_rounds(positions, area, round, [&](std::uint32_t v) {
    return best[v].load(std::memory_order_relaxed) != kNone || !any_triangle.load(std::memory_order_relaxed);
  }));
  std::vector<std::uint8_t> has(n);
  for (std::size_t v = 0; v < n; ++v) has[v] = best[v].load(std::memory_order_relaxed) != kNone;
  std::vector<std::atomic<std::uint64_t>>().swap(best);

  // The corners' values: one pass over the input's vertices.
  std::vector<format::VertexAttributes> corner_values(3 * n);
  {
    CornerLookup lookup(corners, has);
    GM_RETURN_IF_ERROR(vertices([&](std::span<const Vec3f> points, std::span<const format::VertexAttributes> attributes) {
      for (std::size_t i = 0; i < points.size(); ++i)
        lookup.take(points[i], [&](std::uint32_t slot) { corner_values[slot] = attributes[i]; });
      return format::Status();
    }));
    if (!lookup.all_given())
      return format::Status::error(format::Code::kProcessing, "attributes",
                                   "a corner of an input triangle matches no input vertex's position");
  }
  std::vector<format::VertexAttributes> values(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t v = range.begin(); v < range.end(); ++v)
      values[v] = has[v] ? interpolate(corners[v], &corner_values[3 * v], positions[v], kinds)
                         : format::VertexAttributes{{0, 0, 1}, {}, {}};
  });
  return values;
}

double search_cell(std::uint64_t count, double area) {
  const double cell = std::sqrt(2 * area / double(std::max<std::uint64_t>(count, 1)));
  return cell > 0 && std::isfinite(cell) ? cell : 1;
}

}  // namespace gaussmesh::stream
