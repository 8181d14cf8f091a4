// Mesh output: PLY (binary little-endian or ascii, with extra per-vertex / per-face scalar
// properties), OBJ, and Draco. Writers take a whole MeshView: outputs are simplified meshes.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "format/mesh_sink.h"
#include "format/mesh_types.h"
#include "format/output_file.h"
#include "format/status.h"

namespace gaussmesh::format {

// One extra scalar property; values.size() must equal the element count (vertices or faces).
struct PlyAttribute {
  std::string name;  // e.g. "red", "segment", "input_vertex"
  std::variant<std::span<const std::uint8_t>, std::span<const std::int32_t>,
               std::span<const std::uint32_t>, std::span<const float>>
      values;
};

struct PlyWriteOptions {
  bool binary = true;  // binary_little_endian 1.0, else ascii 1.0
  bool write_faces = true;  // false: a point cloud (no face element)
  std::vector<std::string> comments;
  std::vector<PlyAttribute> vertex_attributes;
  std::vector<PlyAttribute> face_attributes;
};

// Precondition: every triangle index < mesh.positions.size(); attribute sizes match.
// Violations of the preconditions are reported as kProcessing errors, not asserted.
// The mesh's own attributes come first among the vertex properties: nx ny nz (float), red green
// blue [alpha] (uchar; alpha when a colour is not opaque), s t (float).
Status write_ply(OutputFile& out, MeshView mesh, const PlyWriteOptions& options);
// Normals as vn, texture coordinates as vt (faces then name them, v/vt/vn), colours as three
// floats after the position ("v x y z r g b", as MeshLab and Blender read them; no alpha).
Status write_obj(OutputFile& out, MeshView mesh);

// Shared by the writers: a colour channel as a byte (clamped to 0–1, rounded to the nearest of
// 0..255), whether any colour is not opaque, and the check that every attribute the mesh has
// holds one value per position (kProcessing otherwise).
std::uint8_t color_byte(float channel);
bool has_alpha(std::span<const Color> colors);
Status check_vertex_attributes(const OutputFile& out, MeshView mesh);

struct DracoWriteOptions {
  int quantization_bits = 14;  // --qp: Draco's default of 11 visibly collapses vertices
  int compression_level = 7;   // --cl 0..10
  int normal_bits = 10;        // --qn: Draco's default (draco_encoder -qn)
  int texcoord_bits = 12;      // --qt: Draco's default (draco_encoder -qt)
};
// Edgebreaker-encoded Draco mesh. (draco_writer.cpp)
Status write_draco(OutputFile& out, MeshView mesh, const DracoWriteOptions& options);
// The bytes write_draco writes, in memory (`out` names the output in messages).
Status encode_draco(const OutputFile& out, MeshView mesh, const DracoWriteOptions& options, std::vector<char>& bytes);

struct GltfWriteOptions {
  bool binary = true;  // .glb (one binary file); else .gltf (JSON, the buffer as a base64 data URI)
  DracoWriteOptions draco;
};
// glTF 2.0 with one triangle primitive compressed by KHR_draco_mesh_compression (required):
// POSITION, and NORMAL, COLOR_0, TEXCOORD_0 when the mesh has them. Texture coordinates are
// written with v flipped (1 - v): glTF's origin is the image's top-left corner, PLY's and OBJ's
// its bottom-left. Accessor counts and POSITION's min/max are those of the Draco data as a
// decoder gives it back. (gltf_writer.cpp)
Status write_gltf(OutputFile& out, MeshView mesh, const GltfWriteOptions& options);

// A mesh too large to hold, delivered in parts: its counts first, then its vertices in order,
// then its faces, each through a callback in batches (a batch is valid only during the call).
class MeshParts {
 public:
  virtual ~MeshParts() = default;
  virtual std::uint64_t vertex_count() const = 0;
  virtual std::uint64_t face_count() const = 0;
  virtual Status vertices(const std::function<Status(std::span<const Vec3f>)>& batch) = 0;
  virtual Status faces(const std::function<Status(std::span<const Triangle>)>& batch) = 0;
};

// Per-vertex values that stream instead of being held: read in vertex order, and from the first
// again after rewind() (a writer may read them more than once).
class VertexValuesReader {
 public:
  virtual ~VertexValuesReader() = default;
  virtual std::uint64_t count() const = 0;
  virtual Status rewind() = 0;
  // The next out.size() values; fewer left is an error.
  virtual Status read(std::span<VertexAttributes> out) = 0;
};

// Per-vertex attributes of a mesh written from parts, in vertex order: the fields `kinds` names,
// of one value per vertex, held whole in `values`, or, when `reader` is set, read from it as the
// vertices stream (an output too large to hold them).
struct PartsAttributes {
  AttributeKinds kinds;
  std::span<const VertexAttributes> values;
  VertexValuesReader* reader = nullptr;
};

// PLY (binary little-endian or ascii) and OBJ from parts, in memory that does not grow with the
// faces: positions and faces streamed, attributes (as write_ply and write_obj write them) from
// `attributes`. A part that delivers other counts than it declared, an index past the vertices,
// or attributes of another count than the vertices is kProcessing (and the caller does not commit
// the file). Draco encodes a whole mesh: it has no such writer. (mesh_parts_writer.cpp)
Status write_ply_parts(OutputFile& out, MeshParts& mesh, bool binary, const std::vector<std::string>& comments,
                       const PartsAttributes& attributes = {});
Status write_obj_parts(OutputFile& out, MeshParts& mesh, const PartsAttributes& attributes = {});

}  // namespace gaussmesh::format
