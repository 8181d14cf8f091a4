// The reader contract check shared by the reader fuzz targets and their regression test.
#include "fuzz/checking_sink.h"

#include "format/byte_source.h"
#include "format/mesh_reader.h"
#include "format/obj_census.h"

namespace gaussmesh::fuzz {

using format::Status;

void CheckingSink::breach(const char* what) {
  if (broken_.empty()) broken_ = what;
}

bool CheckingSink::is_open(const char* call) {
  if (!started_ || ended_) breach(call);
  return broken_.empty();
}

Status CheckingSink::on_header(const format::MeshHeader& header) {
  if (started_) breach("on_header called twice");
  started_ = true;
  header_ = header;
  return {};
}

Status CheckingSink::on_ignored(const std::string& what) {
  is_open("on_ignored outside on_header .. on_end");
  if (what.empty()) breach("on_ignored names nothing");
  return {};
}

Status CheckingSink::on_vertex_attributes(std::span<const format::VertexAttributes> batch) {
  is_open("on_vertex_attributes outside on_header .. on_end");
  if (!header_.attributes.any()) breach("attributes delivered that the header does not announce");
  if (pending_attributes_) breach("two attribute batches without vertices between them");
  for (const format::VertexAttributes& a : batch) {
    if (!format::is_finite(a)) breach("a vertex attribute is not finite");
  }
  pending_attributes_ = batch.size();
  return {};
}

Status CheckingSink::on_vertices(std::span<const format::Vec3f> batch) {
  is_open("on_vertices outside on_header .. on_end");
  if (header_.attributes.any()) {
    if (!pending_attributes_) breach("a vertex batch without its attribute batch");
    if (pending_attributes_ && *pending_attributes_ != batch.size()) breach("attribute batch and vertex batch differ in size");
  }
  pending_attributes_.reset();
  for (const format::Vec3f& p : batch) {
    if (!format::is_finite(p)) breach("a position is not finite");
  }
  vertices_ += batch.size();
  if (vertices_ > format::kMaxVertices) breach("more vertices than a 32-bit index can name");
  if (header_.declared_vertices && vertices_ > *header_.declared_vertices) breach("more vertices than the header declares");
  return {};
}

Status CheckingSink::on_triangles(std::span<const format::Triangle> batch) {
  is_open("on_triangles outside on_header .. on_end");
  if (pending_attributes_) breach("triangles between an attribute batch and its vertices");
  for (const format::Triangle& t : batch) {
    for (format::VertexIndex v : t.v) {
      if (v >= vertices_) breach("a triangle refers to a vertex not delivered yet");
    }
  }
  triangles_ += batch.size();
  return {};
}

Status CheckingSink::on_end() {
  is_open("on_end outside on_header .. on_end");
  if (pending_attributes_) breach("on_end after an attribute batch without its vertices");
  ended_ = true;
  return {};
}

ReadCheck read_and_check(std::string_view bytes, format::MeshFormat format) {
  auto source = format::ByteSource::from_memory(bytes, "<fuzz>");
  format::ReadOptions options;
  options.format = format;
  // Small batches put batch boundaries inside small inputs too.
  options.batch_size = 7;
  options.memory_limit = std::uint64_t{256} << 20;
  CheckingSink sink;
  ReadCheck check{format::read_mesh(*source, options, sink), sink.broken()};
  if (!check.broken.empty()) return check;
  // OBJ once more as an in-core run reads it: the file held, a vertex per (v, vt, vn).
  if (format == format::MeshFormat::kObj) {
    auto again = format::ByteSource::from_memory(bytes, "<fuzz>");
    options.corner_values = true;
    CheckingSink held;
    ReadCheck corners{format::read_mesh(*again, options, held), held.broken()};
    if (corners.broken.empty() && corners.status.is_ok() && !held.ended()) corners.broken = "success without on_end";
    if (!corners.broken.empty()) {
      corners.broken = "with corner values: " + corners.broken;
      return corners;
    }
    auto counted = format::ByteSource::from_memory(bytes, "<fuzz>");
    auto census = format::census_obj(*counted, UINT64_MAX);
    if (!census) return {census.status(), "the census failed on bytes in memory"};
    if (check.status.is_ok() && census->triangles < sink.triangles()) {
      return {check.status, "the census counted fewer triangles than the reader delivered"};
    }
    if (corners.status.is_ok() && (held.header().attributes.texcoords || held.header().attributes.normals) &&
        !census->corner_values) {
      return {corners.status, "the census missed corner values the reader delivered"};
    }
  }
  if (check.status.is_ok() && !sink.ended()) check.broken = "success without on_end";
  if (!check.status.is_ok()) {
    if (sink.ended()) check.broken = "an error after on_end";
    if (check.status.message().empty()) check.broken = "an error without a message";
    if (check.status.code() != format::Code::kBadInput && check.status.code() != format::Code::kResources) {
      check.broken = "an input error that is neither kBadInput nor kResources: " + check.status.to_string();
    }
  }
  return check;
}

}  // namespace gaussmesh::fuzz
