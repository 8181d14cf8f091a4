// gaussmesh sample: Gauss mesh sampling of one mesh (paper §4), samples as a point PLY, an
// optional patch-coloured mesh for MeshLab, and the --report JSON (DESIGN §5).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/pipeline_options.h"
#include "cli/report.h"
#include "cli/sampling_options.h"
#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/pipeline/out_of_core_sample.h"
#include "stream/core/mesh.h"
#include "stream/sampling/sampler.h"

namespace gaussmesh::cli {
namespace {

using format::Code;
using format::Status;

struct SampleCommandOptions {
  std::string input = "-";
  std::string output;
  std::string patches;
  std::string report;
  bool quiet = false;
  bool verbose = false;
  SamplingOptions sampling;
  PipelineOptions pipeline;
};

// A well-spread colour per patch id.
void patch_colour(std::uint32_t id, std::uint8_t rgb[3]) {
  std::uint32_t h = id * 2654435761u;
  h ^= h >> 15;
  for (int i = 0; i < 3; ++i) rgb[i] = static_cast<std::uint8_t>(64 + (h >> (8 * i) & 0xFF) * 3 / 4);
}

Status write_samples(const std::string& path, std::span<const stream::GlobalSample> samples) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t n = samples.size();
  std::vector<format::Vec3f> points(n);
  std::vector<std::uint32_t> input_vertex(n);
  std::vector<std::int32_t> gauss_vertex(n);
  std::vector<std::uint8_t> characteristic(n);
  for (std::size_t k = 0; k < n; ++k) {
    const stream::GlobalSample& s = samples[k];
    points[k] = s.position;
    input_vertex[k] = s.vertex;
    gauss_vertex[k] = s.gauss_vertex == stream::kNoGaussVertex ? -1 : static_cast<std::int32_t>(s.gauss_vertex);
    characteristic[k] = static_cast<std::uint8_t>(s.characteristic);
  }
  format::PlyWriteOptions options;
  options.write_faces = false;
  options.comments = {"gaussmesh sample: characteristic 0 none, 1 convex, 2 concave, 3 saddle"};
  options.vertex_attributes = {{"input_vertex", std::span<const std::uint32_t>(input_vertex)},
                               {"gauss_vertex", std::span<const std::int32_t>(gauss_vertex)},
                               {"characteristic", std::span<const std::uint8_t>(characteristic)}};
  GM_RETURN_IF_ERROR(format::write_ply(**out, {points, {}}, options));
  return (*out)->commit();
}

Status write_samples(const std::string& path, const stream::Mesh& mesh, const stream::SamplingResult& r) {
  std::vector<stream::GlobalSample> samples;
  samples.reserve(r.samples.size());
  for (const stream::Sample& s : r.samples)
    samples.push_back({s.vertex, mesh.positions[s.vertex], s.gauss_vertex, s.characteristic});
  return write_samples(path, samples);
}

Status write_patches(const std::string& path, const stream::Mesh& mesh, const stream::SamplingResult& r) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t nf = mesh.triangles.size(), nv = mesh.positions.size();
  std::vector<std::uint8_t> fr(nf), fg(nf), fb(nf), vr(nv, 160), vg(nv, 160), vb(nv, 160), is_sample(nv, 0);
  std::vector<std::uint32_t> patch(r.face_patch), label(r.face_label);
  for (std::size_t f = 0; f < nf; ++f) {
    std::uint8_t rgb[3];
    patch_colour(r.face_patch[f], rgb);
    fr[f] = rgb[0];
    fg[f] = rgb[1];
    fb[f] = rgb[2];
  }
  for (const stream::Sample& s : r.samples) {
    is_sample[s.vertex] = 1;
    vr[s.vertex] = 255;
    vg[s.vertex] = 0;
    vb[s.vertex] = 0;
  }
  format::PlyWriteOptions options;
  options.comments = {"gaussmesh sample --patches: faces coloured per patch, samples are red vertices"};
  options.vertex_attributes = {{"red", std::span<const std::uint8_t>(vr)},
                               {"green", std::span<const std::uint8_t>(vg)},
                               {"blue", std::span<const std::uint8_t>(vb)},
                               {"sample", std::span<const std::uint8_t>(is_sample)}};
  options.face_attributes = {{"red", std::span<const std::uint8_t>(fr)},
                             {"green", std::span<const std::uint8_t>(fg)},
                             {"blue", std::span<const std::uint8_t>(fb)},
                             {"patch", std::span<const std::uint32_t>(patch)},
                             {"label", std::span<const std::uint32_t>(label)}};
  GM_RETURN_IF_ERROR(format::write_ply(**out, mesh.view(), options));
  return (*out)->commit();
}

// --memory: passes 0-2 over chunks on disk (stream/sampling/chunk_sampler.h); the samples equal the
// in-core run's. No patch mesh (it would be the whole input), exact test only.
int run_sample_out_of_core(const SampleCommandOptions& o, const std::vector<stream::GaussSphereOptions>& spheres,
                           const stream::SamplerOptions& sampler) {
  auto memory = parse_memory_size(o.pipeline.memory);
  if (!memory) return report_error(memory.status());
  if (!o.patches.empty()) {
    return report_error(Status::error(Code::kUsage, "sample",
                                      "--patches writes the whole input mesh and is not available with --memory"));
  }
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  stream::OutOfCoreSamplingOptions options;
  options.memory = stream::MemoryBudget(*memory);
  options.partition.tmp_dir = o.pipeline.tmp;
  options.threads = pipeline_threads(o.pipeline);
  options.spheres = spheres;
  options.sampler = sampler;
  Progress progress;
  options.progress = [&](std::size_t done, std::size_t total, std::uint64_t faces) {
    progress.update("sample", done, total, faces);
  };
  options.partition.progress = [&](const char* pass, std::uint64_t done, std::uint64_t total) {
    progress.update(pass, done, total, total);
  };
  auto sampled = stream::sample_out_of_core(o.input, {}, options);
  if (!sampled) return report_error(sampled.status());
  const auto t1 = Clock::now();
  if (Status s = write_samples(o.output, sampled->samples); !s) return report_error(s);
  const auto t2 = Clock::now();
  const stream::GaussSphere& g = *sampled->gauss;
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: sample: %zu samples in %zu chunks (G: %zu vertices)\n",
                 sampled->samples.size(), sampled->chunks, g.vertex_count());
  }
  if (!o.report.empty()) {
    auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
    Json orientations = Json::array();
    for (std::size_t k = 0; k < spheres.size(); ++k) {
      const auto& q = spheres[k].rotation;
      orientations.push_back({{"rotation", {q[0], q[1], q[2], q[3]}}, {"samples", sampled->samples_per_orientation[k]}});
    }
    const stream::ChunkSamplingStats& st = sampled->stats;
    Json j;
    j["input"] = o.input == "-" ? "<stdin>" : o.input;
    j["input_vertices"] = sampled->vertices;
    j["input_faces"] = sampled->faces;
    j["base"] = stream::gauss_base_name(g.options().base);
    j["frequency"] = g.options().frequency;
    j["smooth"] = o.sampling.smooth;
    j["sample_test"] = stream::sample_test_name(sampler.sample_test);
    j["gauss_vertices"] = g.vertex_count();
    j["gauss_triangles"] = g.triangle_count();
    j["samples"] = sampled->samples.size();
    j["orientations"] = orientations;
    j["chosen_orientation"] = sampled->chosen;
    j["out_of_core"] = true;
    j["memory_bytes"] = *memory;
    j["threads"] = options.threads;
    j["chunks"] = sampled->chunks;
    j["bytes_spilled"] = sampled->bytes_spilled;
    j["filters"] = {{"candidates_initial", st.candidates_initial}, {"exact_samples", st.exact_samples}};
    j["mesh_defects"] = {{"degenerate_faces", st.degenerate_faces}, {"unlabelled_faces", st.unlabelled_faces}};
    j["peak_rss_bytes"] = peak_rss_bytes();
    j["peak_rss_after_partition_bytes"] = sampled->peak_rss_after_partition;
    j["seconds"] = {{"ingest", sampled->seconds_ingest},
                    {"partition", sampled->seconds_partition},
                    {"sample", sampled->seconds_sample},
                    {"cleanup", sampled->seconds_cleanup},
                    {"write", secs(t1, t2)},
                    {"total", secs(t0, t2)}};
    j["partition_seconds"] = partition_seconds(sampled->partition_steps);
    if (Status s = write_report(o.report, j); !s) return report_error(s);
  }
  return 0;
}

int run_sample(const SampleCommandOptions& o) {
  if (o.quiet) set_verbosity(0);
  if (o.verbose) set_verbosity(2);
  auto spheres = gauss_sphere_options(o.sampling);
  if (!spheres) return report_error(spheres.status());
  auto sampler = sampler_options(o.sampling);
  if (!sampler) return report_error(sampler.status());
  if (o.input == "-" && ::isatty(0)) {
    return report_error(Status::error(Code::kUsage, "sample", "no input file, and standard input is a terminal"));
  }
  if (!o.pipeline.memory.empty()) return run_sample_out_of_core(o, *spheres, *sampler);
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto mesh = stream::load_mesh(o.input);
  if (!mesh) return report_error(mesh.status());
  const auto t1 = Clock::now();
  auto sampled = stream::sample_mesh_best_orientation(mesh->view(), *spheres, *sampler);
  if (!sampled) return report_error(sampled.status());
  const auto t2 = Clock::now();
  const stream::SamplingResult& r = sampled->result;
  if (Status s = write_samples(o.output, *mesh, r); !s) return report_error(s);
  if (!o.patches.empty()) {
    if (Status s = write_patches(o.patches, *mesh, r); !s) return report_error(s);
  }
  const auto t3 = Clock::now();
  const stream::GaussSphere& g = *sampled->gauss;
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: sample: %zu samples, %zu candidates, %zu patches (G: %zu vertices)\n",
                 r.samples.size(), r.candidates.size(), r.patch_count, g.vertex_count());
  }
  if (!o.report.empty()) {
    auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
    Json orientations = Json::array();
    for (std::size_t k = 0; k < spheres->size(); ++k) {
      const auto& q = (*spheres)[k].rotation;
      orientations.push_back({{"rotation", {q[0], q[1], q[2], q[3]}}, {"samples", sampled->samples_per_orientation[k]}});
    }
    Json j;
    j["input"] = o.input == "-" ? "<stdin>" : o.input;
    j["input_vertices"] = mesh->positions.size();
    j["input_faces"] = mesh->triangles.size();
    j["base"] = stream::gauss_base_name(g.options().base);
    j["frequency"] = g.options().frequency;
    j["smooth"] = o.sampling.smooth;
    j["sample_test"] = stream::sample_test_name(sampler->sample_test);
    j["gauss_vertices"] = g.vertex_count();
    j["gauss_triangles"] = g.triangle_count();
    j["patches"] = r.patch_count;
    j["candidates"] = r.candidates.size();
    j["samples"] = r.samples.size();
    j["orientations"] = orientations;
    j["chosen_orientation"] = sampled->chosen;
    j["filters"] = {{"candidates_initial", r.stats.candidates_initial},
                    {"merged_patches", r.stats.merged_patches},
                    {"tree_filtered", r.stats.tree_filtered},
                    {"unwinding_filtered", r.stats.unwinding_filtered},
                    {"noisy_filtered", r.stats.noisy_filtered},
                    {"exact_samples", r.stats.exact_samples}};
    j["mesh_defects"] = {{"degenerate_faces", r.stats.degenerate_faces},
                         {"unlabelled_faces", r.stats.unlabelled_faces},
                         {"break_edges", r.stats.break_edges}};
    j["peak_rss_bytes"] = peak_rss_bytes();
    j["seconds"] = {{"read", secs(t0, t1)}, {"sample", secs(t1, t2)}, {"write", secs(t2, t3)}};
    if (Status s = write_report(o.report, j); !s) return report_error(s);
  }
  return 0;
}

}  // namespace

void register_sample(CLI::App& app, Runner& run) {
  auto o = std::make_shared<SampleCommandOptions>();
  CLI::App* sub = app.add_subcommand("sample", "Gauss mesh sampling: samples as a point PLY (ids, Gaussian vertex, characteristic)");
  sub->add_option("input", o->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")->capture_default_str();
  sub->add_option("-o,--output", o->output, "Samples as a binary point PLY ('-': stdout)")->required();
  sub->add_option("--patches", o->patches, "Also write the input mesh coloured per patch, samples in red (PLY)");
  sub->add_option("--report", o->report, "Write the figures as JSON to FILE ('-': stdout)");
  sub->add_flag("-q,--quiet", o->quiet, "Print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", o->verbose, "Print counts on stderr");
  add_sampling_options(*sub, o->sampling);
  add_pipeline_options(*sub, o->pipeline);
  sub->callback([&run, o] { run = [o] { return run_sample(*o); }; });
}

}  // namespace gaussmesh::cli
