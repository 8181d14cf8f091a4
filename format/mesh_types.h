// Small value types shared by readers, writers and the engine: positions, triangles, views.
#pragma once

#include "gaussmesh/mesh.h"

namespace gaussmesh::format {

// The API's mesh types (include/gaussmesh/mesh.h), shared by readers, writers and the engine.
using gaussmesh::Color;
using gaussmesh::format_name;
using gaussmesh::kMaxVertices;
using gaussmesh::MeshFormat;
using gaussmesh::MeshView;
using gaussmesh::Triangle;
using gaussmesh::Vec2f;
using gaussmesh::Vec3f;
using gaussmesh::VertexIndex;

}  // namespace gaussmesh::format
