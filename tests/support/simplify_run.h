// One `gaussmesh simplify` run as the CLI tests make it: PLY output and a report in a scratch
// directory, the output's bytes and the parsed report handed back.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "tests/support/test_util.h"

namespace gaussmesh::testing {

struct SimplifyOutcome {
  int exit_code = 0;
  std::string bytes, err;  // bytes and report: only when exit_code is 0
  nlohmann::json report;
};

// `gaussmesh simplify IN -o DIR/out.ply --format ply FLAGS --report DIR/report.json`.
inline SimplifyOutcome run_simplify(const ScratchDir& dir, const std::string& in, const std::string& flags) {
  const auto quoted = [](const std::string& text) { return "'" + text + "'"; };
  const std::string out = dir.file("out.ply"), report = dir.file("report.json");
  const CommandResult run = run_command(quoted(gaussmesh_binary()) + " simplify " + quoted(in) + " -o " + quoted(out) +
                                        " --format ply " + flags + " --report " + quoted(report));
  SimplifyOutcome r;
  r.exit_code = run.exit_code;
  r.err = run.err;
  if (run.exit_code == 0) {
    r.bytes = read_file(out);
    r.report = nlohmann::json::parse(read_file(report));
  }
  return r;
}

}  // namespace gaussmesh::testing
