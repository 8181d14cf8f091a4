// Temporary files and directories that a killed run (SIGKILL, the OOM killer, a power cut)
// leaves behind, and how a later run finds them. Their owner holds an exclusive flock(2) on each
// for as long as it lives; the kernel drops the lock when the process dies, however it dies, and
// the lock works across PID namespaces (containers sharing a --tmp), where a pid check would not.
// An entry nobody holds is a dead run's. Entries are made under a name no scan matches and renamed
// once locked, so a scan never takes a live run's entry in the moment before its lock.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "format/status.h"

namespace gaussmesh::format {

// The lock on one temporary entry: a descriptor kept open; closing it releases the lock.
class TempOwnership {
 public:
  TempOwnership() = default;
  explicit TempOwnership(int fd) : fd_(fd) {}
  ~TempOwnership();
  TempOwnership(TempOwnership&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  TempOwnership& operator=(TempOwnership&& other) noexcept;
  TempOwnership(const TempOwnership&) = delete;
  TempOwnership& operator=(const TempOwnership&) = delete;
  int fd() const { return fd_; }
  // Hands the descriptor (and with it the lock) to the caller, who closes it.
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_ = -1;
};

// Creates the directory parent/prefix + six random characters, locked, and sets path to it.
// Errors (kOutput) name parent.
Result<TempOwnership> create_owned_directory(const std::string& parent, const std::string& prefix, std::string& path);

// Creates the empty file path, locked and open for writing (the returned lock's descriptor).
// Errors are kOutput with the system's reason as the message; a path that exists already sets
// exists, so that a caller can pick another name.
Result<TempOwnership> create_owned_file(const std::string& path, bool& exists);

// The directory temporary files go in: dir, else $TMPDIR, else /tmp.
std::string temp_parent(const std::string& dir);

// A file open for reading and writing in dir that no path names, so that nothing is left behind
// however the run ends: O_TMPFILE where the file system has it, else a file named prefix + six
// random characters, unlinked at once. -1 with errno set when neither can be made.
int create_unnamed_file(const std::string& dir, const std::string& prefix);

// Removes the files and directories in dir whose names start with prefix that no live process
// holds. Best effort: what cannot be opened, locked or removed (another user's, another cleaner's)
// is left. Returns how many entries went.
std::size_t remove_dead_runs_temps(const std::string& dir, std::string_view prefix);

}  // namespace gaussmesh::format
