// libFuzzer target: the whole in-core simplify of the public API on small meshes made from the
// fuzz bytes, with and without a target, its output checked by simplify_check.h (which gives
// the byte layout). Seeds: small closed shapes in that layout, from scripts/fuzz-seeds.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz/fuzz_abort.h"
#include "fuzz/simplify_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  gaussmesh::fuzz::abort_if_broken(gaussmesh::fuzz::check_simplify(bytes));
  return 0;
}
