// The face and point counts of a Draco mesh, read from the start of its bitstream without
// decoding it: Draco has no streaming decoder, so the reader checks what a decode will need
// before it starts one (docs/formats.md, "Draco input").
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "format/status.h"

namespace gaussmesh::format {

enum class DracoMethod : std::uint8_t { kSequential = 0, kEdgebreaker = 1 };

struct DracoCounts {
  std::uint64_t faces = 0;
  // Sequential: the points the file declares. Edgebreaker: the position vertices it encodes
  // (the decoded points of a mesh with positions only).
  std::uint64_t points = 0;
  DracoMethod method = DracoMethod::kSequential;
  std::uint8_t version_major = 0;
  std::uint8_t version_minor = 0;
};

// Reads the "DRACO" header (version, geometry type, method, flags), steps over the metadata
// when the flags announce it, and reads the counts at the start of the connectivity of either
// method, in every mesh bitstream version Draco 1.5 decodes (1.0 to 2.2). `bytes` is the file
// from its first byte, or its first `bytes.size()` bytes of `file_size` (0: `bytes` is the whole
// file); only the header is read, never more than it needs.
// Errors (kBadInput, "name: byte N"): the bytes end inside the header; not "DRACO"; a version
// outside 1.0..2.2; not a triangle mesh; an unknown method or edgebreaker traversal; a face
// count Draco refuses; metadata nested deeper than 64. Draco 1.5 refuses all of these too.
Result<DracoCounts> read_draco_counts(std::span<const char> bytes, const std::string& name,
                                      std::uint64_t file_size = 0);

}  // namespace gaussmesh::format
