// Signal-time cleanup of temporary files and directories. Everything the handler touches is
// preallocated and every call it makes is async-signal-safe (open, getdents64, unlinkat, rename,
// rmdir; strlen and memcpy on its own buffers).
#include "format/temp_registry.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>

namespace gaussmesh::format {
namespace {

constexpr int kSlots = 64;
constexpr size_t kPathMax = 4096;

struct Slot {
  std::atomic<int> state{0};  // 0 free, 1 filling, 2 file, 3 directory
  char path[kPathMax];
};

Slot g_slots[kSlots];
std::mutex g_mutex;
char g_dirent_buffer[8192];

// Layout of struct linux_dirent64 (getdents64(2)): the name starts at byte 19.
constexpr size_t kDirentReclenOffset = 16;
constexpr size_t kDirentNameOffset = 19;

void remove_directory_contents(const char* path) {
  int dir = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return;
  for (;;) {
    long got = ::syscall(SYS_getdents64, dir, g_dirent_buffer, sizeof g_dirent_buffer);
    if (got <= 0) break;
    for (long pos = 0; pos < got;) {
      const char* entry = g_dirent_buffer + pos;
      unsigned short reclen;
      std::memcpy(&reclen, entry + kDirentReclenOffset, sizeof reclen);
      const char* name = entry + kDirentNameOffset;
      pos += reclen;
      if (std::strcmp(name, ".") == 0 || std::strcmp(name, "..") == 0) continue;
      ::unlinkat(dir, name, 0);
    }
  }
  ::close(dir);
}

// The signal arrives while other threads of the run keep working, and they create files (a
// chunk pass spills a record file per chunk): one listing can miss a file made after it, and the
// directory stays. So the directory is renamed first — creating a file by its old path fails
// from then on — then emptied and removed, again while files made during the rename remain.
char g_dying_path[kPathMax + 8];
void remove_directory(const char* path) {
  const std::size_t n = std::strlen(path);
  if (n + sizeof ".dying" <= sizeof g_dying_path) {
    std::memcpy(g_dying_path, path, n);
    std::memcpy(g_dying_path + n, ".dying", sizeof ".dying");
    if (::rename(path, g_dying_path) == 0) path = g_dying_path;
  }
  for (int attempt = 0; attempt < 100; ++attempt) {
    remove_directory_contents(path);
    if (::rmdir(path) == 0 || errno != ENOTEMPTY) break;
  }
}

void remove_all_registered() {
  const int saved_errno = errno;
  for (Slot& slot : g_slots) {
    int state = slot.state.load();
    if (state == 2) {
      ::unlink(slot.path);
    } else if (state == 3) {
      remove_directory(slot.path);
    }
  }
  errno = saved_errno;
}

void on_signal(int sig) {
  remove_all_registered();
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

}  // namespace

void install_signal_cleanup() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) ::sigaction(sig, &action, nullptr);
}

void remove_registered_temp_paths() { remove_all_registered(); }

int register_temp_path(const std::string& path, bool is_directory) {
  if (path.size() + 1 > kPathMax) return -1;
  std::lock_guard<std::mutex> lock(g_mutex);
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_slots[i].state.compare_exchange_strong(expected, 1)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(is_directory ? 3 : 2);
      return i;
    }
  }
  return -1;
}

void unregister_temp_path(int slot) {
  if (slot < 0 || slot >= kSlots) return;
  g_slots[slot].state.store(0);
}

}  // namespace gaussmesh::format
