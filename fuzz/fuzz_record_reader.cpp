// libFuzzer target: the record-file decoder (format/record_file.h, docs/records.md) on
// arbitrary bytes as a whole record file, checked by record_check.h. Seeds: record files of both
// layouts written by make_record_seeds.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/fuzz_abort.h"
#include "fuzz/record_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The reader takes a path: an in-memory file, reached through /proc, keeps the disk out of it.
  static const int fd = ::memfd_create("gaussmesh-fuzz-record", MFD_CLOEXEC);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ::ftruncate(fd, 0) != 0 || ::pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) {
    gaussmesh::fuzz::abort_if_broken("cannot write the in-memory file");
  }
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  gaussmesh::fuzz::abort_if_broken(gaussmesh::fuzz::check_record_file(path, bytes.substr(0, 20)));
  return 0;
}
