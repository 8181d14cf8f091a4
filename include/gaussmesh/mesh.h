// The mesh types of the API: positions, triangles, a non-owning view and an owning mesh.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace gaussmesh {

// Positions are float: every format is converted on input (doubles are rounded), and Draco
// quantizes far below float precision on output.
struct Vec3f {
  float x = 0, y = 0, z = 0;
  friend bool operator==(const Vec3f&, const Vec3f&) = default;
};

// Vertex indices are 32-bit: a mesh holds at most 2^32 - 1 vertices (readers refuse more).
using VertexIndex = std::uint32_t;
inline constexpr std::uint64_t kMaxVertices = 0xFFFFFFFFull;

struct Triangle {
  VertexIndex v[3] = {0, 0, 0};
  friend bool operator==(const Triangle&, const Triangle&) = default;
};

// A texture coordinate.
struct Vec2f {
  float u = 0, v = 0;
  friend bool operator==(const Vec2f&, const Vec2f&) = default;
};

// A colour, each channel a float from 0 to 1 (an 8-bit channel c is c / 255); a = 1 is opaque.
struct Color {
  float r = 0, g = 0, b = 0, a = 1;
  friend bool operator==(const Color&, const Color&) = default;
};

// A non-owning view of an indexed triangle mesh. Each per-vertex attribute is either empty or
// holds one value per position.
struct MeshView {
  std::span<const Vec3f> positions;
  std::span<const Triangle> triangles;
  std::span<const Vec3f> normals;
  std::span<const Color> colors;
  std::span<const Vec2f> texcoords;
};

// An indexed triangle mesh that owns its arrays; attributes as in MeshView.
struct Mesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  std::vector<Vec3f> normals;
  std::vector<Color> colors;
  std::vector<Vec2f> texcoords;
  MeshView view() const { return {positions, triangles, normals, colors, texcoords}; }
};

// Input file formats (detected from content unless forced).
enum class MeshFormat { kUnknown, kPly, kOff, kObj, kStl, kDraco };

const char* format_name(MeshFormat format);
// "ply", "off", "obj", "stl", "drc"/"draco" (any case) -> format; kUnknown for anything else.
MeshFormat parse_mesh_format(std::string_view name);

}  // namespace gaussmesh
