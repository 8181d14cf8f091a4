// gaussmesh::simplify: the main job, in core or streaming, into a sink, with the run's record.
#include <cmath>
#include <optional>

#include "api/internal.h"
#include "stream/analysis/mesh_distance.h"
#include "stream/attributes/attribute_transfer.h"
#include "stream/attributes/seams.h"
#include "stream/attributes/vertex_values_file.h"
#include "stream/core/fan_split.h"
#include "stream/core/mesh_topology.h"
#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"
#include "stream/finish/colour_quadrics.h"
#include "stream/finish/quadric_finish.h"
#include "stream/partition/spatial_order.h"
#include "stream/pipeline/in_core_simplify.h"
#include "stream/pipeline/out_of_core_simplify.h"

namespace gaussmesh {
namespace {

using api::Json;
using stream::Clock;
using stream::seconds_since;

// The record's fields in and out of core share; result is a stream::SimplifyResult or a
// stream::OutOfCoreSimplify.
Json common_report(const Source& source, const Sink& sink, const SimplifyOptions& o, std::uint64_t input_vertices,
                   std::uint64_t input_faces, const stream::GaussSphereOptions& sphere,
                   const stream::SamplerOptions& sampler, const auto& result, std::size_t chosen, std::uint64_t bytes) {
  Json report;
  report["command"] = "simplify";
  report["input"] = source.kind == Source::Kind::kStandardInput ? std::string("-") : source.name();
  report["output"] = sink.kind == Sink::Kind::kFile ? sink.path : sink.kind == Sink::Kind::kMemory ? "<memory>" : "-";
  report["output_format"] = sink.kind == Sink::Kind::kMemory ? "memory" : output_format_name(sink.resolved_format());
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
  if constexpr (requires { result.parts; }) {
    if (result.parts) {
      report["output_vertices"] = result.parts->vertex_count();
      report["output_faces"] = result.parts->face_count();
    }
  }
  report["output_bytes"] = bytes;
  report["qp"] = o.draco.quantization_bits;
  report["cl"] = o.draco.compression_level;
  return report;
}

stream::FinishTarget finish_target(const TargetOptions& t) {
  return {.faces = t.faces, .ratio = t.ratio, .max_error = t.max_error, .max_error_relative = t.max_error_relative};
}

Status check_target(const TargetOptions& t) {
  if (!(t.ratio >= 0) || t.ratio > 1) return Status::error(Code::kUsage, "--ratio", "must be above 0 and at most 1");
  if (!(t.max_error >= 0) || !std::isfinite(t.max_error)) {
    return Status::error(Code::kUsage, "--max-error", "must be a positive distance");
  }
  return Status();
}

// The finish's fields of the record (docs/cli.md, "Reports").
void finish_report(Json& report, const stream::FinishOptions& o, const std::optional<stream::FinishResult>& f,
                   SimplifyStats& stats) {
  stats.target_faces = o.target_faces;
  report["target_faces"] = o.target_faces;
  report["max_error"] = std::isfinite(o.max_error) ? Json(o.max_error) : Json(nullptr);
  if (!f) return;
  stats.approximation_faces = f->approximation_faces;
  stats.estimated_error = f->estimated_error;
  report["approximation_faces"] = f->approximation_faces;
  report["reached_target"] = f->reached_target;
  report["stopped_by"] = f->stopped_by;
  stats.stopped_by = f->stopped_by;
  report["estimated_error"] = f->estimated_error;
  report["collapses"] = f->collapses;
  report["refused_collapses"] = f->refused;
  report["finish_seconds"] = {{"quadrics", f->seconds_quadrics}, {"collapses", f->seconds_decimate}};
}

// What the output holds a face while it takes its attributes out of core: the gathered mesh
// (18 bytes a face) and its vertices, about half as many as faces, with their attributes and
// the search's state.
constexpr std::uint64_t kAttributedBytesPerFace = 18 + 60;

Json output_attributes_json(const Mesh& mesh) {
  return {{"normals", !mesh.normals.empty()}, {"colors", !mesh.colors.empty()}, {"texcoords", !mesh.texcoords.empty()}};
}
Json output_attributes_json(const format::AttributeKinds& kinds) {
  return {{"normals", kinds.normals}, {"colors", kinds.colors}, {"texcoords", kinds.texcoords}};
}

// The attributes of a chunked finish's output that streams to PLY or OBJ: its vertex positions
// held (its faces streamed twice, for the search grid's size and for computed normals), each
// vertex given the values of the input's surface under it (surface_values) when `triangles` is
// given, else of the nearest input vertex (nearest_vertex_values).
Status streamed_attributes(format::MeshParts& parts, const stream::VertexAttributeSpill* spill,
                           const stream::VertexPassFn& vertices, const stream::TrianglePassFn* triangles,
                           stream::NormalsMode normals, format::PartsAttributes& out,
                           std::vector<format::VertexAttributes>& values) {
  std::vector<format::Vec3f> positions;
  positions.reserve(parts.vertex_count());
  GM_RETURN_IF_ERROR(parts.vertices([&](std::span<const format::Vec3f> b) {
    positions.insert(positions.end(), b.begin(), b.end());
    return Status();
  }));
  double area = 0;
  GM_RETURN_IF_ERROR(parts.faces([&](std::span<const Triangle> b) {
    area += stream::surface_area(positions, b);
    return Status();
  }));
  const format::AttributeKinds input = spill ? spill->kinds() : format::AttributeKinds{};
  if (input.any()) {
    auto found = triangles ? stream::surface_values(*triangles, vertices, input, positions, area)
                           : stream::nearest_vertex_values(vertices, positions, area);
    if (!found) return found.status();
    values = std::move(*found);
  } else {
    values.assign(positions.size(), {});
  }
  if (normals == stream::NormalsMode::kCompute) {
    for (format::VertexAttributes& a : values) a.normal = {0, 0, 0};
    GM_RETURN_IF_ERROR(parts.faces([&](std::span<const Triangle> b) {
      stream::add_face_normals(positions, b, values);
      return Status();
    }));
    stream::normalise_normals(values);
  }
  out.kinds = {normals == stream::NormalsMode::kCompute || (normals == stream::NormalsMode::kKeep && input.normals),
               input.colors, input.texcoords};
  out.values = values;
  if (!out.kinds.any()) values.clear(), out.values = {};
  return Status();
}

// Gives `mesh` the values of the input's surface under each vertex (surface_values): the input's
// triangles and its vertices streamed, normals by `normals`.
Status surface_attributes(const stream::TrianglePassFn& triangles, const stream::VertexPassFn& vertices,
                          const format::AttributeKinds& kinds, stream::NormalsMode normals, Mesh& mesh) {
  auto values = stream::surface_values(triangles, vertices, kinds, mesh.positions,
                                       stream::surface_area(mesh.positions, mesh.triangles));
  if (!values) return values.status();
  stream::assign_attributes(*values, kinds, normals, mesh);
  return Status();
}

// The reader's own warnings (what it skipped), one for the input's per-vertex values it did not
// understand, and one for the attributes the run drops (the chunked finish's output), each
// naming what.
std::vector<std::string> input_warnings(const std::vector<std::string>& skipped, const std::vector<std::string>& ignored,
                                        const format::AttributeKinds& dropped) {
  std::vector<std::string> warnings = skipped;
  if (!ignored.empty()) {
    std::string names;
    for (const std::string& name : ignored) names += (names.empty() ? "" : ", ") + name;
    warnings.push_back("vertex values not understood and not kept: " + names);
  }
  if (dropped.any()) {
    std::string kinds;
    if (dropped.colors) kinds = "colours";
    if (dropped.normals) kinds += std::string(kinds.empty() ? "" : ", ") + "normals";
    if (dropped.texcoords) kinds += std::string(kinds.empty() ? "" : ", ") + "texture coordinates";
    warnings.push_back(kinds + " not kept: the output is too large to hold within --memory with them");
  }
  return warnings;
}

stream::NormalsMode normals_mode(Normals normals) {
  return normals == Normals::kKeep      ? stream::NormalsMode::kKeep
         : normals == Normals::kCompute ? stream::NormalsMode::kCompute
                                        : stream::NormalsMode::kNone;
}

Status no_faces(const Source& source, std::uint64_t vertices) {
  return Status::error(Code::kBadInput, source.name(), "no faces to simplify (" + std::to_string(vertices) + " vertices)");
}

stream::Weld stream_weld(Weld weld) {
  return weld == Weld::kOn ? stream::Weld::kOn : weld == Weld::kOff ? stream::Weld::kOff : stream::Weld::kAuto;
}

Status empty_approximation(const Source& source) {
  return Status::error(Code::kProcessing, source.name(), "the approximation has no faces (too few samples: raise --frequency)");
}

Result<SimplifyStats> simplify_out_of_core(const Source& source, const Sink& sink, const SimplifyOptions& o,
                                           const std::vector<stream::GaussSphereOptions>& spheres,
                                           const stream::SamplerOptions& sampler, std::uint64_t memory,
                                           Clock::time_point started) {
  stream::OutOfCoreSimplifyOptions options;
  api::set_streaming_options(options, o.resources, memory, spheres, sampler);
  options.finish = finish_target(o.target);
  options.auto_frequency = o.sampling.frequency == kAutoFrequency;
  options.memory_explicit = o.resources.memory_bytes != 0;
  options.memory_ceiling = api::usable_memory() / 4;  // as far as the automatic budget may grow
  options.whole_output_bytes_per_face = api::whole_output_bytes_per_face(sink);
  if (o.resources.progress) {
    const ProgressFn& progress = o.resources.progress;
    options.progress = [&progress](const char* pass, std::size_t done, std::size_t total, std::uint64_t faces) {
      progress(pass, done, total, faces);
    };
  }
  options.partition.weld = stream_weld(o.weld);
  options.partition.spill_attributes = true;
  format::ReadOptions read = api::read_options(source);
  read.weld_stl = o.weld == Weld::kOff;  // else STL comes as a soup, welded with the rest in bounded memory
  read.memory_limit = api::whole_input_limit(o.resources);
  auto result = stream::simplify_out_of_core(api::stream_path(source), read, options);
  if (!result) return result.status();
  if (result->faces == 0) return no_faces(source, result->vertices);
  const std::uint64_t output_faces = result->parts ? result->parts->face_count() : result->mesh.triangles.size();
  const std::uint64_t output_vertices = result->parts ? result->parts->vertex_count() : result->mesh.positions.size();
  if (output_faces == 0) return empty_approximation(source);
  // The input's attributes from its vertex spill. A chunked finish's output that streams (PLY,
  // OBJ) holds its vertices for them; one that does not (Draco, memory) is gathered whole. When
  // that would pass an explicit budget, the output goes without them, and says so. While the
  // partition's files are at hand (a chunked finish) and the budget holds the search, each vertex
  // takes the values of the input's surface under it, as in core; else of the nearest input vertex.
  auto t = Clock::now();
  format::AttributeKinds dropped;
  format::PartsAttributes parts_attributes;
  std::vector<format::VertexAttributes> parts_values;
  std::unique_ptr<stream::VertexValuesFile> values_file;  // the values of a transfer in runs
  std::uint64_t attribute_runs = 0;                       // its runs (0: none)
  const stream::NormalsMode normals = normals_mode(o.normals);
  const stream::VertexAttributeSpill* spill = result->attribute_spill.get();
  const format::AttributeKinds input_kinds = spill ? spill->kinds() : format::AttributeKinds{};
  // The spill is decompressed on a thread of its own beside the search, when there are two.
  const bool ahead = options.threads > 1;
  const stream::VertexPassFn vertices = [spill, ahead](const stream::VertexBatchFn& batch) {
    return spill ? spill->each(batch, ahead) : Status();
  };
  const char* transfer = input_kinds.any() ? "nearest_vertex" : "none";
  // What the surface search may take with what the process holds (the streaming budget's ceiling
  // under --memory auto).
  const std::uint64_t limit = options.memory_explicit ? options.memory.bytes() : options.memory_ceiling;
  bool transferred = false;
  if (result->parts && (spill || normals == stream::NormalsMode::kCompute)) {
    // A streamed output adds its vertices' share to what the process holds now (its resident set
    // once the allocator's free pages are handed back).
    const bool streams = api::whole_output_bytes_per_face(sink) == 0;
    if (streams) stream::release_free_memory();
    const std::uint64_t held = result->parts->vertex_count(), resident = streams ? stream::current_rss() : 0;
    const std::uint64_t need = streams ? resident + held * stream::kNearestValuesBytesPerVertex
                                       : api::whole_output_bytes(sink, result->parts->face_count(), kAttributedBytesPerFace);
    const bool surface = input_kinds.any() && result->input_triangles &&
                         (limit == 0 || need + held * stream::kSurfaceValuesBytesPerVertex <= limit);
    if (surface) transfer = "surface";
    // Past an explicit budget a streamed output takes the input's values in runs of vertices
    // that fit beside what the process holds (nearest_vertex_values_in_runs), without computed
    // normals (they take every vertex's faces at once); when the runs would be too short, or the
    // output is gathered whole, it goes without them. The warning names what is not kept.
    const std::uint64_t budget = options.memory_explicit ? options.memory.bytes() : 0;
    const bool over_budget = options.memory_explicit && need > budget;
    if (over_budget) dropped.normals = normals == stream::NormalsMode::kCompute;
    if (over_budget && streams && spill) {
      const std::string dir = format::temp_parent(o.resources.tmp_dir);
      auto file = stream::VertexValuesFile::create(dir);
      if (!file) return file.status();
      const stream::NearVertexPassFn near = [spill, ahead](const stream::PositionBox& box, const stream::VertexBatchFn& batch) {
        return spill->each(batch, ahead, &box);
      };
      auto fitted = stream::nearest_vertex_values_in_runs(vertices, near, *result->parts, budget, dir, **file);
      if (!fitted) return fitted.status();
      attribute_runs = *fitted;
      if (attribute_runs > 0) values_file = std::move(*file);
    }
    if (attribute_runs > 0) {
      parts_attributes.kinds = {normals == stream::NormalsMode::kKeep && input_kinds.normals, input_kinds.colors, input_kinds.texcoords};
      parts_attributes.reader = values_file.get();
      transfer = "nearest_vertex";
    } else if (over_budget) {
      dropped.colors = result->input_attributes.colors;
      dropped.texcoords = result->input_attributes.texcoords;
      dropped.normals = dropped.normals || (normals == stream::NormalsMode::kKeep && result->input_attributes.normals);
      transfer = "none";
    } else if (streams) {
      GM_RETURN_IF_ERROR(streamed_attributes(*result->parts, spill, vertices, surface ? &result->input_triangles : nullptr,
                                             normals, parts_attributes, parts_values));
    } else {
      auto whole = api::gather(*result->parts);
      if (!whole) return whole.status();
      result->mesh = std::move(*whole);
      if (surface) {
        GM_RETURN_IF_ERROR(surface_attributes(result->input_triangles, vertices, input_kinds, normals, result->mesh));
        transferred = true;
      }
      result->input_triangles = nullptr;  // it reads the partition's files, which go with the parts
      result->parts.reset();
    }
  }
  if (!result->parts && !transferred) {  // else it streams as it is read back, without attributes
    bool surface = input_kinds.any() && result->input_triangles;
    if (surface && limit > 0) {
      stream::release_free_memory();
      surface = stream::current_rss() + result->mesh.positions.size() * stream::kSurfaceValuesBytesPerVertex <= limit;
    }
    if (surface) {
      GM_RETURN_IF_ERROR(surface_attributes(result->input_triangles, vertices, input_kinds, normals, result->mesh));
      transfer = "surface";
    } else {
      GM_RETURN_IF_ERROR(stream::transfer_nearest_vertex(vertices, input_kinds, result->mesh, normals));
    }
  }
  result->input_triangles = nullptr;
  {
    const auto cleanup = Clock::now();
    result->input_partition.reset();  // and the partition's files it read
    result->seconds_cleanup += seconds_since(cleanup);
  }
  result->attribute_spill.reset();  // and its file
  const double seconds_attributes = seconds_since(t);
  t = Clock::now();
  auto bytes = result->parts ? api::write_mesh_parts(sink, *result->parts, o.draco,
                                                     options.memory_explicit ? options.memory.bytes() : 0, parts_attributes)
                             : api::write_mesh(sink, result->mesh.view(), o.draco);
  if (!bytes) return bytes.status();
  const double seconds_write = seconds_since(t);

  SimplifyStats stats;
  stats.input_vertices = result->vertices + result->welded_vertices;
  stats.welded_vertices = result->welded_vertices;
  stats.input_faces = result->faces;
  stats.output_vertices = output_vertices;
  stats.output_faces = output_faces;
  stats.output_bytes = *bytes;
  stats.samples = result->samples;
  stats.out_of_core = true;
  stats.memory_bytes = memory;
  stats.warnings = input_warnings(result->input_warnings, result->ignored_vertex_values, dropped);
  // Per-vertex texture coordinates come with their seams split into separate vertices at one
  // place; the streaming engine sees those as open edges and simplifies each side apart.
  if (result->input_attributes.texcoords) {
    stats.warnings.push_back(
        "texture coordinates stream without their seams: a vertex split at a seam is two vertices out of core, so the two "
        "sides are simplified apart and the output may open along the seams (--engine in-core keeps them)");
  }
  stats.chunks = result->chunks;
  stats.peak_rss_bytes = peak_rss_bytes();
  stats.seconds = seconds_since(started);

  Json report = common_report(source, sink, o, stats.input_vertices, result->faces, spheres[result->chosen], sampler,
                              *result, result->chosen, *bytes);
  t = Clock::now();
  result->parts.reset();  // and its temporary files
  result->seconds_cleanup += seconds_since(t);
  finish_report(report, result->finish_options, result->finish, stats);
  if (result->finish) report["approximation"] = result->collapsed_input ? "input" : "gauss";
  report["attribute_transfer"] = transfer;
  report["attribute_runs"] = attribute_runs;
  report["output_attributes"] = parts_attributes.kinds.any() ? output_attributes_json(parts_attributes.kinds)
                                                             : output_attributes_json(result->mesh);
  report["warnings"] = stats.warnings;
  report["merged_patches"] = result->merged_patches;
  report["merge_rounds"] = result->merge_rounds;
  report["mesher"] = "patch";
  report["out_of_core"] = true;
  report["memory_bytes"] = memory;
  if (result->finish_memory_estimate > 0) report["finish_memory_estimate_bytes"] = result->finish_memory_estimate;
  if (result->chunked) {
    const auto& c = *result->chunked;
    report["chunked_finish"] = {{"round_pieces", c.round_pieces},
                                {"round_faces", c.round_faces},
                                {"round_locked_faces", c.round_locked_faces},
                                {"round_seconds", c.seconds_rounds},
                                {"largest_piece", c.largest_piece},
                                {"unheld_pieces", c.unheld_pieces}};
  }
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
  report["peak_rss_bytes"] = stats.peak_rss_bytes;
  report["peak_rss_after_partition_bytes"] = result->peak_rss_after_partition;
  report["peak_rss_after_pieces_bytes"] = result->peak_rss_after_pieces;
  report["peak_rss_after_merge_bytes"] = result->peak_rss_after_merge;
  report["peak_rss_after_loops_bytes"] = result->peak_rss_after_loops;
  report["reordered"] = result->reordered;
  report["welded_vertices"] = result->welded_vertices;
  report["seconds"] = {{"ingest", result->seconds_ingest},
                       {"reorder", result->seconds_reorder},
                       {"partition", result->seconds_partition},
                       {"sample", result->seconds_sample},
                       {"stitch", result->seconds_stitch},
                       {"mesh", result->seconds_mesh},
                       {"cleanup", result->seconds_cleanup},
                       {"attributes", seconds_attributes},
                       {"write", seconds_write},
                       {"total", stats.seconds}};
  report["partition_seconds"] = {{"plan", result->partition_steps.plan},
                                 {"rings", result->partition_steps.rings},
                                 {"chunks", result->partition_steps.chunks}};
  report["reorder_seconds"] = {{"vertices", result->reorder_steps.vertices},
                                {"faces", result->reorder_steps.faces},
                                {"spill", result->reorder_steps.spill}};
  report["stitch_seconds"] = {{"pieces", result->stitch_steps.pieces},
                              {"merge", result->stitch_steps.merge},
                              {"chains", result->stitch_steps.chains},
                              {"loops", result->stitch_steps.loops},
                              {"loop_stitch", result->stitch_steps.loop_stitch}};
  stats.report_json = report.dump(2);
  return stats;
}

Result<SimplifyStats> simplify_in_core(const Source& source, const Sink& sink, const SimplifyOptions& o,
                                       const std::vector<stream::GaussSphereOptions>& spheres,
                                       const stream::SamplerOptions& sampler, Clock::time_point started) {
  auto t = Clock::now();
  auto mesh = api::load(source, o.weld == Weld::kOff, o.resources.memory_bytes, /*corner_values=*/true);
  if (!mesh) return mesh.status();
  const double seconds_read = seconds_since(t);
  // An input split where its values differ (texture seams, hard normals: stream/attributes/seams.h)
  // is simplified as its surface welded by position; a target then keeps the seams. The split
  // input stays for the values.
  std::optional<stream::Seams> seams;
  stream::Mesh seamed_input;
  if (o.mesher == Mesher::kPatch) seams = stream::find_seams(mesh->view);
  if (seams) {
    if (!mesh->owned.positions.empty() || !mesh->owned.triangles.empty()) {
      seamed_input = std::move(mesh->owned);
    } else {
      const MeshView& v = mesh->view;
      seamed_input = {{v.positions.begin(), v.positions.end()}, {v.triangles.begin(), v.triangles.end()},
                     {v.normals.begin(), v.normals.end()}, {v.colors.begin(), v.colors.end()},
                     {v.texcoords.begin(), v.texcoords.end()}};
    }
    mesh->owned = stream::Mesh{seams->welded.positions, seams->welded.triangles, {}, {}, {}};
    mesh->view = mesh->owned.view();
  }
  // A scattered input is renumbered in spatial order, and a soup welded, as the out-of-core
  // engine does, so that both reach the same output (stream/partition/spatial_order.h).
  t = Clock::now();
  stream::OrderProbe probe;
  probe.add(mesh->view.triangles);
  const bool weld = stream::should_weld(stream_weld(o.weld), mesh->view.positions.size(), mesh->view.triangles.size());
  const bool reordered = weld || probe.scattered(mesh->view.positions.size());
  const bool has_attributes = seams || !mesh->view.normals.empty() || !mesh->view.colors.empty() || !mesh->view.texcoords.empty();
  // The attributes are taken from the input as read (a copy of its positions and faces when the
  // renumbering below rewrites them, beside its attributes, which the renumbered mesh does not
  // keep): the transfer needs its surface, not its numbering.
  stream::Mesh as_read;
  std::uint64_t welded = 0;
  if (reordered) {
    if (has_attributes && !seams) {  // with seams the split input is kept already
      as_read.positions.assign(mesh->view.positions.begin(), mesh->view.positions.end());
      as_read.triangles.assign(mesh->view.triangles.begin(), mesh->view.triangles.end());
      auto take = [](auto& owned, auto view) {
        return owned.empty() ? std::vector(view.begin(), view.end()) : std::move(owned);
      };
      as_read.normals = take(mesh->owned.normals, mesh->view.normals);
      as_read.colors = take(mesh->owned.colors, mesh->view.colors);
      as_read.texcoords = take(mesh->owned.texcoords, mesh->view.texcoords);
    }
    if (mesh->owned.positions.empty() && mesh->owned.triangles.empty()) {
      mesh->owned.positions.assign(mesh->view.positions.begin(), mesh->view.positions.end());
      mesh->owned.triangles.assign(mesh->view.triangles.begin(), mesh->view.triangles.end());
    }
    welded = stream::reorder_spatially(mesh->owned.positions, mesh->owned.triangles, weld);
    mesh->owned.normals.clear();
    mesh->owned.colors.clear();
    mesh->owned.texcoords.clear();
    mesh->view = mesh->owned.view();
  }
  const MeshView attribute_input = seams ? seamed_input.view() : reordered ? as_read.view() : mesh->view;
  const double seconds_reorder = seconds_since(t);
  const MeshView input = mesh->view;
  if (input.triangles.empty()) return no_faces(source, input.positions.size());

  stream::SimplifyOptions options;
  options.spheres = spheres;
  options.sampler = sampler;
  const stream::FinishOptions finish = stream::resolve_finish(finish_target(o.target), input.triangles.size(),
                                                              stream::finite_diagonal(input.positions));
  GM_RETURN_IF_ERROR(stream::check_finish_target(finish, input.triangles.size(), source.name()));
  if (o.target.any() && o.sampling.frequency == kAutoFrequency)
    options.min_samples = stream::finish_min_samples(finish, input.triangles.size());
  options.mesher = o.mesher == Mesher::kVoronoi ? stream::MesherKind::kVoronoi : stream::MesherKind::kPatch;
  // One run on `faces`: the finish on the input itself where the target asks for it
  // (stream::finish_collapses_input), else on the Gauss approximation; also when the input is not
  // a manifold OpenMesh can hold. `non_manifold`: a stage found it not a manifold, or the output
  // is not one.
  struct Attempt {
    std::optional<stream::FinishResult> finished;
    bool collapsed_input = false;
    stream::SimplifyResult result;
    bool non_manifold = false;
  };
  // --color-weight: the input's colour ramps as quadrics of the mesh the finish collapses.
  auto colour_terms = [&](MeshView collapsed) {
    return o.color_weight > 0 && !attribute_input.colors.empty()
               ? stream::colour_quadrics(attribute_input, collapsed, stream::frame_of(collapsed), o.color_weight)
               : stream::ColourTerms{};
  };
  // With seams, any target collapses the welded input with its seams (the Gauss approximation does
  // not keep them), once: the non-manifold retry below splits the fans of `input`, without them.
  bool seams_kept = false, seams_tried = false;
  std::size_t seam_split_vertices = 0;  // copies the fan split of the welded surface made
  auto attempt = [&](MeshView faces) -> Result<Attempt> {
    Attempt a;
    if (seams && !seams_tried && o.target.any() && o.sampling.frequency == kAutoFrequency) {
      seams_tried = true;
      stream::ColourTerms colour = colour_terms(seams->welded.view());
      auto f = stream::finish_input(seams->welded.view(), finish, seams->corner_wedges, colour.quadrics, colour.sums);
      if (!f && f.status().code() != Code::kProcessing) return f.status();
      if (!f) {
        // Not an oriented manifold once welded: a vertex per fan of faces, as for any input
        // (stream/core/fan_split.h); the faces keep their order, so their corners' wedges hold.
        auto s = stream::split_vertex_fans(seams->welded);
        if (!s) return s.status();
        seam_split_vertices = s->added_vertices;
        if (s->added_vertices > 0) {
          colour = colour_terms(seams->welded.view());
          f = stream::finish_input(seams->welded.view(), finish, seams->corner_wedges, colour.quadrics, colour.sums);
          if (!f && f.status().code() != Code::kProcessing) return f.status();
        }
      }
      if (f) {
        a.finished = std::move(f).value(), a.collapsed_input = true, seams_kept = true;
        a.finished->mesh = stream::split_at_seams(attribute_input, *seams, a.finished->mesh, a.finished->corner_wedges,
                                                  a.finished->source, a.finished->region, normals_mode(o.normals));
        return a;
      }
      a.non_manifold = true;
      return a;
    }
    if (o.target.any() && o.sampling.frequency == kAutoFrequency &&
        stream::finish_collapses_input(finish, faces.triangles.size())) {
      const stream::Mesh compact = stream::compact_input(faces.positions, faces.triangles);
      const stream::ColourTerms colour = colour_terms(compact.view());
      auto f = stream::finish_input(compact.view(), finish, {}, colour.quadrics, colour.sums);
      if (!f && f.status().code() != Code::kProcessing) return f.status();
      if (f) a.finished = std::move(f).value(), a.collapsed_input = true;
      a.non_manifold = !f;
    }
    if (!a.collapsed_input) {
      auto simplified = stream::simplify_mesh(faces, options);
      if (!simplified) return simplified.status();
      a.result = std::move(simplified).value();
      a.non_manifold = a.non_manifold || a.result.mesher_fallback;
    }
    // A vertex with two fans can also pass through the meshers and the finish into the output:
    // the output, which is small, says so (the Voronoi mesher makes no topology promise).
    if (!a.non_manifold && options.mesher == stream::MesherKind::kPatch) {
      auto topology = stream::compute_topology(a.collapsed_input ? a.finished->mesh.view() : a.result.mesh.view());
      a.non_manifold = topology && !topology->is_manifold();
    }
    return a;
  };
  auto first = attempt(input);
  if (!first) return first.status();
  // A non-manifold input runs again with a vertex per fan of faces, so that every face is kept
  // (stream/core/fan_split.h, docs/cli.md "Non-manifold input"). The copy has no attributes: they
  // come from the input's surface, which the split does not change.
  stream::FanSplit split;
  stream::Mesh split_input;
  MeshView faces = input;
  if (first->non_manifold) {
    split_input.positions.assign(input.positions.begin(), input.positions.end());
    split_input.triangles.assign(input.triangles.begin(), input.triangles.end());
    auto s = stream::split_vertex_fans(split_input);
    if (!s) return s.status();
    split = *s;
    if (split.added_vertices > 0) {
      faces = split_input.view();
      first = attempt(faces);
      if (!first) return first.status();
    }
  }
  std::optional<stream::FinishResult> finished = std::move(first->finished);
  const bool collapsed_input = first->collapsed_input;
  auto result = Result<stream::SimplifyResult>(std::move(first->result));
  if (collapsed_input) result->mesh = std::move(finished->mesh);
  if (result->mesh.triangles.empty()) return empty_approximation(source);

  if (finish.enabled() && !finished) {
    auto f = stream::finish_in_core(faces, result->mesh.view(), finish);
    if (!f) return f.status();
    result->mesh = std::move(f->mesh);
    result->birth.clear();  // moved vertices are no longer input vertices
    finished = std::move(f).value();
  }
  t = Clock::now();
  if (!seams_kept && (has_attributes || o.normals == Normals::kCompute)) {
    stream::transfer_attributes(attribute_input, result->mesh, normals_mode(o.normals));
  }
  const double seconds_attributes = seconds_since(t);
  std::optional<stream::MeshDistance> measured;
  if (o.target.measure) {
    auto d = stream::mesh_distance(input, result->mesh.view(), {});
    if (!d) return d.status();
    measured = *d;
  }

  t = Clock::now();
  auto bytes = api::write_mesh(sink, result->mesh.view(), o.draco);
  if (!bytes) return bytes.status();
  const double seconds_write = seconds_since(t);

  SimplifyStats stats;
  stats.input_vertices = input.positions.size() + welded;
  stats.welded_vertices = welded;
  stats.input_faces = input.triangles.size();
  stats.output_vertices = result->mesh.positions.size();
  stats.output_faces = result->mesh.triangles.size();
  stats.output_bytes = *bytes;
  stats.samples = result->samples;
  stats.chunks = 1;
  stats.warnings = input_warnings(mesh->input_warnings, mesh->ignored_vertex_values, {});
  if (seams && !seams_kept) {
    stats.warnings.push_back("the input's values differ at " + std::to_string(seams->seam_vertices) +
                             " positions (texture seams, hard normals or colour edges); " +
                             (seams_tried      ? std::string("its surface welded by position is not an oriented manifold, so "
                                                                 "they are not kept: this output's faces may cross them")
                              : o.target.any() ? std::string("an explicit --frequency takes the Gauss approximation, which does "
                                                             "not keep them: this output's faces may cross them")
                                               : std::string("only a target (--ratio, --target-faces, --max-error) keeps them: "
                                                             "this output's faces may cross them")));
  }
  if (result->mesher_fallback) {
    // The collapse mesher leaves out the faces it cannot add without an edge or a vertex that is
    // not a manifold (docs/cli.md, "Non-manifold input"); faces with a repeated corner are left out
    // on every input and are not news.
    std::size_t repeated = 0;
    for (const Triangle& f : input.triangles) repeated += f.v[0] == f.v[1] || f.v[1] == f.v[2] || f.v[0] == f.v[2];
    if (result->skipped_input_faces > repeated) {
      stats.warnings.push_back(std::to_string(result->skipped_input_faces - repeated) +
                               " input faces left out at edges with more than two faces or vertices joining separate fans, "
                               "so that the output is a manifold (the first faces in file order are kept)");
    }
  }
  stats.peak_rss_bytes = peak_rss_bytes();
  stats.seconds = seconds_since(started);

  Json report = common_report(source, sink, o, stats.input_vertices, input.triangles.size(),
                              options.spheres[result->orientation_index], options.sampler, *result,
                              result->orientation_index, *bytes);
  finish_report(report, finish, finished, stats);
  if (finished) report["approximation"] = collapsed_input ? "input" : "gauss";
  // In core: the surface under each vertex, or the seams' own rule (stream/attributes/seams.h).
  report["attribute_transfer"] = !has_attributes ? "none" : seams_kept ? "seams" : "surface";
  report["attribute_runs"] = 0;
  report["output_attributes"] = output_attributes_json(result->mesh);
  report["warnings"] = stats.warnings;
  if (measured) {
    stats.measured = true;
    stats.hausdorff = measured->hausdorff;
    stats.rms = measured->rms;
    stats.diagonal = measured->diagonal;
    report["measured"] = {{"hausdorff", measured->hausdorff},
                          {"rms", measured->rms},
                          {"diagonal", measured->diagonal},
                          {"hausdorff_pct", measured->hausdorff_pct()},
                          {"rms_pct", measured->rms_pct()},
                          {"facing_away_faces", measured->b_to_a.facing_away},
                          {"facing_away_area_pct", measured->b_to_a.facing_away_pct()}};
  }
  report["mesher"] = stream::mesher_name(options.mesher);
  report["out_of_core"] = false;
  report["chains"] = result->graph.chains;
  report["corners"] = result->graph.corners;
  report["kept_corners"] = result->kept_corners;
  report["kept_chain_vertices"] = result->kept_chain_vertices;
  report["kept_interior_vertices"] = result->kept_interior_vertices;
  report["skipped_input_faces"] = result->skipped_input_faces;
  report["split_vertices"] = split.added_vertices + (seams_kept ? seam_split_vertices : 0);
  report["color_weight"] = o.color_weight;
  report["seam_vertices"] = seams ? seams->seam_vertices : 0;
  report["seams_kept"] = seams_kept;
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
  report["peak_rss_bytes"] = stats.peak_rss_bytes;
  report["reordered"] = reordered;
  report["welded_vertices"] = welded;
  report["seconds"] = {{"read", seconds_read},
                       {"reorder", seconds_reorder},
                       {"sample", result->seconds_sample},
                       {"mesh", result->seconds_mesh},
                       {"attributes", seconds_attributes},
                       {"write", seconds_write},
                       {"total", stats.seconds}};
  stats.report_json = report.dump(2);
  return stats;
}

}  // namespace

namespace {

Result<SimplifyStats> simplify_job(const Source& source, const Sink& sink, const SimplifyOptions& options) {
  const auto started = Clock::now();
  if (options.draco.quantization_bits < 1 || options.draco.quantization_bits > 24) {
    return Status::error(Code::kUsage, "--qp", "Draco quantization bits must be between 1 and 24");
  }
  if (options.draco.compression_level < 0 || options.draco.compression_level > 10) {
    return Status::error(Code::kUsage, "--cl", "Draco compression level must be between 0 and 10");
  }
  GM_RETURN_IF_ERROR(check_target(options.target));
  auto spheres = options.target.any() && options.sampling.frequency == kAutoFrequency
                     ? api::frequency_ladder(options.sampling)
                     : api::gauss_spheres(options.sampling);
  if (!spheres) return spheres.status();
  const stream::SamplerOptions sampler = api::sampler_options(options.sampling);
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(source, "simplify"));
  auto engine = options.mesher == Mesher::kVoronoi
                    ? api::choose_in_core_only(source, options.resources, "--mesher", "the Voronoi mesher")
                    : choose_engine(source, options.resources);
  if (!engine) return engine.status();
  // A target's finish adds to the in-core working set (the input path holds ~kInputBytesPerFace
  // more a face): the automatic choice counts it, so that an explicit budget still holds.
  if (engine->engine == Engine::kInCore && options.resources.engine == Engine::kAuto && options.target.any() &&
      (source.kind == Source::Kind::kFile || source.kind == Source::Kind::kStandardInput)) {
    const std::uint64_t limit =
        options.resources.memory_bytes != 0 ? options.resources.memory_bytes : api::usable_memory() / 4;
    const std::uint64_t faces = engine->estimated_faces;
    if (in_core_bytes(faces) + stream::kInputBytesPerFace * faces > limit) {
      engine->engine = Engine::kOutOfCore;
      engine->memory_bytes = options.resources.memory_bytes != 0 ? options.resources.memory_bytes : auto_memory_budget();
    }
  }
  api::keep_seams_in_core(source, options.resources, options.target.any() ? stream::kInputBytesPerFace : 0, *engine);
  if (engine->engine == Engine::kOutOfCore) {
    if (options.target.measure) {
      return Status::error(Code::kUsage, "--measure",
                           "measures in core only: this input streams (run `gaussmesh compare` on the output)");
    }
    if (options.color_weight > 0) {
      return Status::error(Code::kUsage, "--color-weight",
                           "weighs colours in core only: this input streams (--engine in-core holds it)");
    }
    return simplify_out_of_core(source, sink, options, *spheres, sampler, engine->memory_bytes, started);
  }
  return simplify_in_core(source, sink, options, *spheres, sampler, started);
}

}  // namespace

Result<SimplifyStats> simplify(const Source& source, const Sink& sink, const SimplifyOptions& options) {
  return api::guarded("simplify", [&] { return simplify_job(source, sink, options); });
}

}  // namespace gaussmesh
