// Standard input that is a pipe, made to look like the file it carries when it is small: the
// engine is chosen by the input's size, which a pipe does not tell (docs/cli.md, "Memory budget").
#pragma once

#include <cstdint>
#include <string>

#include "gaussmesh/status.h"

namespace gaussmesh::cli {

// When standard input is a pipe (or a socket), copies its first bytes, up to `limit`, to an
// unnamed file in `tmp_dir` (empty: $TMPDIR, else /tmp). If the input ends within them, that file
// replaces fd 0: a regular file, so the job chooses, counts and reads it as it would the same
// file. Otherwise fd 0 becomes a new pipe that a thread fills with the copied bytes and then the
// rest of the input, so the job streams it as before. The file has no name from the start (or
// loses it at once), so nothing is left behind whatever ends the process. Memory: a 1 MiB buffer.
// Errors: kBadInput when <stdin> cannot be read, kOutput when the copy cannot be written.
Status spool_standard_input(const std::string& tmp_dir, std::uint64_t limit);

}  // namespace gaussmesh::cli
