// Writing a result mesh to OUT or stdout in the format the user asked for (--format, or the
// extension; Draco when neither says), always through OutputFile's write-then-rename.
#pragma once

#include <string>

#include "format/mesh_writer.h"
#include "format/status.h"

namespace gaussmesh::cli {

enum class OutputKind { kDraco, kPlyBinary, kPlyAscii, kObj };

// --format values: "draco"/"drc", "ply", "ply-ascii", "obj"; empty: from the extension of
// path (.drc .ply .obj), Draco for "-" or an unknown extension. kUsage for an unknown name.
format::Result<OutputKind> choose_output_kind(const std::string& format_flag, const std::string& path);
const char* output_kind_name(OutputKind kind);

// Writes mesh to path ("-": stdout, binary refused on a terminal) and commits it; returns the
// number of bytes written.
format::Result<std::uint64_t> write_mesh_output(const std::string& path, OutputKind kind, format::MeshView mesh,
                                                const format::DracoWriteOptions& draco);

}  // namespace gaussmesh::cli
