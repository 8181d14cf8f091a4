// Helpers for tests that damage record files on purpose: read every record out, write them back.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "format/status.h"

namespace gaussmesh::testing {

// Every record of a record file (format/record_file.h), frame after frame.
format::Result<std::vector<std::byte>> read_all_records(const std::string& path, std::uint32_t kind,
                                                        std::uint32_t record_bytes);
// A new record file at path holding records (a whole number of record_bytes), default framing.
format::Status write_all_records(const std::string& path, std::uint32_t kind, std::uint32_t record_bytes,
                                 std::span<const std::byte> records);

}  // namespace gaussmesh::testing
