// gaussmesh simplify: the main job — mesh in (file or stdin), approximation out (Draco by
// default, PLY or OBJ; file or stdout), with an optional JSON report (DESIGN §5).
#include <chrono>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/output.h"
#include "cli/pipeline_options.h"
#include "cli/report.h"
#include "cli/sampling_options.h"
#include "format/mesh_reader.h"
#include "stream/pipeline/out_of_core_simplify.h"
#include "stream/core/mesh.h"
#include "stream/pipeline/in_core_simplify.h"

namespace gaussmesh::cli {
namespace {

struct SimplifyArgs {
  std::string input = "-";
  std::string output;
  std::string input_format;
  std::string output_format;
  std::string mesher = "patch";
  std::string report;
  int qp = 14;
  int cl = 7;
  bool quiet = false;
  bool verbose = false;
  SamplingOptions sampling;
  PipelineOptions pipeline;
};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The report fields in and out of core share (DESIGN §5); result is a stream::SimplifyResult or
// a stream::OutOfCoreSimplify.
Json simplify_report(const SimplifyArgs& args, OutputKind kind, std::uint64_t input_vertices, std::uint64_t input_faces,
                     const stream::GaussSphereOptions& sphere, const stream::SamplerOptions& sampler, const auto& result,
                     std::size_t chosen, std::uint64_t bytes) {
  Json report;
  report["command"] = "simplify";
  report["input"] = args.input;
  report["output"] = args.output;
  report["output_format"] = output_kind_name(kind);
  report["input_vertices"] = input_vertices;
  report["input_faces"] = input_faces;
  report["gauss_base"] = stream::gauss_base_name(sphere.base);
  report["gauss_frequency"] = sphere.frequency;
  report["gauss_vertices"] = result.gauss_vertices;
  report["gauss_triangles"] = result.gauss_triangles;
  report["rotation"] = result.rotation;
  report["orientations"] = result.samples_per_orientation.size();
  report["orientation_chosen"] = chosen;
  report["samples_per_orientation"] = result.samples_per_orientation;
  report["sample_test"] = stream::sample_test_name(sampler.sample_test);
  report["smooth"] = sampler.smooth_iterations;
  report["patches"] = result.patches;
  report["candidates"] = result.candidates;
  report["samples"] = result.samples;
  report["mesher_rounds"] = result.polygon.rounds;
  report["refined_patches"] = result.polygon.refined_patches;
  report["guards"] = result.polygon.guards;
  report["output_vertices"] = result.mesh.positions.size();
  report["output_faces"] = result.mesh.triangles.size();
  report["output_bytes"] = bytes;
  report["qp"] = args.qp;
  report["cl"] = args.cl;
  return report;
}

// --memory: the out-of-core pipeline (stream/pipeline/out_of_core_simplify.h); same output as in core.
int run_simplify_out_of_core(const SimplifyArgs& args, OutputKind kind, const std::vector<stream::GaussSphereOptions>& spheres,
                             const stream::SamplerOptions& sampler, const format::ReadOptions& read_options,
                             std::chrono::steady_clock::time_point started) {
  using format::Code;
  using format::Status;
  auto memory = parse_memory_size(args.pipeline.memory);
  if (!memory) return report_error(memory.status());
  if (args.mesher != "patch") {
    return report_error(Status::error(Code::kUsage, "simplify", "--memory runs the per-patch mesher only"));
  }
  stream::OutOfCoreSimplifyOptions options;
  options.memory = stream::MemoryBudget(*memory);
  options.partition.tmp_dir = args.pipeline.tmp;
  options.threads = pipeline_threads(args.pipeline);
  options.spheres = spheres;
  options.sampler = sampler;
  Progress progress;
  options.progress = [&](const char* pass, std::size_t done, std::size_t total, std::uint64_t faces) {
    progress.update(pass, done, total, faces);
  };
  options.partition.progress = [&](const char* pass, std::uint64_t done, std::uint64_t total) {
    progress.update(pass, done, total, total);
  };
  auto result = stream::simplify_out_of_core(args.input, read_options, options);
  if (!result) return report_error(result.status());
  if (result->faces == 0) {
    return report_error(Status::error(Code::kBadInput, args.input == "-" ? "<stdin>" : args.input,
                                      "no faces to simplify (" + std::to_string(result->vertices) + " vertices)"));
  }
  if (result->mesh.triangles.empty()) {
    return report_error(Status::error(Code::kProcessing, args.input == "-" ? "<stdin>" : args.input,
                                      "the approximation has no faces (too few samples: raise --frequency)"));
  }
  auto t = std::chrono::steady_clock::now();
  format::DracoWriteOptions draco;
  draco.quantization_bits = args.qp;
  draco.compression_level = args.cl;
  auto bytes = write_mesh_output(args.output, kind, result->mesh.view(), draco);
  if (!bytes) return report_error(bytes.status());
  const double seconds_write = seconds_since(t);
  if (verbosity() >= 1) {
    std::fprintf(stderr, "gaussmesh: %llu -> %zu faces, %zu samples, %llu bytes (%s), %zu chunks\n",
                 static_cast<unsigned long long>(result->faces), result->mesh.triangles.size(), result->samples,
                 static_cast<unsigned long long>(*bytes), output_kind_name(kind), result->chunks);
  }
  if (!args.report.empty()) {
    Json report = simplify_report(args, kind, result->vertices, result->faces, spheres[0], sampler, *result,
                                  result->chosen, *bytes);
    report["merged_patches"] = result->merged_patches;
    report["merge_rounds"] = result->merge_rounds;
    report["mesher"] = "patch";
    report["out_of_core"] = true;
    report["memory_bytes"] = *memory;
    report["threads"] = options.threads;
    report["chunks"] = result->chunks;
    report["bytes_spilled"] = result->bytes_spilled;
    report["stitch_half_edges"] = result->stitch_half_edges;
    report["stitch_runs"] = result->stitch_runs;
    report["stitch_vertices"] = result->stitch_vertices;
    report["fetched_patches"] = result->fetched_patches;
    report["fetched_faces"] = result->fetched_faces;
    report["fetched_chunks"] = result->fetched_chunks;
    report["loop_chunks"] = result->loop_chunks;
    report["loop_faces"] = result->loop_faces;
    if (sampler.sample_test == stream::SampleTest::kPaper) {
      report["candidate_pairs"] = result->candidate_pairs;
      report["chain_fragments"] = result->chain_fragments;
      report["paper_filters"] = {{"tree_filtered", result->tree_filtered},
                                       {"unwinding_filtered", result->unwinding_filtered},
                                       {"noisy_filtered", result->noisy_filtered}};
    }
    report["peak_rss_bytes"] = peak_rss_bytes();
    report["peak_rss_after_partition_bytes"] = result->peak_rss_after_partition;
    report["peak_rss_after_pieces_bytes"] = result->peak_rss_after_pieces;
    report["peak_rss_after_merge_bytes"] = result->peak_rss_after_merge;
    report["peak_rss_after_loops_bytes"] = result->peak_rss_after_loops;
    report["seconds"] = {{"ingest", result->seconds_ingest},
                         {"partition", result->seconds_partition},
                         {"sample", result->seconds_sample},
                         {"stitch", result->seconds_stitch},
                         {"mesh", result->seconds_mesh},
                         {"cleanup", result->seconds_cleanup},
                         {"write", seconds_write},
                         {"total", seconds_since(started)}};
    report["partition_seconds"] = partition_seconds(result->partition_steps);
    report["stitch_seconds"] = {{"pieces", result->stitch_steps.pieces},
                                {"merge", result->stitch_steps.merge},
                                {"chains", result->stitch_steps.chains},
                                {"loops", result->stitch_steps.loops},
                                {"loop_stitch", result->stitch_steps.loop_stitch}};
    auto status = write_report(args.report, report);
    if (!status.is_ok()) return report_error(status);
  }
  return 0;
}

int run_simplify(const SimplifyArgs& args) {
  using format::Code;
  using format::Status;
  auto started = std::chrono::steady_clock::now();
  if (args.quiet) set_verbosity(0);
  if (args.verbose) set_verbosity(2);
  auto kind = choose_output_kind(args.output_format, args.output);
  if (!kind) return report_error(kind.status());
  if (args.mesher != "patch" && args.mesher != "voronoi") {
    return report_error(Status::error(Code::kUsage, "--mesher", "expected patch or voronoi, got '" + args.mesher + "'"));
  }
  auto spheres = gauss_sphere_options(args.sampling);
  if (!spheres) return report_error(spheres.status());
  auto sampler = sampler_options(args.sampling);
  if (!sampler) return report_error(sampler.status());

  format::ReadOptions read_options;
  if (!args.input_format.empty()) {
    read_options.format = format::parse_format_name(args.input_format);
    if (read_options.format == format::MeshFormat::kUnknown) {
      return report_error(Status::error(Code::kUsage, "--input-format", "unknown format '" + args.input_format + "'"));
    }
  }
  if (!args.pipeline.memory.empty()) {
    return run_simplify_out_of_core(args, *kind, *spheres, *sampler, read_options, started);
  }
  auto t = std::chrono::steady_clock::now();
  auto mesh = stream::load_mesh(args.input, read_options);
  if (!mesh) return report_error(mesh.status());
  double seconds_read = seconds_since(t);
  if (mesh->triangles.empty()) {
    return report_error(Status::error(Code::kBadInput, args.input == "-" ? "<stdin>" : args.input,
                                      "no faces to simplify (" + std::to_string(mesh->positions.size()) + " vertices)"));
  }

  stream::SimplifyOptions options;
  options.spheres = *spheres;
  options.sampler = *sampler;
  options.mesher = args.mesher == "voronoi" ? stream::MesherKind::kVoronoi : stream::MesherKind::kPatch;
  auto result = stream::simplify_mesh(mesh->view(), options);
  if (!result) return report_error(result.status());
  if (result->mesh.triangles.empty()) {
    return report_error(Status::error(Code::kProcessing, args.input == "-" ? "<stdin>" : args.input,
                                      "the approximation has no faces (too few samples: raise --frequency)"));
  }

  t = std::chrono::steady_clock::now();
  format::DracoWriteOptions draco;
  draco.quantization_bits = args.qp;
  draco.compression_level = args.cl;
  auto bytes = write_mesh_output(args.output, *kind, result->mesh.view(), draco);
  if (!bytes) return report_error(bytes.status());
  double seconds_write = seconds_since(t);

  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: read %.3f s, sample %.3f s, mesh %.3f s, write %.3f s\n", seconds_read,
                 result->seconds_sample, result->seconds_mesh, seconds_write);
  }
  if (verbosity() >= 1) {
    std::fprintf(stderr, "gaussmesh: %zu -> %zu faces, %zu samples, %llu bytes (%s)\n", mesh->triangles.size(),
                 result->mesh.triangles.size(), result->samples, static_cast<unsigned long long>(*bytes),
                 output_kind_name(*kind));
  }
  if (!args.report.empty()) {
    Json report = simplify_report(args, *kind, mesh->positions.size(), mesh->triangles.size(), options.spheres[0],
                                  options.sampler, *result, result->orientation_index, *bytes);
    report["mesher"] = stream::mesher_name(options.mesher);
    report["chains"] = result->graph.chains;
    report["corners"] = result->graph.corners;
    report["kept_corners"] = result->kept_corners;
    report["kept_chain_vertices"] = result->kept_chain_vertices;
    report["kept_interior_vertices"] = result->kept_interior_vertices;
    report["skipped_input_faces"] = result->skipped_input_faces;
    report["planar_patches"] = result->planar_patches;
    report["collapse_patches"] = result->collapse_patches;
    report["mean_plane_patches"] = result->polygon.mean_plane_patches;
    report["densified_patches"] = result->polygon.densified_patches;
    report["collapsed_patches"] = result->polygon.collapsed_patches;
    report["original_patches"] = result->polygon.original_patches;
    report["interior_samples"] = result->polygon.interior_samples;
    report["mesher_fallback"] = result->mesher_fallback;
    if (result->mesher_fallback) report["mesher_fallback_reason"] = result->mesher_fallback_reason;
    report["chunks"] = 1;
    report["peak_rss_bytes"] = peak_rss_bytes();
    report["seconds"] = {{"read", seconds_read},
                         {"sample", result->seconds_sample},
                         {"mesh", result->seconds_mesh},
                         {"write", seconds_write},
                         {"total", seconds_since(started)}};
    auto status = write_report(args.report, report);
    if (!status.is_ok()) return report_error(status);
  }
  return 0;
}

}  // namespace

void register_simplify(CLI::App& app, Runner& run) {
  auto args = std::make_shared<SimplifyArgs>();
  CLI::App* sub = app.add_subcommand("simplify", "simplify a mesh into a Draco (or PLY/OBJ) approximation");
  sub->add_option("input", args->input, "input mesh, or - for stdin (default)");
  sub->add_option("-o,--output", args->output, "output file, or - for stdout")->required();
  sub->add_option("--format", args->output_format, "output format: draco (default), ply, ply-ascii, obj");
  sub->add_option("--input-format", args->input_format, "force the input format: ply, off, obj, stl");
  sub->add_option("--mesher", args->mesher, "patch (default, topology-preserving) or voronoi");
  sub->add_option("--qp", args->qp, "Draco position quantization bits 1-24 (default 14; encoder cost doubles per bit)")->check(CLI::Range(1, 24));
  sub->add_option("--cl", args->cl, "Draco compression level 0-10 (default 7)")->check(CLI::Range(0, 10));
  sub->add_option("--report", args->report, "write a JSON report to this file (- for stdout)");
  sub->add_flag("-q,--quiet", args->quiet, "print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", args->verbose, "print timings on stderr");
  add_sampling_options(*sub, args->sampling);
  add_pipeline_options(*sub, args->pipeline);
  sub->callback([&run, args] { run = [args] { return run_simplify(*args); }; });
}

}  // namespace gaussmesh::cli
