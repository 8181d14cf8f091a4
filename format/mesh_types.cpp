// Names of mesh formats, for messages and reports.
#include "gaussmesh/mesh.h"

namespace gaussmesh {

const char* format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::kUnknown: return "unknown";
    case MeshFormat::kPly: return "ply";
    case MeshFormat::kOff: return "off";
    case MeshFormat::kObj: return "obj";
    case MeshFormat::kStl: return "stl";
    case MeshFormat::kDraco: return "draco";
  }
  return "unknown";
}

}  // namespace gaussmesh
