// The event interface every streaming reader drives: header, then batches of vertices and
// triangles. Readers never hold the whole mesh; a sink decides what to keep.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"

namespace gaussmesh::format {

// The per-vertex attributes an input carries, beside positions.
struct AttributeKinds {
  bool normals = false, colors = false, texcoords = false;
  bool any() const { return normals || colors || texcoords; }
  friend bool operator==(const AttributeKinds&, const AttributeKinds&) = default;
};

// One vertex's attributes as a reader delivers them; the fields its header does not announce
// hold their defaults.
struct VertexAttributes {
  Vec3f normal;
  Color color;
  Vec2f texcoord;
};

// Whether every value is a finite number (readers refuse a vertex with a NaN or an infinity).
inline bool is_finite(const Vec3f& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
inline bool is_finite(const VertexAttributes& a) {
  return is_finite(a.normal) && std::isfinite(a.color.r) && std::isfinite(a.color.g) && std::isfinite(a.color.b) &&
         std::isfinite(a.color.a) && std::isfinite(a.texcoord.u) && std::isfinite(a.texcoord.v);
}

struct MeshHeader {
  MeshFormat format = MeshFormat::kUnknown;
  // Counts as the file declares them (PLY, OFF, binary STL), or empty when the format has
  // none (OBJ, ascii STL). Untrusted: a sink must never size an allocation by them alone.
  std::optional<std::uint64_t> declared_vertices;
  std::optional<std::uint64_t> declared_faces;  // polygons, before fan triangulation
  // Where the delivered positions lie in the input, for a sink that would rather read them back
  // than keep a copy (the out-of-core partition): set when the input's vertices are fixed-size
  // records of little-endian float32 x, y, z at the start of its body (binary little-endian PLY
  // whose first element is the vertex element, on a little-endian machine). Vertex v's x, y, z
  // are the four bytes at first_byte + v * stride + xyz[axis], bit for bit the values the reader
  // delivers, for v below declared_vertices. Only meaningful when the input is a file the sink
  // can open again by its name (not standard input).
  struct RawVertices {
    std::uint64_t first_byte = 0;
    std::uint32_t stride = 0;
    std::uint32_t xyz[3] = {0, 0, 0};
  };
  std::optional<RawVertices> raw_vertices;
  // The attributes the reader delivers (on_vertex_attributes).
  AttributeKinds attributes;
};

// Contract a reader keeps:
//  - on_header once, first; on_end once, last, only after the input was read completely;
//  - vertices are numbered in delivery order from 0 across batches;
//  - every triangle delivered refers only to vertices already delivered;
//  - polygons are fan-triangulated (v0 v1 v2, v0 v2 v3, ...); triangles may be degenerate
//    (repeated index, zero area): the reader passes them on unchanged;
//  - when header.attributes.any(), each on_vertices is preceded by one on_vertex_attributes
//    with the same number of values, one per vertex of that batch;
//  - a batch's span is valid only during the call.
// A sink returning an error stops the reader, which returns that error.
class MeshSink {
 public:
  virtual ~MeshSink() = default;
  virtual Status on_header(const MeshHeader& /*header*/) { return {}; }
  // A per-vertex value the input has and the reader does not deliver (a PLY property "quality",
  // OBJ texture coordinates), named once, at any time between on_header and on_end.
  virtual Status on_ignored(const std::string& /*what*/) { return {}; }
  // Something the reader skipped because the input reads the same without it (a PLY header line
  // with no keyword, such as Blender 2.4's "Created by …"): one sentence naming where and what,
  // at most once per kind of thing.
  virtual Status on_warning(const std::string& /*message*/) { return {}; }
  virtual Status on_vertex_attributes(std::span<const VertexAttributes> /*batch*/) { return {}; }
  virtual Status on_vertices(std::span<const Vec3f> batch) = 0;
  virtual Status on_triangles(std::span<const Triangle> batch) = 0;
  virtual Status on_end() { return {}; }
};

}  // namespace gaussmesh::format
