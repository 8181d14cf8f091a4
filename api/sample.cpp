// gaussmesh::sample: Gauss mesh sampling (paper §4) in core or streaming; samples as a point
// PLY, an optional patch-coloured mesh, and the run's record.
#include "api/internal.h"
#include "format/output_file.h"
#include "stream/core/stopwatch.h"
#include "stream/pipeline/out_of_core_sample.h"

namespace gaussmesh {
namespace {

using api::Json;
using stream::Clock;
using stream::seconds_since;

Sample public_sample(const stream::GlobalSample& s) {
  Sample out;
  out.vertex = s.vertex;
  out.position = s.position;
  out.gauss_vertex = s.gauss_vertex == stream::kNoGaussVertex ? kNoGaussVertex : static_cast<std::int32_t>(s.gauss_vertex);
  out.characteristic = static_cast<Characteristic>(s.characteristic);
  return out;
}

Status write_samples(const std::string& path, std::span<const Sample> samples) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t n = samples.size();
  std::vector<Vec3f> points(n);
  std::vector<std::uint32_t> input_vertex(n);
  std::vector<std::int32_t> gauss_vertex(n);
  std::vector<std::uint8_t> characteristic(n);
  for (std::size_t k = 0; k < n; ++k) {
    points[k] = samples[k].position;
    input_vertex[k] = samples[k].vertex;
    gauss_vertex[k] = samples[k].gauss_vertex;
    characteristic[k] = static_cast<std::uint8_t>(samples[k].characteristic);
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

Status write_patches(const std::string& path, MeshView mesh, const stream::SamplingResult& r) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t nf = mesh.triangles.size(), nv = mesh.positions.size();
  std::vector<std::uint8_t> fr(nf), fg(nf), fb(nf), vr(nv, 160), vg(nv, 160), vb(nv, 160), is_sample(nv, 0);
  std::vector<std::uint32_t> patch(r.face_patch), label(r.face_label);
  for (std::size_t f = 0; f < nf; ++f) {
    std::uint8_t rgb[3];
    api::spread_colour(r.face_patch[f], rgb);
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
  GM_RETURN_IF_ERROR(format::write_ply(**out, mesh, options));
  return (*out)->commit();
}

Json orientations_json(const std::vector<stream::GaussSphereOptions>& spheres, const auto& samples_per_orientation) {
  Json orientations = Json::array();
  for (std::size_t k = 0; k < spheres.size(); ++k) {
    const auto& q = spheres[k].rotation;
    orientations.push_back({{"rotation", {q[0], q[1], q[2], q[3]}}, {"samples", samples_per_orientation[k]}});
  }
  return orientations;
}

// The fields both engines' records start with.
Json report_head(const Source& source, std::uint64_t vertices, std::uint64_t faces, const stream::GaussSphere& g,
                 const SampleOptions& o, const stream::SamplerOptions& sampler) {
  Json j;
  j["input"] = source.name();
  j["input_vertices"] = vertices;
  j["input_faces"] = faces;
  j["base"] = stream::gauss_base_name(g.options().base);
  j["frequency"] = g.options().frequency;
  j["smooth"] = o.sampling.smooth;
  j["sample_test"] = stream::sample_test_name(sampler.sample_test);
  j["gauss_vertices"] = g.vertex_count();
  j["gauss_triangles"] = g.triangle_count();
  return j;
}

Status deliver(const std::string& path, std::vector<Sample>& found, std::vector<Sample>* samples) {
  if (!path.empty()) GM_RETURN_IF_ERROR(write_samples(path, found));
  if (samples != nullptr) *samples = std::move(found);
  return {};
}

Result<SampleStats> sample_out_of_core(const Source& source, const std::string& path, const SampleOptions& o,
                                       const std::vector<stream::GaussSphereOptions>& spheres,
                                       const stream::SamplerOptions& sampler, std::uint64_t memory,
                                       std::vector<Sample>* samples) {
  const auto t0 = Clock::now();
  stream::OutOfCoreSamplingOptions options;
  api::set_streaming_options(options, o.resources, memory, spheres, sampler);
  if (o.resources.progress) {
    const ProgressFn& progress = o.resources.progress;
    options.progress = [&progress](std::size_t done, std::size_t total, std::uint64_t faces) {
      progress("sample", done, total, faces);
    };
  }
  format::ReadOptions read = api::read_options(source);
  read.memory_limit = api::whole_input_limit(o.resources);
  auto sampled = stream::sample_out_of_core(api::stream_path(source), read, options);
  if (!sampled) return sampled.status();
  const auto t1 = Clock::now();
  std::vector<Sample> found;
  found.reserve(sampled->samples.size());
  for (const stream::GlobalSample& s : sampled->samples) found.push_back(public_sample(s));
  GM_RETURN_IF_ERROR(deliver(path, found, samples));
  const auto t2 = Clock::now();
  const stream::GaussSphere& g = *sampled->gauss;

  SampleStats stats;
  stats.input_vertices = sampled->vertices;
  stats.input_faces = sampled->faces;
  stats.samples = sampled->samples.size();
  stats.out_of_core = true;
  stats.memory_bytes = memory;
  stats.chunks = sampled->chunks;
  stats.peak_rss_bytes = peak_rss_bytes();
  stats.seconds = seconds_since(t0);

  const stream::ChunkSamplingStats& st = sampled->stats;
  Json j = report_head(source, sampled->vertices, sampled->faces, g, o, sampler);
  j["samples"] = sampled->samples.size();
  j["orientations"] = orientations_json(spheres, sampled->samples_per_orientation);
  j["chosen_orientation"] = sampled->chosen;
  j["out_of_core"] = true;
  j["memory_bytes"] = memory;
  j["threads"] = options.threads;
  j["chunks"] = sampled->chunks;
  j["bytes_spilled"] = sampled->bytes_spilled;
  j["filters"] = {{"candidates_initial", st.candidates_initial}, {"exact_samples", st.exact_samples}};
  j["mesh_defects"] = {{"degenerate_faces", st.degenerate_faces}, {"unlabelled_faces", st.unlabelled_faces}};
  j["peak_rss_bytes"] = stats.peak_rss_bytes;
  j["peak_rss_after_partition_bytes"] = sampled->peak_rss_after_partition;
  j["seconds"] = {{"ingest", sampled->seconds_ingest},
                  {"partition", sampled->seconds_partition},
                  {"sample", sampled->seconds_sample},
                  {"cleanup", sampled->seconds_cleanup},
                  {"write", stream::seconds_between(t1, t2)},
                  {"total", stats.seconds}};
  j["partition_seconds"] = {{"plan", sampled->partition_steps.plan},
                            {"rings", sampled->partition_steps.rings},
                            {"chunks", sampled->partition_steps.chunks}};
  stats.report_json = j.dump(2);
  return stats;
}

Result<SampleStats> sample_in_core(const Source& source, const std::string& path, const SampleOptions& o,
                                   const std::vector<stream::GaussSphereOptions>& spheres,
                                   const stream::SamplerOptions& sampler, std::vector<Sample>* samples) {
  const auto t0 = Clock::now();
  auto mesh = api::load(source, true, o.resources.memory_bytes);
  if (!mesh) return mesh.status();
  const MeshView input = mesh->view;
  const auto t1 = Clock::now();
  auto sampled = stream::sample_mesh_best_orientation(input, spheres, sampler);
  if (!sampled) return sampled.status();
  const auto t2 = Clock::now();
  const stream::SamplingResult& r = sampled->result;
  std::vector<Sample> found;
  found.reserve(r.samples.size());
  for (const stream::Sample& s : r.samples) {
    found.push_back(public_sample({s.vertex, input.positions[s.vertex], s.gauss_vertex, s.characteristic}));
  }
  GM_RETURN_IF_ERROR(deliver(path, found, samples));
  if (!o.patches_path.empty()) GM_RETURN_IF_ERROR(write_patches(o.patches_path, input, r));
  const auto t3 = Clock::now();
  const stream::GaussSphere& g = *sampled->gauss;

  SampleStats stats;
  stats.input_vertices = input.positions.size();
  stats.input_faces = input.triangles.size();
  stats.samples = r.samples.size();
  stats.chunks = 1;
  stats.peak_rss_bytes = peak_rss_bytes();
  stats.seconds = seconds_since(t0);

  Json j = report_head(source, input.positions.size(), input.triangles.size(), g, o, sampler);
  j["patches"] = r.patch_count;
  j["candidates"] = r.candidates.size();
  j["samples"] = r.samples.size();
  j["orientations"] = orientations_json(spheres, sampled->samples_per_orientation);
  j["chosen_orientation"] = sampled->chosen;
  j["out_of_core"] = false;
  j["filters"] = {{"candidates_initial", r.stats.candidates_initial},
                  {"merged_patches", r.stats.merged_patches},
                  {"tree_filtered", r.stats.tree_filtered},
                  {"unwinding_filtered", r.stats.unwinding_filtered},
                  {"noisy_filtered", r.stats.noisy_filtered},
                  {"exact_samples", r.stats.exact_samples}};
  j["mesh_defects"] = {{"degenerate_faces", r.stats.degenerate_faces},
                       {"unlabelled_faces", r.stats.unlabelled_faces},
                       {"break_edges", r.stats.break_edges}};
  j["peak_rss_bytes"] = stats.peak_rss_bytes;
  j["seconds"] = {{"read", stream::seconds_between(t0, t1)}, {"sample", stream::seconds_between(t1, t2)}, {"write", stream::seconds_between(t2, t3)}};
  stats.report_json = j.dump(2);
  return stats;
}

}  // namespace

namespace {

Result<SampleStats> sample_job(const Source& source, const std::string& path, const SampleOptions& options,
                               std::vector<Sample>* samples) {
  auto spheres = api::gauss_spheres(options.sampling);
  if (!spheres) return spheres.status();
  const stream::SamplerOptions sampler = api::sampler_options(options.sampling);
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(source, "sample"));
  // The patch mesh is the whole input.
  auto engine = options.patches_path.empty()
                    ? choose_engine(source, options.resources)
                    : api::choose_in_core_only(source, options.resources, "--patches", "the patch mesh");
  if (!engine) return engine.status();
  if (engine->engine == Engine::kOutOfCore) {
    return sample_out_of_core(source, path, options, *spheres, sampler, engine->memory_bytes, samples);
  }
  return sample_in_core(source, path, options, *spheres, sampler, samples);
}

}  // namespace

Result<SampleStats> sample(const Source& source, const std::string& path, const SampleOptions& options,
                           std::vector<Sample>* samples) {
  return api::guarded("sample", [&] { return sample_job(source, path, options, samples); });
}

}  // namespace gaussmesh
