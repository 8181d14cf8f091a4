// gaussmesh compare: symmetric Hausdorff and RMS distance between two meshes, in % of the
// first mesh's bounding-box diagonal (the measure is stream/analysis/mesh_distance; docs/compare.md).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <tbb/global_control.h>

#include "cli/commands.h"
#include "cli/report.h"
#include "stream/core/mesh.h"
#include "stream/analysis/mesh_distance.h"

namespace gaussmesh::cli {
namespace {

using format::Code;
using format::Status;

struct CompareOptions {
  std::string a, b;
  std::string report;
  std::size_t samples = stream::DistanceOptions{}.samples;
  std::uint64_t seed = stream::DistanceOptions{}.seed;
  std::size_t threads = 0;  // 0: all cores
  bool quiet = false;
  bool verbose = false;
};

std::string display_name(const std::string& path) { return path == "-" ? "<stdin>" : path; }

Json one_sided_json(const stream::OneSidedDistance& d, double diagonal) {
  Json j;
  j["max_pct"] = stream::MeshDistance::pct(d.max, diagonal);
  j["rms_pct"] = stream::MeshDistance::pct(d.rms, diagonal);
  j["mean_pct"] = stream::MeshDistance::pct(d.mean, diagonal);
  j["area_samples"] = d.area_samples;
  j["feature_samples"] = d.feature_samples;
  return j;
}

Json report_json(const CompareOptions& options, const stream::Mesh& a, const stream::Mesh& b,
                 const stream::MeshDistance& d, double read_s, double measure_s) {
  using stream::MeshDistance;
  Json j;
  j["a"] = display_name(options.a);
  j["b"] = display_name(options.b);
  j["a_vertices"] = a.positions.size();
  j["a_faces"] = a.triangles.size();
  j["b_vertices"] = b.positions.size();
  j["b_faces"] = b.triangles.size();
  j["diagonal"] = d.diagonal;
  j["hausdorff_pct"] = d.hausdorff_pct();
  j["rms_pct"] = d.rms_pct();
  j["hausdorff_a_to_b_pct"] = MeshDistance::pct(d.a_to_b.max, d.diagonal);
  j["hausdorff_b_to_a_pct"] = MeshDistance::pct(d.b_to_a.max, d.diagonal);
  j["rms_a_to_b_pct"] = MeshDistance::pct(d.a_to_b.rms, d.diagonal);
  j["rms_b_to_a_pct"] = MeshDistance::pct(d.b_to_a.rms, d.diagonal);
  j["hausdorff"] = d.hausdorff;
  j["rms"] = d.rms;
  j["samples_a"] = d.a_to_b.area_samples + d.a_to_b.feature_samples;
  j["samples_b"] = d.b_to_a.area_samples + d.b_to_a.feature_samples;
  j["a_to_b"] = one_sided_json(d.a_to_b, d.diagonal);
  j["b_to_a"] = one_sided_json(d.b_to_a, d.diagonal);
  j["seed"] = options.seed;
  j["samples_option"] = options.samples;
  j["peak_rss_bytes"] = peak_rss_bytes();
  j["seconds"] = {{"read", read_s}, {"measure", measure_s}};
  return j;
}

void print_summary(const CompareOptions& options, const stream::MeshDistance& d) {
  using stream::MeshDistance;
  std::printf("A          %s\n", display_name(options.a).c_str());
  std::printf("B          %s\n", display_name(options.b).c_str());
  std::printf("hausdorff  %.6g %% of A's diagonal (%.6g)\n", d.hausdorff_pct(), d.hausdorff);
  std::printf("rms        %.6g %% (%.6g)\n", d.rms_pct(), d.rms);
  const std::pair<const char*, const stream::OneSidedDistance*> sides[] = {
      {"A -> B", &d.a_to_b}, {"B -> A", &d.b_to_a}};
  for (const auto& [label, side] : sides) {
    std::printf("%s     max %.6g %%  rms %.6g %%  mean %.6g %%  (%zu area + %zu vertex/edge samples)\n",
                label, MeshDistance::pct(side->max, d.diagonal),
                MeshDistance::pct(side->rms, d.diagonal), MeshDistance::pct(side->mean, d.diagonal),
                side->area_samples, side->feature_samples);
  }
}

int run_compare(const CompareOptions& options) {
  if (options.quiet) set_verbosity(0);
  if (options.verbose) set_verbosity(2);
  if (options.a == "-" && options.b == "-") {
    return report_error(Status::error(Code::kUsage, "compare", "only one of A and B can be '-'"));
  }
  if ((options.a == "-" || options.b == "-") && ::isatty(0)) {
    return report_error(Status::error(Code::kUsage, "compare",
                                      "input '-' given, and standard input is a terminal"));
  }
  if (options.samples == 0) {
    return report_error(Status::error(Code::kUsage, "--samples", "must be at least 1"));
  }
  std::optional<tbb::global_control> thread_limit;
  if (options.threads > 0) {
    thread_limit.emplace(tbb::global_control::max_allowed_parallelism, options.threads);
  }
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto a = stream::load_mesh(options.a);  // errors name the file and place
  if (!a) return report_error(a.status());
  auto b = stream::load_mesh(options.b);
  if (!b) return report_error(b.status());
  const auto t1 = Clock::now();
  stream::DistanceOptions distance_options;
  distance_options.samples = options.samples;
  distance_options.seed = options.seed;
  auto distance = stream::mesh_distance(a->view(), b->view(), distance_options);
  if (!distance) {
    // The library names the mesh "A" or "B"; the user knows it by its file name.
    const Status& s = distance.status();
    const std::string& path = s.where() == "A" ? options.a : s.where() == "B" ? options.b : "";
    return report_error(path.empty() ? s
                                     : Status::error(s.code(), display_name(path), s.message()));
  }
  const auto t2 = Clock::now();
  const double read_s = std::chrono::duration<double>(t1 - t0).count();
  const double measure_s = std::chrono::duration<double>(t2 - t1).count();
  // With --report -, standard output carries the JSON only.
  if (options.report != "-") print_summary(options, *distance);
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: compare: read %.3f s, measure %.3f s, peak RSS %llu bytes\n",
                 read_s, measure_s, static_cast<unsigned long long>(peak_rss_bytes()));
  }
  if (!options.report.empty()) {
    Status written =
        write_report(options.report, report_json(options, *a, *b, *distance, read_s, measure_s));
    if (!written) return report_error(written);
  }
  return 0;
}

}  // namespace

void register_compare(CLI::App& app, Runner& run) {
  auto options = std::make_shared<CompareOptions>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Hausdorff and RMS distance between two meshes, in % of A's bounding-box diagonal");
  sub->add_option("A", options->a, "First mesh (the reference for %), '-' for stdin")->required();
  sub->add_option("B", options->b, "Second mesh, '-' for stdin")->required();
  sub->add_option("--report", options->report, "Write the figures as JSON to FILE ('-': stdout)");
  sub->add_option("--samples", options->samples,
                  "Area samples on A; B gets the same density (vertices and edge midpoints are "
                  "sampled too)")
      ->capture_default_str();
  sub->add_option("--seed", options->seed, "Seed of the sample positions")->capture_default_str();
  sub->add_option("--threads", options->threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  sub->add_flag("-q,--quiet", options->quiet, "Print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", options->verbose, "Print timings on stderr");
  sub->callback([&run, options] { run = [options] { return run_compare(*options); }; });
}

}  // namespace gaussmesh::cli
