// gaussmesh compare: symmetric Hausdorff and RMS distance between two meshes, in % of A's
// bounding-box diagonal (docs/compare.md).
#include <memory>
#include <string>

#include "cli/commands.h"

namespace gaussmesh::cli {
namespace {

struct CompareArgs {
  std::string a, b, report;
  std::uint64_t samples = CompareOptions{}.samples;
  std::uint64_t seed = CompareOptions{}.seed;
  std::uint32_t threads = 0;
  bool quiet = false;
  bool verbose = false;
};

void print_summary(const CompareArgs& args, const Distance& d) {
  const auto name = [](const std::string& path) { return path == "-" ? std::string("<stdin>") : path; };
  std::printf("A          %s\n", name(args.a).c_str());
  std::printf("B          %s\n", name(args.b).c_str());
  std::printf("hausdorff  %.6g %% of A's diagonal (%.6g)\n", d.pct(d.hausdorff), d.hausdorff);
  std::printf("rms        %.6g %% (%.6g)\n", d.pct(d.rms), d.rms);
  const std::pair<const char*, const OneSidedDistance*> sides[] = {{"A -> B", &d.a_to_b}, {"B -> A", &d.b_to_a}};
  for (const auto& [label, side] : sides) {
    std::printf("%s     max %.6g %%  rms %.6g %%  mean %.6g %%  (%llu area + %llu vertex/edge samples)\n", label,
                d.pct(side->max), d.pct(side->rms), d.pct(side->mean),
                static_cast<unsigned long long>(side->area_samples), static_cast<unsigned long long>(side->feature_samples));
  }
}

int run_compare(const CompareArgs& args) {
  if (args.quiet) set_verbosity(0);
  if (args.verbose) set_verbosity(2);
  CompareOptions options;
  options.samples = args.samples;
  options.seed = args.seed;
  options.threads = args.threads;
  auto distance = compare(input_source(args.a), input_source(args.b), options);
  if (!distance) return report_error(distance.status());
  // With --report -, standard output carries the JSON only.
  if (args.report != "-") print_summary(args, *distance);
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: compare: %.3f s, peak RSS %llu bytes\n", distance->seconds,
                 static_cast<unsigned long long>(peak_rss_bytes()));
  }
  if (!args.report.empty()) {
    if (Status s = write_report(args.report, distance->report_json); !s) return report_error(s);
  }
  return 0;
}

}  // namespace

void register_compare(CLI::App& app, Runner& run) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Hausdorff and RMS distance between two meshes, in % of A's bounding-box diagonal");
  sub->add_option("A", args->a, "First mesh (the reference for %), '-' for stdin")->required();
  sub->add_option("B", args->b, "Second mesh, '-' for stdin")->required();
  sub->add_option("--report", args->report, "Write the figures as JSON to FILE ('-': stdout)");
  sub->add_option("--samples", args->samples,
                  "Area samples on A; B gets the same density (vertices and edge midpoints are sampled too)")
      ->capture_default_str();
  sub->add_option("--seed", args->seed, "Seed of the sample positions")->capture_default_str();
  sub->add_option("--threads", args->threads, "Worker threads (0: all cores)")->capture_default_str();
  sub->add_flag("-q,--quiet", args->quiet, "Print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", args->verbose, "Print timings on stderr");
  sub->callback([&run, args] { run = [args] { return run_compare(*args); }; });
}

}  // namespace gaussmesh::cli
