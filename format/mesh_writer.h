// Mesh output: PLY (binary little-endian or ascii, with extra per-vertex / per-face scalar
// properties), OBJ, and Draco. Writers take a whole MeshView: outputs are simplified meshes.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

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
Status write_ply(OutputFile& out, MeshView mesh, const PlyWriteOptions& options);
Status write_obj(OutputFile& out, MeshView mesh);

struct DracoWriteOptions {
  int quantization_bits = 14;  // --qp: Draco's default of 11 visibly collapses vertices
  int compression_level = 7;   // --cl 0..10
};
// Edgebreaker-encoded Draco mesh. (draco_writer.cpp)
Status write_draco(OutputFile& out, MeshView mesh, const DracoWriteOptions& options);

}  // namespace gaussmesh::format
