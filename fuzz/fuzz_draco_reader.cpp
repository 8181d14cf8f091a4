// libFuzzer target: the Draco reader (decoded whole once its header's counts fit the limit) on
// arbitrary bytes, forced (no detection), checked against the reader contract by checking_sink.h.
// Seeds: fixtures/ and small files from scripts/fuzz.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz/checking_sink.h"
#include "fuzz/fuzz_abort.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  gaussmesh::fuzz::abort_if_broken(gaussmesh::fuzz::read_and_check(bytes, gaussmesh::format::MeshFormat::kDraco).broken);
  return 0;
}
