// STL input: telling ascii from binary STL without consuming input (used by format
// detection and by read_stl, declared in mesh_reader.h). Internal to format/.
#pragma once

#include <string_view>

#include "format/byte_source.h"

namespace gaussmesh::format {

enum class StlEncoding { kNotStl, kAscii, kBinary };

// Looks at the first bytes (and the size, when known) and says whether they start an ascii
// STL ("solid" then text with "facet"/"endsolid"), a binary STL (84 + 50 * count == size,
// or "solid" followed by binary bytes), or neither as far as can be told. A binary STL whose
// size is unknown and whose header does not start with "solid" is kNotStl here; callers
// decide on a fallback.
Result<StlEncoding> sniff_stl(ByteSource& source);

// True when the first bytes hold control characters no text mesh format has (NUL, ...).
bool looks_binary(std::string_view head);

}  // namespace gaussmesh::format
