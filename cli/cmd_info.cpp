// gaussmesh info: counts, bounds, boundary loops, manifoldness and genus of a mesh.
#include "cli/commands.h"

namespace gaussmesh::cli {

void register_info(CLI::App& app, Runner& run) {
  CLI::App* sub = app.add_subcommand("info", "(not implemented yet)");
  sub->allow_extras();
  sub->callback([&run] {
    run = [] {
      return report_error(format::Status::error(format::Code::kUsage, "info", "not implemented yet"));
    };
  });
}

}  // namespace gaussmesh::cli
