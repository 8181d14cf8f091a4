// The pipe on standard input copied to an unnamed file (stdin_spool.h).
#include "cli/stdin_spool.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

#include "format/temp_ownership.h"

namespace gaussmesh::cli {
namespace {

constexpr std::size_t kBuffer = std::size_t{1} << 20;

Status output_error(const std::string& where, const char* what) {
  return Status::error(Code::kOutput, where, std::string(what) + ": " + std::strerror(errno));
}

bool write_all(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// Copies `from` to `to` until `from` ends (or `to` is closed: the job stopped reading).
void copy_to_end(int from, int to, std::vector<char>& buffer) {
  for (;;) {
    const ssize_t n = ::read(from, buffer.data(), buffer.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0 || !write_all(to, buffer.data(), static_cast<std::size_t>(n))) return;
  }
}

}  // namespace

Status spool_standard_input(const std::string& tmp_dir, std::uint64_t limit) {
  struct stat st {};
  if (::fstat(STDIN_FILENO, &st) != 0 || !(S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))) return {};
  const std::string dir = format::temp_parent(tmp_dir);
  const int file = format::create_unnamed_file(dir, "gaussmesh-stdin-");
  if (file < 0) return output_error(dir, "cannot make a file to hold standard input");
  std::vector<char> buffer(kBuffer);
  std::uint64_t copied = 0;
  bool ended = false;
  while (copied < limit) {
    const ssize_t n = ::read(STDIN_FILENO, buffer.data(), buffer.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const Status status = Status::error(Code::kBadInput, "<stdin>", std::string("cannot read: ") + std::strerror(errno));
      ::close(file);
      return status;
    }
    if (n == 0) {
      ended = true;
      break;
    }
    if (!write_all(file, buffer.data(), static_cast<std::size_t>(n))) {
      const Status status = output_error(dir, "cannot hold standard input");
      ::close(file);
      return status;
    }
    copied += static_cast<std::uint64_t>(n);
  }
  if (::lseek(file, 0, SEEK_SET) != 0) {
    const Status status = output_error(dir, "cannot read back standard input");
    ::close(file);
    return status;
  }
  if (ended) {
    const bool replaced = ::dup2(file, STDIN_FILENO) == STDIN_FILENO;
    ::close(file);
    return replaced ? Status() : output_error("<stdin>", "cannot replace standard input");
  }
  // Longer than the limit: the job streams it from a new pipe, the copied bytes first.
  int ends[2];
  const int rest = ::dup(STDIN_FILENO);
  if (rest < 0 || ::pipe2(ends, O_CLOEXEC) != 0) {
    const Status status = output_error("<stdin>", "cannot pass standard input on");
    if (rest >= 0) ::close(rest);
    ::close(file);
    return status;
  }
  ::fcntl(ends[1], F_SETPIPE_SZ, static_cast<int>(kBuffer));
  if (::dup2(ends[0], STDIN_FILENO) != STDIN_FILENO) {
    const Status status = output_error("<stdin>", "cannot replace standard input");
    for (int fd : {ends[0], ends[1], rest, file}) ::close(fd);
    return status;
  }
  ::close(ends[0]);
  std::thread([file, rest, to = ends[1], buffer = std::move(buffer)]() mutable {
    // A job that stops reading early makes the writes fail (EPIPE) rather than end the process.
    sigset_t pipe_signal;
    sigemptyset(&pipe_signal);
    sigaddset(&pipe_signal, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_signal, nullptr);
    copy_to_end(file, to, buffer);
    ::close(file);
    copy_to_end(rest, to, buffer);
    ::close(rest);
    ::close(to);
  }).detach();
  return {};
}

}  // namespace gaussmesh::cli
