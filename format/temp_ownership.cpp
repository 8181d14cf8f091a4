// Locked temporary entries and the removal of dead runs' ones (temp_ownership.h).
#include "format/temp_ownership.h"

#include <dirent.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace gaussmesh::format {
namespace {

// The suffix of a file's name before it is locked, which scans pass over (a directory's name
// starts with "creating-" instead: mkdtemp wants its random part last).
constexpr std::string_view kCreating = ".creating";

bool lock(int fd) { return ::flock(fd, LOCK_EX | LOCK_NB) == 0; }

// rename(2) that fails with EEXIST rather than replace an existing target. A file system without
// RENAME_NOREPLACE gets a check first, which is racy only against another run choosing the same
// random name.
int rename_no_replace(const std::string& from, const std::string& to) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) return 0;
  if (errno != EINVAL && errno != ENOSYS) return -1;
  if (::access(to.c_str(), F_OK) == 0) {
    errno = EEXIST;
    return -1;
  }
  return ::rename(from.c_str(), to.c_str());
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

TempOwnership::~TempOwnership() {
  if (fd_ >= 0) ::close(fd_);
}

TempOwnership& TempOwnership::operator=(TempOwnership&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

Result<TempOwnership> create_owned_directory(const std::string& parent, const std::string& prefix, std::string& path) {
  for (int attempt = 0; attempt < 16; ++attempt) {
    // Made under a name that does not start with the prefix, locked, then given its own name.
    std::string hidden = parent + "/" + std::string(kCreating.substr(1)) + "-" + prefix + "XXXXXX";
    if (::mkdtemp(hidden.data()) == nullptr) {
      return Status::error(Code::kOutput, parent, "cannot create a temporary directory: " + errno_text());
    }
    TempOwnership owned(::open(hidden.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (owned.fd() < 0 || !lock(owned.fd())) {
      const std::string why = errno_text();
      ::rmdir(hidden.c_str());
      return Status::error(Code::kOutput, parent, "cannot lock a temporary directory: " + why);
    }
    const std::string named = parent + "/" + prefix + hidden.substr(hidden.size() - 6);
    if (rename_no_replace(hidden, named) == 0) {
      path = named;
      return owned;
    }
    const int err = errno;
    ::rmdir(hidden.c_str());
    if (err != EEXIST) return Status::error(Code::kOutput, parent, "cannot create a temporary directory: " + std::string(std::strerror(err)));
  }
  return Status::error(Code::kOutput, parent, "cannot create a unique temporary directory");
}

Result<TempOwnership> create_owned_file(const std::string& path, bool& exists) {
  exists = false;
  const std::string hidden = path + std::string(kCreating);
  TempOwnership owned(::open(hidden.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
  if (owned.fd() < 0) {
    exists = errno == EEXIST;
    return Status::error(Code::kOutput, path, errno_text());
  }
  if (!lock(owned.fd())) {
    ::unlink(hidden.c_str());
    return Status::error(Code::kOutput, path, "cannot lock it: " + errno_text());
  }
  if (rename_no_replace(hidden, path) != 0) {
    exists = errno == EEXIST;
    const std::string why = errno_text();
    ::unlink(hidden.c_str());
    return Status::error(Code::kOutput, path, why);
  }
  return owned;
}

std::size_t remove_dead_runs_temps(const std::string& dir, std::string_view prefix) {
  DIR* listing = ::opendir(dir.c_str());
  if (listing == nullptr) return 0;
  std::size_t removed = 0;
  while (const dirent* entry = ::readdir(listing)) {
    const std::string_view name = entry->d_name;
    if (!name.starts_with(prefix) || name.ends_with(kCreating)) continue;
    const std::string path = dir + "/" + std::string(name);
    // O_NOFOLLOW: a symlink planted under a matching name is not followed, and not removed.
    TempOwnership probe(::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK));
    if (probe.fd() < 0 || !lock(probe.fd())) continue;  // unreadable, or a live run's
    std::error_code ec;
    if (std::filesystem::remove_all(path, ec) > 0 && !ec) ++removed;
  }
  ::closedir(listing);
  return removed;
}

std::string temp_parent(const std::string& dir) {
  if (!dir.empty()) return dir;
  const char* env = std::getenv("TMPDIR");
  return env != nullptr && *env != '\0' ? env : "/tmp";
}

int create_unnamed_file(const std::string& dir, const std::string& prefix) {
  const int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
  std::string path = dir + "/" + prefix + "XXXXXX";
  const int named = ::mkostemp(path.data(), O_CLOEXEC);
  if (named >= 0) ::unlink(path.c_str());
  return named;
}

}  // namespace gaussmesh::format
