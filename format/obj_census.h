// A quick pass over an OBJ file before it is read: how many triangles its faces make and whether
// they give texture coordinates or normals per corner. Only the in-core reader keeps those
// (ReadOptions::corner_values), so the engine choice reads the file's lines once to know whether
// holding it in memory would keep them, and what holding it would cost.
#pragma once

#include <cstdint>

#include "format/byte_source.h"
#include "format/status.h"

namespace gaussmesh::format {

struct ObjCensus {
  std::uint64_t triangles = 0;  // each `f` of n ≥ 3 corners counts n − 2, as the reader fans it
  // The `v`, `vt` and `vn` statements: the lists a reader that holds the file keeps.
  std::uint64_t vertices = 0, texcoords = 0, normals = 0;
  bool corner_values = false;   // some `f` corner names a vt or a vn (v/vt, v//vn, v/vt/vn)
  bool complete = false;        // false: stopped once past the caller's `enough` triangles
};

// Counts the faces of the OBJ text in `source` from its cursor on, statements continued with a
// final '\' included. It checks nothing (the reader does): malformed statements are counted as
// they look, a lone '\' that continues a face costs no corner. Stops, incomplete, once more than
// `enough` triangles are counted. A read error is the source's.
Result<ObjCensus> census_obj(ByteSource& source, std::uint64_t enough);

// Whether any byte from the cursor on is a '/'. A file without one names no vt or vn in a corner,
// and this is many times faster to find than the census's count: a plain OBJ costs only this.
Result<bool> any_slash(ByteSource& source);

}  // namespace gaussmesh::format
