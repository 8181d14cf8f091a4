// Streaming mesh input: format detection from content and dispatch to the per-format readers.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "format/byte_source.h"
#include "format/mesh_sink.h"

namespace gaussmesh::format {

struct ReadOptions {
  // kUnknown: detect from the content (works on stdin). Anything else forces that reader.
  MeshFormat format = MeshFormat::kUnknown;
  // Vertices / triangles per sink call.
  size_t batch_size = size_t{1} << 16;
  // STL: weld corners at equal positions in a hash table that grows with the mesh; false: each
  // corner is a vertex of its own, in fixed memory (a soup, for a caller that welds).
  bool weld_stl = true;
  // Bytes the reader may hold at once; 0: no limit. Only the readers whose memory grows with the
  // input use it: Draco (decoded whole) refuses an input that would pass it before holding it,
  // and the STL weld's table stops at half of it (kResources either way).
  std::uint64_t memory_limit = 0;
  // OBJ: read texture coordinates and normals given per face corner (f v/vt/vn). The reader then
  // holds the file's v, vt and vn lists and its faces, and at the end delivers one vertex per
  // distinct (v, vt, vn) triple its faces use: a position with several values (a seam) becomes
  // several vertices at the same place. Memory grows with the input (memory_limit applies), so
  // only a caller that holds the mesh anyway asks for it; without it vt and vn are named as not
  // kept and the file streams.
  bool corner_values = false;
};

// Looks at the first bytes (without consuming them) and names the format, or kUnknown.
// PLY: "ply" magic; OFF: "OFF"/"NOFF"/"COFF"/...; STL: binary size check or "solid" + "facet";
// OBJ: recognised statements. Draco: "DRACO" magic.
Result<MeshFormat> detect_format(ByteSource& source);

// "ply", "off", "obj", "stl", "drc"/"draco" (case-insensitive) -> format, or kUnknown.
MeshFormat parse_format_name(std::string_view name);
// Format named by a path's extension, or kUnknown.
MeshFormat format_from_extension(std::string_view path);

// Reads the whole input into sink, detecting the format unless options.format says.
// Errors name source.name() and the byte offset or line.
Status read_mesh(ByteSource& source, const ReadOptions& options, MeshSink& sink);
// Opens path ("-" for stdin) and reads it.
Status read_mesh_file(const std::string& path, const ReadOptions& options, MeshSink& sink);

// Per-format readers (ply_reader.cpp, off_reader.cpp, obj_reader.cpp, stl_reader.cpp,
// draco_reader.cpp).
Status read_ply(ByteSource& source, const ReadOptions& options, MeshSink& sink);
Status read_off(ByteSource& source, const ReadOptions& options, MeshSink& sink);
Status read_obj(ByteSource& source, const ReadOptions& options, MeshSink& sink);
Status read_stl(ByteSource& source, const ReadOptions& options, MeshSink& sink);
// Draco (draco_reader.cpp): decoded whole in memory — Draco has no streaming decoder — after
// a check, from the counts in its header, that the decode fits options.memory_limit.
Status read_draco(ByteSource& source, const ReadOptions& options, MeshSink& sink);

}  // namespace gaussmesh::format
