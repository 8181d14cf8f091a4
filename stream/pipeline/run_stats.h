// The figures of a pipeline run, taken in one place: each pass's seconds, the seconds of the
// steps inside a pass, and the process's peak RSS after a pass or step.
#pragma once

#include <cstdint>

#include "stream/core/process_memory.h"
#include "stream/core/stopwatch.h"

namespace gaussmesh::stream {

// Times passes and their steps: a pass begins, steps end one after another (each the next one's
// start), and the pass ends. Where peak_rss_after is given, it gets the process's peak RSS
// (getrusage) as the pass or step ends, to tell which one sets the peak.
class RunStats {
 public:
  RunStats() { begin_pass(); }

  // A pass, and its first step, begin now.
  void begin_pass() { pass_ = step_ = Clock::now(); }

  // Seconds since the step began; the next step begins now.
  double end_step(std::uint64_t* peak_rss_after = nullptr) {
    const auto now = Clock::now();
    const double seconds = std::chrono::duration<double>(now - step_).count();
    step_ = now;
    if (peak_rss_after) *peak_rss_after = peak_rss();
    return seconds;
  }

  // Seconds since the pass began.
  double end_pass(std::uint64_t* peak_rss_after = nullptr) const {
    const double seconds = seconds_since(pass_);
    if (peak_rss_after) *peak_rss_after = peak_rss();
    return seconds;
  }

 private:
  Clock::time_point pass_, step_;
};

}  // namespace gaussmesh::stream
