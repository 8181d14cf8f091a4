// gaussmesh segment: spherical segmentation (paper §6) of a closed mesh, written as a PLY with a
// segment id and a colour per face, and the --report JSON (docs/cli.md).
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/sampling_options.h"

namespace gaussmesh::cli {
namespace {

struct SegmentCommandOptions {
  std::string input = "-";
  std::string output;
  std::uint32_t max_smooth = SegmentOptions{}.max_smooth;
  CommonFlags common;
  SamplingFlags sampling;
};

int run_segment(const SegmentCommandOptions& o) {
  apply_verbosity(o.common);
  SegmentOptions options;
  auto sampling = sampling_options(o.sampling, options.sampling);
  if (!sampling) return report_error(sampling.status());
  options.sampling = *sampling;
  options.max_smooth = o.max_smooth;
  auto stats = segment(Source::file(o.input), o.output, options);
  if (!stats) return report_error(stats.status());
  if (verbosity() >= 1 && !stats->note.empty()) std::fprintf(stderr, "gaussmesh: segment: note: %s\n", stats->note.c_str());
  if (verbosity() >= 2) std::fprintf(stderr, "gaussmesh: segment: %s\n", stats->summary.c_str());
  return finish(o.common, stats->report_json);
}

}  // namespace

void register_segment(CLI::App& app, Runner& run) {
  auto o = std::make_shared<SegmentCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "segment", "Spherical segmentation (paper §6): g+1 segments of a closed genus-g mesh, as a per-face coloured PLY");
  sub->add_option("input", o->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")->capture_default_str();
  sub->add_option("-o,--output", o->output, "Segmented mesh as a binary PLY ('-': stdout)")->required();
  sub->add_option("--max-smooth", o->max_smooth, "Cap on the normal smoothing iterations")->capture_default_str();
  add_common_flags(*sub, o->common, "Print counts on stderr");
  // --frequency defaults to 1 here; --smooth is where the smoothing search starts.
  add_sampling_options(*sub, o->sampling);
  sub->callback([&run, o] { run = [o] { return run_segment(*o); }; });
}

}  // namespace gaussmesh::cli
