// gaussmesh compare: symmetric Hausdorff and RMS distance between two meshes, in % of A's
// bounding-box diagonal (docs/compare.md).
#include <memory>
#include <string>

#include "cli/commands.h"

namespace gaussmesh::cli {
namespace {

struct CompareArgs {
  std::string a, b;
  std::uint64_t samples = CompareOptions{}.samples;
  std::uint64_t seed = CompareOptions{}.seed;
  std::uint32_t threads = 0;
  CommonFlags common;
};

void print_summary(const CompareArgs& args, const Distance& d) {
  std::printf("A          %s\n", Source::file(args.a).name().c_str());
  std::printf("B          %s\n", Source::file(args.b).name().c_str());
  std::printf("hausdorff  %.6g %% of A's diagonal (%.6g)\n", d.pct(d.hausdorff), d.hausdorff);
  std::printf("rms        %.6g %% (%.6g)\n", d.pct(d.rms), d.rms);
  const std::pair<const char*, const OneSidedDistance*> sides[] = {{"A -> B", &d.a_to_b}, {"B -> A", &d.b_to_a}};
  for (const auto& [label, side] : sides) {
    std::printf("%s     max %.6g %% at (%.6g, %.6g, %.6g)  rms %.6g %%  mean %.6g %%  (%llu area + %llu vertex/edge samples)\n",
                label, d.pct(side->max), side->max_at[0], side->max_at[1], side->max_at[2], d.pct(side->rms),
                d.pct(side->mean), static_cast<unsigned long long>(side->area_samples),
                static_cast<unsigned long long>(side->feature_samples));
  }
  std::printf("facing away  A: %llu faces (%.3g %% of its area)  B: %llu faces (%.3g %% of its area)\n",
              static_cast<unsigned long long>(d.a_to_b.facing_away_faces), d.a_to_b.facing_away_area_pct,
              static_cast<unsigned long long>(d.b_to_a.facing_away_faces), d.b_to_a.facing_away_area_pct);
}

int run_compare(const CompareArgs& args) {
  apply_verbosity(args.common);
  CompareOptions options;
  options.samples = args.samples;
  options.seed = args.seed;
  options.threads = args.threads;
  auto distance = compare(Source::file(args.a), Source::file(args.b), options);
  if (!distance) return report_error(distance.status());
  // With --report -, standard output carries the JSON only.
  if (args.common.report != "-") print_summary(args, *distance);
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: compare: %.3f s, peak RSS %llu bytes\n", distance->seconds,
                 static_cast<unsigned long long>(peak_rss_bytes()));
  }
  return finish(args.common, distance->report_json);
}

}  // namespace

void register_compare(CLI::App& app, Runner& run) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Hausdorff and RMS distance between two meshes, in % of A's bounding-box diagonal");
  sub->add_option("A", args->a, "First mesh (the reference for %), '-' for stdin")->required();
  sub->add_option("B", args->b, "Second mesh, '-' for stdin")->required();
  sub->add_option("--samples", args->samples,
                  "Area samples on A; B gets the same density (vertices and edge midpoints are sampled too)")
      ->capture_default_str();
  sub->add_option("--seed", args->seed, "Seed of the sample positions")->capture_default_str();
  sub->add_option("--threads", args->threads, "Worker threads (0: all cores)")->capture_default_str();
  add_common_flags(*sub, args->common, "Print timings on stderr");
  sub->callback([&run, args] { run = [args] { return run_compare(*args); }; });
}

}  // namespace gaussmesh::cli
