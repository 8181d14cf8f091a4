// The background writer of the spills: the ingest pass's positions and faces (and the owner pass's
// owners.bin) written on a thread of their own while the caller goes on.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/thread_status.h"
#include "stream/partition/face_spill.h"
#include "stream/partition/spill_writer.h"

namespace gaussmesh::stream::detail {

using format::Status;
using format::Triangle;
using format::Vec3f;

// Writes the ingest's two spills, on a thread of its own when `background` (the run has
// --threads > 1): the kernel's copy of the positions into the page cache (on one thread, about
// half the ingest's time) and the face spill's compression then run beside the reader's
// parsing. Each batch is copied into one of at most kInFlight buffers (the
// reader's batch is only valid during its call); one consumer keeps each file in order.
class SpillThread {
 public:
  SpillThread(SpillWriter& positions, FaceSpill& faces, bool background) : positions_(positions), faces_(faces) {
    if (background) {
      free_.reserve(kInFlight);  // run() hands buffers back without allocating
      thread_ = std::thread([this] { run(); });
    }
  }
  ~SpillThread() { stop(); }
  SpillThread(const SpillThread&) = delete;
  SpillThread& operator=(const SpillThread&) = delete;

  Status vertices(std::span<const Vec3f> batch) { return put(false, std::as_bytes(batch)); }
  // Bytes for the first writer (the owner pass's owners.bin).
  Status bytes(std::span<const std::byte> bytes) { return put(false, bytes); }
  Status triangles(std::span<const Triangle> batch) { return put(true, std::as_bytes(batch)); }
  // Waits until everything handed over is written; the first write error.
  Status finish() {
    stop();
    return status_;
  }

 private:
  static constexpr std::size_t kInFlight = 4;
  struct Item {
    bool faces = false;
    std::vector<std::byte> bytes;
  };
  Status write(bool faces, std::span<const std::byte> bytes) {
    if (faces) {
      return faces_.write({reinterpret_cast<const Triangle*>(bytes.data()), bytes.size() / sizeof(Triangle)});
    }
    return positions_.write(bytes.data(), bytes.size());
  }
  Status put(bool faces, std::span<const std::byte> bytes) {
    if (!thread_.joinable()) return status_.is_ok() ? (status_ = write(faces, bytes)) : status_;
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return pending_.size() < kInFlight || !status_.is_ok(); });
    if (!status_.is_ok()) return status_;
    Item item{faces, {}};
    if (!free_.empty()) {
      item.bytes = std::move(free_.back());
      free_.pop_back();
    }
    item.bytes.assign(bytes.begin(), bytes.end());
    pending_.push_back(std::move(item));
    changed_.notify_all();
    return {};
  }
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      changed_.wait(lock, [&] { return !pending_.empty() || stopping_; });
      if (pending_.empty()) return;  // stopping, and everything is written
      Item item = std::move(pending_.front());
      pending_.pop_front();
      const bool write_it = status_.is_ok();
      lock.unlock();
      Status status = write_it ? status_of_work("ingest", [&] { return write(item.faces, item.bytes); }) : Status{};
      lock.lock();
      if (!status.is_ok() && status_.is_ok()) status_ = status;
      free_.push_back(std::move(item.bytes));
      changed_.notify_all();
    }
  }
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }

  SpillWriter& positions_;
  FaceSpill& faces_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Item> pending_;
  std::vector<std::vector<std::byte>> free_;
  Status status_;  // the first write error (under mutex_ with a thread)
  bool stopping_ = false;
  std::thread thread_;  // last: starts once the rest is built (none without `background`)
};

}  // namespace gaussmesh::stream::detail
