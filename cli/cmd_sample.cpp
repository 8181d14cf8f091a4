// gaussmesh sample: not written yet; the subcommand exists so that usage is stable.
#include "cli/commands.h"

namespace gaussmesh::cli {

void register_sample(CLI::App& app, Runner& run) {
  CLI::App* sub = app.add_subcommand("sample", "(not implemented yet)");
  sub->allow_extras();
  sub->callback([&run] {
    run = [] {
      return report_error(format::Status::error(format::Code::kUsage, "sample", "not implemented yet"));
    };
  });
}

}  // namespace gaussmesh::cli
