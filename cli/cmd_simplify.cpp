// gaussmesh simplify: the main job — mesh in (file or stdin), approximation out (Draco by
// default, PLY or OBJ; file or stdout), with an optional JSON report (docs/cli.md).
#include <cmath>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/memory_guard.h"
#include "cli/resource_options.h"
#include "cli/sampling_options.h"
#include "cli/stdin_spool.h"

namespace gaussmesh::cli {
namespace {

struct SimplifyArgs {
  std::string input = "-";
  std::string output;
  std::string input_format;
  std::string output_format;
  std::string mesher = "patch";
  std::uint64_t target_faces = 0;
  double ratio = 0;
  std::string max_error;  // a distance, or a percentage of the diagonal ("0.1%")
  bool measure = false;
  bool weld = false, no_weld = false;
  int qp = 14;
  int cl = 7;
  int qn = 10;
  int qt = 12;
  std::string normals = "keep";
  double color_weight = 0;
  CommonFlags common;
  SamplingFlags sampling;
  ResourceFlags resources;
};

// Given flags are checked here (a target of 0 is an error, not "no target"); the API checks the
// rest once the input is known (a target above its faces).
Result<TargetOptions> target_options(const SimplifyArgs& args, const std::function<bool(const char*)>& given) {
  TargetOptions t;
  if (given("--target-faces")) {
    if (args.target_faces == 0) return Status::error(Code::kUsage, "--target-faces", "must be at least 1");
    t.faces = args.target_faces;
  }
  if (given("--ratio")) {
    if (!(args.ratio > 0) || args.ratio > 1) {
      return Status::error(Code::kUsage, "--ratio", "must be above 0 and at most 1, got " + std::to_string(args.ratio));
    }
    t.ratio = args.ratio;
  }
  if (given("--max-error")) {
    std::string text = args.max_error;
    if (!text.empty() && text.back() == '%') {
      t.max_error_relative = true;
      text.pop_back();
    }
    char* end = nullptr;
    const double e = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !(e > 0) || !std::isfinite(e)) {
      return Status::error(Code::kUsage, "--max-error",
                           "expected a positive distance, or a percentage of the diagonal such as 0.1%, got '" +
                               args.max_error + "'");
    }
    t.max_error = e;
  }
  t.measure = args.measure;
  return t;
}

int run_simplify(const SimplifyArgs& args, const std::function<bool(const char*)>& sub_given) {
  apply_verbosity(args.common);
  auto output_format = parse_output_format(args.output_format);
  if (!output_format) {
    return report_error(Status::error(Code::kUsage, "--format",
                                      "unknown output format '" + args.output_format + "' (draco, ply, ply-ascii, obj, glb, gltf)"));
  }
  SimplifyOptions options;
  options.weld = args.weld ? Weld::kOn : args.no_weld ? Weld::kOff : Weld::kAuto;
  if (args.mesher == "patch") options.mesher = Mesher::kPatch;
  else if (args.mesher == "voronoi") options.mesher = Mesher::kVoronoi;
  else return report_error(Status::error(Code::kUsage, "--mesher", "expected patch or voronoi, got '" + args.mesher + "'"));
  auto sampling = sampling_options(args.sampling);
  if (!sampling) return report_error(sampling.status());
  options.sampling = *sampling;
  auto resources = resource_options(args.resources);
  if (!resources) return report_error(resources.status());
  options.resources = *resources;
  options.draco.quantization_bits = args.qp;
  options.draco.compression_level = args.cl;
  options.draco.normal_bits = args.qn;
  options.draco.texcoord_bits = args.qt;
  if (args.normals == "keep") options.normals = Normals::kKeep;
  else if (args.normals == "compute") options.normals = Normals::kCompute;
  else if (args.normals == "none") options.normals = Normals::kNone;
  else return report_error(Status::error(Code::kUsage, "--normals", "expected keep, compute or none, got '" + args.normals + "'"));
  if (!(args.color_weight >= 0) || !std::isfinite(args.color_weight)) {
    return report_error(Status::error(Code::kUsage, "--color-weight", "must be 0 or more, got " + std::to_string(args.color_weight)));
  }
  options.color_weight = args.color_weight;
  auto target = target_options(args, sub_given);
  if (!target) return report_error(target.status());
  options.target = *target;
  MeshFormat input_format = MeshFormat::kUnknown;
  if (!args.input_format.empty()) {
    input_format = parse_mesh_format(args.input_format);
    if (input_format == MeshFormat::kUnknown) {
      return report_error(Status::error(Code::kUsage, "--input-format", "unknown format '" + args.input_format + "'"));
    }
  }
  Progress progress;
  MemoryGuard guard(guarded_budget(options.resources));
  options.resources.progress = guard.noting_pass(progress.callback());
  const Sink sink = Sink::file(args.output, *output_format);
  // A pipe small enough for the size rule to hold in core is read as the file it carries.
  if (args.input == "-" && options.resources.engine == Engine::kAuto) {
    if (Status spooled = spool_standard_input(options.resources.tmp_dir, kInCoreMaxFileBytes); !spooled) {
      return report_error(spooled);
    }
  }
  auto stats = simplify(Source::file(args.input, input_format), sink, options);
  if (!stats) return report_error(stats.status());
  if (verbosity() >= 1) {
    for (const std::string& warning : stats->warnings) {
      std::fprintf(stderr, "gaussmesh: %s: warning: %s\n", args.input == "-" ? "<stdin>" : args.input.c_str(), warning.c_str());
    }
  }
  if (stats->stopped_by == "approximation") {
    std::fprintf(stderr,
                 "gaussmesh: %s: %llu faces, below the target of %llu: the Gauss approximation has no more "
                 "(--frequency auto stops at %u; a higher --frequency costs memory and time)\n",
                 args.input == "-" ? "<stdin>" : args.input.c_str(), static_cast<unsigned long long>(stats->output_faces),
                 static_cast<unsigned long long>(stats->target_faces), kMaxAutoFrequency);
  }
  if (stats->stopped_by == "topology") {
    std::fprintf(stderr,
                 "gaussmesh: %s: %llu faces, above the target of %llu: every further collapse would change the "
                 "topology or fold a face\n",
                 args.input == "-" ? "<stdin>" : args.input.c_str(), static_cast<unsigned long long>(stats->output_faces),
                 static_cast<unsigned long long>(stats->target_faces));
  }
  if (verbosity() >= 1) {
    std::string where = stats->out_of_core ? ", " + std::to_string(stats->chunks) + " chunks" : "";
    std::fprintf(stderr, "gaussmesh: %llu -> %llu faces, %llu samples, %llu bytes (%s)%s\n",
                 static_cast<unsigned long long>(stats->input_faces), static_cast<unsigned long long>(stats->output_faces),
                 static_cast<unsigned long long>(stats->samples), static_cast<unsigned long long>(stats->output_bytes),
                 output_format_name(sink.resolved_format()), where.c_str());
  }
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: %s, %.3f s, peak RSS %llu bytes\n", stats->out_of_core ? "out of core" : "in core",
                 stats->seconds, static_cast<unsigned long long>(stats->peak_rss_bytes));
  }
  return finish(args.common, stats->report_json);
}

}  // namespace

void register_simplify(CLI::App& app, Runner& run) {
  auto args = std::make_shared<SimplifyArgs>();
  CLI::App* sub = app.add_subcommand("simplify", "simplify a mesh into a Draco (or PLY/OBJ) approximation");
  sub->add_option("input", args->input, "input mesh, or - for stdin (default)");
  sub->add_option("-o,--output", args->output, "output file, or - for stdout")->required();
  sub->add_option("--format", args->output_format, "output format: draco (default), ply, ply-ascii, obj, glb, gltf (glTF 2.0 with Draco); else from -o's extension");
  sub->add_option("--input-format", args->input_format, "force the input format: ply, off, obj, stl");
  sub->add_option("--target-faces", args->target_faces, "at most N faces: the Gauss approximation collapsed with the input's quadrics");
  sub->add_option("--ratio", args->ratio, "at most this fraction of the input's faces, 0 < R <= 1");
  sub->add_option("--max-error", args->max_error,
                  "no collapse whose estimated error passes E (input units), or E% of the bounding-box diagonal");
  sub->add_flag("--measure", args->measure, "add the output's Hausdorff and RMS distance to the input to the report (in core)");
  auto* weld = sub->add_flag("--weld", args->weld, "join vertices at exactly the same position first (default: for a triangle soup)");
  sub->add_flag("--no-weld", args->no_weld, "never join vertices by position (STL is then welded by its reader, in memory that grows with the mesh)")->excludes(weld);
  sub->add_option("--mesher", args->mesher, "patch (default, topology-preserving) or voronoi");
  sub->add_option("--qp", args->qp, "Draco position quantization bits 1-24 (default 14; encoder cost doubles per bit)")->check(CLI::Range(1, 24));
  sub->add_option("--cl", args->cl, "Draco compression level 0-10 (default 7)")->check(CLI::Range(0, 10));
  sub->add_option("--qn", args->qn, "Draco normal quantization bits 1-30 (default 10)")->check(CLI::Range(1, 30));
  sub->add_option("--qt", args->qt, "Draco texture coordinate quantization bits 1-30 (default 12)")->check(CLI::Range(1, 30));
  sub->add_option("--normals", args->normals,
                  "output normals: keep (the input's, interpolated; default), compute (from the output's faces) or none");
  sub->add_option("--color-weight", args->color_weight,
                  "with a target, in core: how much moving a vertex across the input's colour ramps costs (0: colours "
                  "do not count, the default; 1: a full colour step across a face costs like moving that face's width "
                  "off the surface)");
  add_common_flags(*sub, args->common, "print timings on stderr");
  add_sampling_options(*sub, args->sampling);
  add_resource_options(*sub, args->resources);
  sub->callback([&run, args, sub] {
    auto given = [sub](const char* flag) { return sub->count(flag) > 0; };
    run = [args, given] { return run_simplify(*args, given); };
  });
}

}  // namespace gaussmesh::cli
