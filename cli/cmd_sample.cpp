// gaussmesh sample: Gauss mesh sampling of one mesh (paper §4), samples as a point PLY, an
// optional patch-coloured mesh for MeshLab, and the --report JSON (docs/cli.md).
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/memory_guard.h"
#include "cli/resource_options.h"
#include "cli/sampling_options.h"

namespace gaussmesh::cli {
namespace {

struct SampleCommandOptions {
  std::string input = "-";
  std::string output;
  std::string patches;
  CommonFlags common;
  SamplingFlags sampling;
  ResourceFlags resources;
};

int run_sample(const SampleCommandOptions& o) {
  apply_verbosity(o.common);
  SampleOptions options;
  auto sampling = sampling_options(o.sampling);
  if (!sampling) return report_error(sampling.status());
  options.sampling = *sampling;
  auto resources = resource_options(o.resources);
  if (!resources) return report_error(resources.status());
  options.resources = *resources;
  options.patches_path = o.patches;
  Progress progress;
  MemoryGuard guard(guarded_budget(options.resources));
  options.resources.progress = guard.noting_pass(progress.callback());
  auto stats = sample(Source::file(o.input), o.output, options);
  if (!stats) return report_error(stats.status());
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: sample: %llu samples (%s, %llu chunks)\n",
                 static_cast<unsigned long long>(stats->samples), stats->out_of_core ? "out of core" : "in core",
                 static_cast<unsigned long long>(stats->chunks));
  }
  return finish(o.common, stats->report_json);
}

}  // namespace

void register_sample(CLI::App& app, Runner& run) {
  auto o = std::make_shared<SampleCommandOptions>();
  CLI::App* sub = app.add_subcommand("sample", "Gauss mesh sampling: samples as a point PLY (ids, Gaussian vertex, characteristic)");
  sub->add_option("input", o->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")->capture_default_str();
  sub->add_option("-o,--output", o->output, "Samples as a binary point PLY ('-': stdout)")->required();
  sub->add_option("--patches", o->patches, "Also write the input mesh coloured per patch, samples in red (PLY; in core)");
  add_common_flags(*sub, o->common, "Print counts on stderr");
  add_sampling_options(*sub, o->sampling);
  add_resource_options(*sub, o->resources);
  sub->callback([&run, o] { run = [o] { return run_sample(*o); }; });
}

}  // namespace gaussmesh::cli
