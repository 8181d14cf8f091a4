#pragma once
// OpenMesh, included with its own asserts off: every property access (mesh.point(v), status, a
// face's patch) asserts that the property's type name equals the handle's, a string compare that
// costs a large share of a mesher's time and checks nothing of ours. Our asserts stay on in
// release builds (CMakeLists.txt), so <cassert> is included again afterwards for the including
// file. Only stream/ .cpp files include this (docs/design.md: OpenMesh stays out of headers).
#ifndef NDEBUG
#define GAUSSMESH_RESTORE_ASSERT
#define NDEBUG
#endif
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#ifdef GAUSSMESH_RESTORE_ASSERT
#undef NDEBUG
#undef GAUSSMESH_RESTORE_ASSERT
#include <cassert>
#endif
