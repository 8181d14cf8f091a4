// The record-file decoder (format/record_file.h) driven to the end of a file, checked: every
// record is read twice, once decoded (next) and once passed over (skip), and each pass must end
// in an error value or at a clean end that holds the records the seek table claims. Shared by
// fuzz_record_reader and the regression test over fixtures/fuzz/.
#pragma once

#include <string>
#include <string_view>

namespace gaussmesh::fuzz {

// Reads the record file at path, expecting the kind and record size its own header names (so
// that arbitrary bytes get past the header check); a record size the writer could not have
// used (0, above kMaxRecordFrameBytes) is replaced by 1. Returns the first breach, or empty.
// `header` is the file's first bytes (at least 20 of them to name kind and size).
std::string check_record_file(const std::string& path, std::string_view header);

}  // namespace gaussmesh::fuzz
