// An output's vertex values found in runs, in an unnamed temporary file (vertex_values_file.h).
#include "stream/attributes/vertex_values_file.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <limits>
#include <cstring>
#include <vector>

#include "format/file_io.h"
#include "format/temp_ownership.h"
#include "stream/core/process_memory.h"

namespace gaussmesh::stream {

template <class Record>
UnnamedRecordFile<Record>::~UnnamedRecordFile() {
  if (fd_ >= 0) ::close(fd_);
}

template <class Record>
format::Status UnnamedRecordFile<Record>::create(const std::string& dir) {
  dir_ = dir;
  fd_ = format::create_unnamed_file(dir, "gaussmesh-run-values-");
  if (fd_ < 0) return format::Status::error(format::Code::kOutput, dir, std::string("cannot make a temporary file: ") + std::strerror(errno));
  return {};
}

template <class Record>
format::Status UnnamedRecordFile<Record>::append(std::span<const Record> records) {
  if (!format::write_all(fd_, records.data(), records.size_bytes(), count_ * sizeof(Record))) {
    return format::Status::error(format::Code::kOutput, dir_, std::string("cannot write a temporary file: ") + std::strerror(errno));
  }
  count_ += records.size();
  return {};
}

template <class Record>
format::Status UnnamedRecordFile<Record>::replace(std::uint64_t index, const Record& record) {
  if (index >= count_) return format::Status::error(format::Code::kProcessing, dir_, "replaced past a temporary file's last record");
  if (!format::write_all(fd_, &record, sizeof(Record), index * sizeof(Record))) {
    return format::Status::error(format::Code::kOutput, dir_, std::string("cannot write a temporary file: ") + std::strerror(errno));
  }
  return {};
}

template <class Record>
format::Status UnnamedRecordFile<Record>::read(std::uint64_t first, std::span<Record> out) const {
  if (first > count_ || out.size() > count_ - first) {
    return format::Status::error(format::Code::kProcessing, dir_, "read past a temporary file's last record");
  }
  if (!format::pread_all(fd_, out.data(), out.size_bytes(), first * sizeof(Record))) {
    return format::Status::error(format::Code::kBadInput, dir_, "temporary file is shorter than written");
  }
  return {};
}

template class UnnamedRecordFile<format::VertexAttributes>;
template class UnnamedRecordFile<format::Vec3f>;

format::Result<std::unique_ptr<VertexValuesFile>> VertexValuesFile::create(const std::string& dir) {
  std::unique_ptr<VertexValuesFile> file(new VertexValuesFile);
  GM_RETURN_IF_ERROR(file->file_.create(dir));
  return file;
}

format::Status VertexValuesFile::rewind() {
  at_ = 0;
  return {};
}

format::Status VertexValuesFile::read(std::span<format::VertexAttributes> out) {
  GM_RETURN_IF_ERROR(file_.read(at_, out));
  at_ += out.size();
  return {};
}

format::Result<std::uint64_t> nearest_vertex_values_in_runs(const VertexPassFn& input, const NearVertexPassFn& near,
                                                            format::MeshParts& output, std::uint64_t budget,
                                                            const std::string& dir, VertexValuesFile& into,
                                                            std::uint64_t run) {
  const std::uint64_t total = output.vertex_count();
  UnnamedRecordFile<Vec3f> positions_file;
  GM_RETURN_IF_ERROR(positions_file.create(dir));
  GM_RETURN_IF_ERROR(output.vertices([&](std::span<const Vec3f> batch) { return positions_file.append(batch); }));
  if (positions_file.count() != total) {
    return format::Status::error(format::Code::kProcessing, "output", "the mesh delivered other vertices than declared");
  }
  release_free_memory();
  const std::uint64_t held = current_rss() + kSpillReadingBytes;
  const std::uint64_t fits = budget > held ? (budget - held) / kNearestValuesBytesPerVertex : 0;
  if (fits < std::min(kMinAttributeRun, total)) return std::uint64_t{0};
  run = run > 0 ? std::min(run, fits) : fits;

  std::vector<Vec3f> positions;
  const auto load = [&](std::uint64_t first, std::uint64_t end) {
    positions.resize(end - first);
    return positions_file.read(first, positions);
  };
  // The density: the area of the faces whose corners all lie in the first run, per its vertex.
  double area_per_vertex = 0;
  {
    const std::uint64_t end = std::min(total, run);
    GM_RETURN_IF_ERROR(load(0, end));
    std::vector<Triangle> inside;
    double area = 0;
    GM_RETURN_IF_ERROR(output.faces([&](std::span<const Triangle> batch) {
      inside.clear();
      for (const Triangle& t : batch)
        if (t.v[0] < end && t.v[1] < end && t.v[2] < end) inside.push_back(t);
      area += surface_area(positions, inside);
      return format::Status();
    }));
    area_per_vertex = end > 0 ? area / double(end) : 0;
  }
  // The vertices runs left open: their positions and output indices. Searched when they are half
  // a run, so that the run's positions, the gathered ones and their search stay within a run's
  // share.
  std::vector<Vec3f> open_positions;
  std::vector<std::uint64_t> open_index;
  const auto search_open = [&]() -> format::Status {
    if (open_positions.empty()) return {};
    auto found = nearest_vertex_values(input, open_positions, area_per_vertex * double(open_positions.size()));
    if (!found) return found.status();
    for (std::size_t i = 0; i < open_index.size(); ++i) GM_RETURN_IF_ERROR(into.replace(open_index[i], (*found)[i]));
    open_positions.clear();
    open_index.clear();
    return {};
  };
  std::vector<std::uint32_t> left;
  for (std::uint64_t first = 0; first < total; first += run) {
    const std::uint64_t end = std::min(total, first + run);
    GM_RETURN_IF_ERROR(load(first, end));
    // The first round finds input vertices within a quarter of a cell: those in frames that
    // meet the run's box grown by that much (rounded outwards to floats).
    VertexPassFn first_round = input;
    if (near) {
      const double area = area_per_vertex * double(end - first), r = 1.01 * search_cell(end - first, area) / 4;
      PositionBox box;
      for (const Vec3f& p : positions) box.add(p);
      const auto out = [r](float x, float sign) {
        return std::nextafter(float(double(x) + sign * r), sign * std::numeric_limits<float>::infinity());
      };
      box.lo = {out(box.lo.x, -1), out(box.lo.y, -1), out(box.lo.z, -1)};
      box.hi = {out(box.hi.x, 1), out(box.hi.y, 1), out(box.hi.z, 1)};
      first_round = [&near, box](const VertexBatchFn& batch) { return near(box, batch); };
    }
    auto found = nearest_vertex_values(first_round, positions, area_per_vertex * double(end - first), &left);
    if (!found) return found.status();
    GM_RETURN_IF_ERROR(into.append(*found));
    for (const std::uint32_t v : left) {
      open_positions.push_back(positions[v]);
      open_index.push_back(first + v);
      if (2 * open_positions.size() >= run) GM_RETURN_IF_ERROR(search_open());
    }
  }
  GM_RETURN_IF_ERROR(search_open());
  return (total + run - 1) / run;
}

}  // namespace gaussmesh::stream
