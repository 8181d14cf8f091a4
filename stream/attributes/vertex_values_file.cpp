// An output's vertex values in an unnamed temporary file (vertex_values_file.h).
#include "stream/attributes/vertex_values_file.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include "format/file_io.h"
#include "format/temp_ownership.h"

namespace gaussmesh::stream {

format::Result<std::unique_ptr<VertexValuesFile>> VertexValuesFile::create(const std::string& dir) {
  std::unique_ptr<VertexValuesFile> file(new VertexValuesFile);
  file->dir_ = dir;
  file->fd_ = format::create_unnamed_file(dir, "gaussmesh-run-values-");
  if (file->fd_ < 0) {
    return format::Status::error(format::Code::kOutput, dir, std::string("cannot make a temporary file: ") + std::strerror(errno));
  }
  return file;
}

VertexValuesFile::~VertexValuesFile() {
  if (fd_ >= 0) ::close(fd_);
}

format::Status VertexValuesFile::append(std::span<const format::VertexAttributes> values) {
  const std::uint64_t bytes = values.size_bytes();
  if (!format::write_all(fd_, values.data(), bytes, count_ * sizeof(format::VertexAttributes))) {
    return format::Status::error(format::Code::kOutput, dir_, std::string("cannot write a temporary file: ") + std::strerror(errno));
  }
  count_ += values.size();
  return {};
}

format::Status VertexValuesFile::rewind() {
  at_ = 0;
  return {};
}

format::Status VertexValuesFile::read(std::span<format::VertexAttributes> out) {
  if (out.size() > count_ - at_) {
    return format::Status::error(format::Code::kProcessing, dir_, "read past the last vertex's values");
  }
  if (!format::pread_all(fd_, out.data(), out.size_bytes(), at_ * sizeof(format::VertexAttributes))) {
    return format::Status::error(format::Code::kBadInput, dir_, "temporary file is shorter than written");
  }
  at_ += out.size();
  return {};
}

format::Status nearest_vertex_values_in_runs(const VertexPassFn& input, format::MeshParts& output, std::uint64_t run,
                                             VertexValuesFile& into) {
  const std::uint64_t total = output.vertex_count();
  run = std::max<std::uint64_t>(run, 1);
  std::vector<format::Vec3f> positions;
  std::vector<format::Triangle> inside;
  for (std::uint64_t first = 0; first < total; first += run) {
    const std::uint64_t end = std::min(total, first + run);
    positions.clear();
    std::uint64_t at = 0;
    GM_RETURN_IF_ERROR(output.vertices([&](std::span<const format::Vec3f> batch) {
      const std::uint64_t from = std::max(at, first), to = std::min(at + batch.size(), end);
      if (from < to) positions.insert(positions.end(), batch.begin() + (from - at), batch.begin() + (to - at));
      at += batch.size();
      return format::Status();
    }));
    if (positions.size() != end - first) {
      return format::Status::error(format::Code::kProcessing, "output", "the mesh delivered fewer vertices than declared");
    }
    const auto in_run = [&](format::VertexIndex v) { return v >= first && v < end; };
    double area = 0;
    GM_RETURN_IF_ERROR(output.faces([&](std::span<const format::Triangle> batch) {
      inside.clear();
      for (const format::Triangle& t : batch) {
        if (in_run(t.v[0]) && in_run(t.v[1]) && in_run(t.v[2])) {
          inside.push_back({{format::VertexIndex(t.v[0] - first), format::VertexIndex(t.v[1] - first),
                             format::VertexIndex(t.v[2] - first)}});
        }
      }
      area += surface_area(positions, inside);
      return format::Status();
    }));
    auto found = nearest_vertex_values(input, positions, area);
    if (!found) return found.status();
    GM_RETURN_IF_ERROR(into.append(*found));
  }
  return {};
}

}  // namespace gaussmesh::stream
