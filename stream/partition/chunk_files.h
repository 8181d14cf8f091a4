// The chunk face record files' names, and the thread that creates them ahead of the final scan.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

namespace gaussmesh::stream::detail {

inline std::string chunk_file_path(const std::string& dir, std::uint32_t chunk) {
  char name[32];
  std::snprintf(name, sizeof name, "/chunk-%06u.gmr", chunk);
  return dir + name;
}

// Creates the chunk files, empty, on a thread of its own while the ring rounds run: a create
// allocates an inode (a fraction of a millisecond on ext4), which the final scan's thread would
// otherwise pay once per chunk. The writers open them with O_TRUNC later; a create that fails
// here is left to the writer to report.
class ChunkFileMaker {
 public:
  ChunkFileMaker(const std::string& dir, std::uint32_t chunks, bool background) {
    if (!background) return;
    thread_ = std::thread([this, dir, chunks] {
      char path[4096];
      for (std::uint32_t c = 0; c < chunks && !stop_.load(std::memory_order_relaxed); ++c) {
        // No allocation on this thread (an exception here would end the process).
        if (std::snprintf(path, sizeof path, "%s/chunk-%06u.gmr", dir.c_str(), c) >= int(sizeof path)) return;
        const int fd = ::open(path, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
        if (fd >= 0) ::close(fd);
      }
    });
  }
  ~ChunkFileMaker() { finish(true); }
  ChunkFileMaker(const ChunkFileMaker&) = delete;
  ChunkFileMaker& operator=(const ChunkFileMaker&) = delete;
  // Waits for the thread (stopping it first when `stop`).
  void finish(bool stop = false) {
    if (!thread_.joinable()) return;
    if (stop) stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace gaussmesh::stream::detail
