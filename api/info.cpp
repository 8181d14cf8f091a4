// gaussmesh::info: counts, bounds, boundary loops, manifoldness and genus of a mesh.
#include "api/internal.h"
#include "stream/core/mesh_topology.h"
#include "stream/core/stopwatch.h"

namespace gaussmesh {
namespace {

api::Json vec_json(const Vec3f& v) { return api::Json::array({v.x, v.y, v.z}); }

api::Json report_json(const MeshInfo& i) {
  api::Json j;
  j["input"] = i.input;
  j["format"] = format_name(i.format);
  j["input_vertices"] = i.vertices;
  j["input_faces"] = i.faces;
  j["unreferenced_vertices"] = i.unreferenced_vertices;
  j["degenerate_faces"] = i.degenerate_faces;
  j["zero_area_faces"] = i.zero_area_faces;
  j["duplicate_faces"] = i.duplicate_faces;
  j["edges"] = i.edges;
  j["boundary_edges"] = i.boundary_edges;
  j["boundary_loops"] = i.boundary_loops;
  j["non_manifold_edges"] = i.non_manifold_edges;
  j["non_manifold_vertices"] = i.non_manifold_vertices;
  j["components"] = i.components;
  j["euler_characteristic"] = i.euler_characteristic;
  j["manifold"] = i.manifold;
  j["closed"] = i.closed;
  j["consistently_oriented"] = i.consistently_oriented;
  j["orientable"] = i.orientable ? api::Json(*i.orientable) : api::Json(nullptr);
  j["genus"] = i.genus ? api::Json(*i.genus) : api::Json(nullptr);
  j["bounds"] = {{"min", vec_json(i.bounds_min)}, {"max", vec_json(i.bounds_max)}, {"diagonal", i.diagonal}};
  j["attributes"] = {{"normals", i.normals}, {"colors", i.colors}, {"texcoords", i.texcoords}};
  j["ignored_vertex_values"] = i.ignored_vertex_values;
  j["warnings"] = i.warnings;
  j["peak_rss_bytes"] = i.peak_rss_bytes;
  j["seconds"] = {{"read", i.seconds_read}, {"analyse", i.seconds_analyse}};
  return j;
}

}  // namespace

namespace {

Result<MeshInfo> info_job(const Source& source) {
  if (source.format == MeshFormat::kDraco) {
    return Status::error(Code::kUsage, "--input-format", "info reads ply, off, obj or stl when a format is forced");
  }
  GM_RETURN_IF_ERROR(api::check_not_a_terminal(source, "info"));
  const auto t0 = stream::Clock::now();
  auto mesh = api::load(source);
  if (!mesh) return mesh.status();
  const MeshView view = mesh->view;
  const double read_s = stream::seconds_since(t0);
  const auto t1 = stream::Clock::now();
  auto topology = stream::compute_topology(view);
  if (!topology) return topology.status();
  const stream::MeshTopology& t = *topology;
  MeshInfo i;
  i.input = source.name();
  i.format = mesh->format;
  i.vertices = t.vertices;
  i.unreferenced_vertices = t.unreferenced_vertices;
  i.faces = t.faces;
  i.degenerate_faces = t.degenerate_faces;
  i.zero_area_faces = t.zero_area_faces;
  i.duplicate_faces = t.duplicate_faces;
  i.bounds_min = t.bounds_min;
  i.bounds_max = t.bounds_max;
  i.diagonal = t.diagonal;
  i.edges = t.edges;
  i.boundary_edges = t.boundary_edges;
  i.boundary_loops = t.boundary_loops;
  i.non_manifold_edges = t.non_manifold_edges;
  i.non_manifold_vertices = t.non_manifold_vertices;
  i.components = t.components;
  i.euler_characteristic = t.euler_characteristic;
  i.orientable = t.orientable;
  i.consistently_oriented = t.consistently_oriented;
  i.genus = t.genus;
  i.manifold = t.is_manifold();
  i.closed = t.is_closed();
  i.normals = !view.normals.empty();
  i.colors = !view.colors.empty();
  i.texcoords = !view.texcoords.empty();
  i.ignored_vertex_values = mesh->ignored_vertex_values;
  i.warnings = mesh->input_warnings;
  i.seconds_read = read_s;
  i.seconds_analyse = stream::seconds_since(t1);
  i.peak_rss_bytes = peak_rss_bytes();
  i.report_json = report_json(i).dump(2);
  return i;
}

}  // namespace

Result<MeshInfo> info(const Source& source) {
  return api::guarded("info", [&] { return info_job(source); });
}

}  // namespace gaussmesh
