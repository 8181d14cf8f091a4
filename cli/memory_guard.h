// The command's guard on an explicit --memory: a thread that reads the process's peak resident
// memory every few milliseconds and ends the run when it passes what the budget allows, so that an input
// the passes cannot keep within the budget (docs/pipeline.md, "Memory") is refused with exit 5
// and one line instead of running on far past it or being killed by the OOM killer.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "gaussmesh/gaussmesh.h"

namespace gaussmesh::cli {

// What a run under `budget` bytes may hold resident: a quarter more for what the passes do not
// count (the allocator's slack, buffers in flight), and 32 MiB for the process itself (code,
// libraries, thread stacks), which the smallest budgets do not cover.
std::uint64_t guarded_limit(std::uint64_t budget);

// The budget the guard holds a run to: the explicit --memory, except under --engine in-core (the
// budget is a contract on the streaming engine; a forced in-core run holds the whole mesh), and
// 0 (none) under --memory auto.
std::uint64_t guarded_budget(const ResourceOptions& resources);

class MemoryGuard {
 public:
  // Starts the thread; budget 0 (--memory auto) starts nothing, nor does a build with
  // AddressSanitizer, whose resident memory is mostly its own (memory_guard.cpp).
  explicit MemoryGuard(std::uint64_t budget);
  ~MemoryGuard();
  MemoryGuard(const MemoryGuard&) = delete;
  MemoryGuard& operator=(const MemoryGuard&) = delete;
  // `progress` with the pass noted first (the line names it): the callback to hand the run.
  ProgressFn noting_pass(ProgressFn progress);

 private:
  void set_pass(const char* pass);
  void watch();

  std::uint64_t budget_ = 0, limit_ = 0;
  std::mutex mutex_;  // guards pass_ and stopping_
  char pass_[32] = {};
  std::condition_variable stop_;
  bool stopping_ = false;
  std::thread thread_;  // last: starts once the rest is built
};

}  // namespace gaussmesh::cli
