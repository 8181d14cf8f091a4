// Small value types shared by readers, writers and the engine: positions, triangles, views.
#pragma once

#include <cstdint>
#include <span>

namespace gaussmesh::format {

// Positions are stored as float: every format we read is converted on input (doubles are
// rounded), and Draco quantizes far below float precision on output.
struct Vec3f {
  float x = 0, y = 0, z = 0;
  friend bool operator==(const Vec3f&, const Vec3f&) = default;
};

// Vertex indices are 32-bit: a mesh may hold at most 2^32 - 1 vertices (readers refuse more
// with a clear error). Global ids in out-of-core records are 64-bit.
using VertexIndex = std::uint32_t;
inline constexpr std::uint64_t kMaxVertices = 0xFFFFFFFFull;

struct Triangle {
  VertexIndex v[3] = {0, 0, 0};
  friend bool operator==(const Triangle&, const Triangle&) = default;
};

// A non-owning view of an indexed triangle mesh.
struct MeshView {
  std::span<const Vec3f> positions;
  std::span<const Triangle> triangles;
};

enum class MeshFormat { kUnknown, kPly, kOff, kObj, kStl, kDraco };

const char* format_name(MeshFormat format);

}  // namespace gaussmesh::format
