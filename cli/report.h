// The --report JSON object: field names per DESIGN §5, written atomically.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "format/status.h"
#include "stream/partition/chunk_partition.h"

namespace gaussmesh::cli {

using Json = nlohmann::ordered_json;

// Writes report to path ("-" = stdout) through OutputFile (temp + rename).
format::Status write_report(const std::string& path, const Json& report);

// The report's `partition_seconds`: the partition's steps, adding up to `seconds.partition`.
inline Json partition_seconds(const stream::PartitionSteps& steps) {
  return {{"plan", steps.plan}, {"rings", steps.rings}, {"chunks", steps.chunks}};
}

// Peak resident set size of this process so far (VmHWM), in bytes; 0 if unknown.
std::uint64_t peak_rss_bytes();

}  // namespace gaussmesh::cli
