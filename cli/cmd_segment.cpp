// gaussmesh segment: not written yet; the subcommand exists so that usage is stable.
#include "cli/commands.h"

namespace gaussmesh::cli {

void register_segment(CLI::App& app, Runner& run) {
  CLI::App* sub = app.add_subcommand("segment", "(not implemented yet)");
  sub->allow_extras();
  sub->callback([&run] {
    run = [] {
      return report_error(format::Status::error(format::Code::kUsage, "segment", "not implemented yet"));
    };
  });
}

}  // namespace gaussmesh::cli
