// Error values that every layer returns upward; only cli/ prints them and picks the exit code.
#pragma once

#include "gaussmesh/status.h"

namespace gaussmesh::format {

// The API's error values (include/gaussmesh/status.h), used by every layer.
using gaussmesh::Code;
using gaussmesh::code_name;
using gaussmesh::Result;
using gaussmesh::Status;

}  // namespace gaussmesh::format

// Propagates a failed Status from an expression that yields one.
#define GM_RETURN_IF_ERROR(expr)                  \
  do {                                            \
    ::gaussmesh::format::Status gm_status_ = (expr); \
    if (!gm_status_.is_ok()) return gm_status_;   \
  } while (0)
