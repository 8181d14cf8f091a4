// Reading vertex positions back from the input file itself, when its vertices are fixed-size
// float records (VertexFiles::input): opening it again, checked unchanged, and decoding a record.
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/partition/chunk_partition.h"
#include "stream/partition/posix_io.h"

namespace gaussmesh::stream::detail {

using format::Code;
using format::Result;
using format::Status;
using format::Vec3f;

inline std::int64_t modified_ns(const struct stat& st) {
  return static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

// Opens the input to read its vertex records back; kBadInput when it is gone, or its size or
// modification time is not what the ingest saw.
inline Result<int> open_input_positions(const VertexFiles::InputPositions& in) {
  const int fd = ::open(in.path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::error(Code::kBadInput, in.path, "cannot open the input again to read its positions: " + errno_text());
  struct stat st{};
  if (::fstat(fd, &st) != 0 || static_cast<std::uint64_t>(st.st_size) != in.size || modified_ns(st) != in.modified_ns) {
    ::close(fd);
    return Status::error(Code::kBadInput, in.path, "the input changed during the run");
  }
  return fd;
}

// A position from one of the input's vertex records.
inline Vec3f input_position(const VertexFiles::InputPositions& in, const std::byte* record) {
  float c[3];
  for (int a = 0; a < 3; ++a) std::memcpy(&c[a], record + in.xyz[a], 4);
  return {c[0], c[1], c[2]};
}

}  // namespace gaussmesh::stream::detail
