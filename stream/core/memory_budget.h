// The working-set budget of an out-of-core run (--memory): one value that every pass draws its
// share from, so that each share is stated where it is taken and the shares can be added up.
#pragma once

#include <algorithm>
#include <cstdint>

namespace gaussmesh::stream {

class MemoryBudget {
 public:
  MemoryBudget() = default;  // unlimited: no pass checks its resident set
  explicit MemoryBudget(std::uint64_t bytes) : bytes_(bytes) {}

  std::uint64_t bytes() const { return bytes_; }
  bool is_limited() const { return bytes_ != 0; }

  // num/den of the whole budget (den > 0).
  std::uint64_t fraction(std::uint64_t num, std::uint64_t den) const { return bytes_ / den * num; }
  // What is left for a pass's data once `reserve` bytes (the process itself, a reader window) are
  // set aside; half the budget when the reserve would take more than half of it.
  std::uint64_t after_reserve(std::uint64_t reserve) const {
    return bytes_ > 2 * reserve ? bytes_ - reserve : bytes_ / 2;
  }
  // An even share for each of `parts` users in flight (threads, open files); parts 0 counts as 1.
  std::uint64_t per_part(std::uint64_t parts) const { return bytes_ / std::max<std::uint64_t>(parts, 1); }
  // A budget of `bytes` for a sub-step, to pass down as a whole.
  static MemoryBudget of(std::uint64_t bytes) { return MemoryBudget(bytes); }

 private:
  std::uint64_t bytes_ = 0;
};

}  // namespace gaussmesh::stream
