// The --report JSON object: field names per DESIGN §5, written atomically.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "format/status.h"

namespace gaussmesh::cli {

using Json = nlohmann::ordered_json;

// Writes report to path ("-" = stdout) through OutputFile (temp + rename).
format::Status write_report(const std::string& path, const Json& report);

// The partition's seconds by step (out-of-core results: OutOfCoreSampling, OutOfCoreSimplify),
// the report's `partition_seconds`: they add up to `seconds.partition`.
template <class Result>
Json partition_seconds(const Result& r) {
  return {{"plan", r.seconds_plan}, {"rings", r.seconds_rings}, {"chunks", r.seconds_chunks}};
}

// Peak resident set size of this process so far (VmHWM), in bytes; 0 if unknown.
std::uint64_t peak_rss_bytes();

}  // namespace gaussmesh::cli
