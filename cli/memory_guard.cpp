// The resident-memory guard of an explicit --memory (memory_guard.h).
#include "cli/memory_guard.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::cli {
namespace {

// Under AddressSanitizer (the sanitized test stage, docs/design.md "Tests") the resident set is
// mostly the sanitizer's own: shadow memory, redzones and the quarantine of freed blocks put the
// command past the limit of a 16 MiB budget before it has read its input. The guard would then
// end runs for memory that is not the passes', so it is not started there; the budget's checks
// before a pass (a Draco decode, the STL weld) still refuse as they do in any build.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kResidentIsOurs = false;
#else
constexpr bool kResidentIsOurs = true;
#endif

}  // namespace

std::uint64_t guarded_limit(std::uint64_t budget) { return budget + budget / 4 + (std::uint64_t{32} << 20); }

std::uint64_t guarded_budget(const ResourceOptions& resources) {
  return resources.engine == Engine::kInCore ? 0 : resources.memory_bytes;
}

MemoryGuard::MemoryGuard(std::uint64_t budget) : budget_(budget), limit_(guarded_limit(budget)) {
  if (budget_ > 0 && kResidentIsOurs) thread_ = std::thread([this] { watch(); });
}

MemoryGuard::~MemoryGuard() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  stop_.notify_all();
  thread_.join();
}

void MemoryGuard::set_pass(const char* pass) {
  if (!thread_.joinable()) return;
  std::lock_guard lock(mutex_);
  std::snprintf(pass_, sizeof pass_, "%s", pass);
}

ProgressFn MemoryGuard::noting_pass(ProgressFn progress) {
  return [this, progress = std::move(progress)](const char* pass, std::uint64_t done, std::uint64_t total,
                                                 std::uint64_t triangles) {
    set_pass(pass);
    progress(pass, done, total, triangles);
  };
}

void MemoryGuard::watch() {
  std::unique_lock lock(mutex_);
  while (!stop_.wait_for(lock, std::chrono::milliseconds(10), [this] { return stopping_; })) {
    // The peak since exec (stream::peak_rss) includes the current resident set.
    const std::uint64_t resident = peak_rss_bytes();
    if (resident <= limit_) continue;
    const char* pass = pass_[0] != '\0' ? pass_ : nullptr;
    // Standard error stays locked until the exit: a pass that fails on the files removed below
    // would otherwise print a second line.
    ::flockfile(stderr);
    std::fprintf(stderr,
                 "gaussmesh: --memory: %llu MiB resident%s%s%s, past the budget of %llu MiB (a run may pass it by a quarter "
                 "and 32 MiB): this input needs more memory than the passes can keep within it; raise --memory\n",
                 static_cast<unsigned long long>(resident >> 20), pass ? " in the " : "", pass ? pass : "", pass ? " pass" : "",
                 static_cast<unsigned long long>(budget_ >> 20));
    remove_temporary_files();
    std::_Exit(5);  // Code::kResources, as every refusal of the budget
  }
}

}  // namespace gaussmesh::cli
