// Write-then-rename output files and guarded standard output.
#include "format/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

#include "format/temp_ownership.h"
#include "format/temp_registry.h"

namespace gaussmesh::format {
namespace {

constexpr size_t kBufferSize = 1u << 20;

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

Result<std::unique_ptr<OutputFile>> OutputFile::create(const std::string& path, bool binary) {
  std::unique_ptr<OutputFile> out(new OutputFile());
  out->buffer_.reset(new char[kBufferSize]);
  if (path == "-") {
    if (binary && ::isatty(STDOUT_FILENO)) {
      return Status::error(Code::kUsage, "<stdout>",
                           "refusing to write binary output to a terminal (redirect it, or use -o FILE)");
    }
    out->fd_ = STDOUT_FILENO;
    out->display_ = "<stdout>";
    return out;
  }
  out->target_ = path;
  out->display_ = path;
  std::string dir = ".";
  std::string base = path;
  if (auto slash = path.rfind('/'); slash != std::string::npos) {
    dir = slash == 0 ? "/" : path.substr(0, slash);
    base = path.substr(slash + 1);
  }
  if (base.empty()) return Status::error(Code::kUsage, path, "output path names a directory");
  // A device or a pipe (-o /dev/null, a named FIFO) is written in place: renaming a file onto it
  // would replace it.
  struct stat target {};
  if (::stat(path.c_str(), &target) == 0 && !S_ISREG(target.st_mode)) {
    if (S_ISDIR(target.st_mode)) return Status::error(Code::kUsage, path, "output path names a directory");
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return Status::error(Code::kOutput, path, "cannot open output: " + errno_text(errno));
    out->fd_ = fd;
    out->in_place_ = true;
    return out;
  }
  // A run killed while writing this output left its temporary file: it goes now. (Locked names say
  // "gaussmesh-run"; an unlocked one of a version that took no lock is left alone.)
  const std::string temp_prefix = "." + base + ".gaussmesh-run-";
  remove_dead_runs_temps(dir, temp_prefix);
  std::random_device rd;
  for (int attempt = 0; attempt < 16; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "%d-%08x", static_cast<int>(::getpid()), rd());
    std::string temp = dir + "/" + temp_prefix + suffix + ".tmp";
    int slot = register_temp_path(temp, false);
    bool exists = false;
    Result<TempOwnership> owned = create_owned_file(temp, exists);
    if (owned.is_ok()) {
      out->fd_ = owned->release();  // held until commit or destruction: the lock says a live run owns it
      out->temp_ = temp;
      out->slot_ = slot;
      return out;
    }
    unregister_temp_path(slot);
    if (!exists) {
      return Status::error(Code::kOutput, path, "cannot create output: " + owned.status().message());
    }
  }
  return Status::error(Code::kOutput, path, "cannot create a unique temporary file beside the output");
}

OutputFile::~OutputFile() {
  if (in_place_ && fd_ >= 0) ::close(fd_);
  if (!temp_.empty()) {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(temp_.c_str());
    unregister_temp_path(slot_);
  }
}

Status OutputFile::flush() {
  size_t done = 0;
  while (done < used_) {
    ssize_t put = ::write(fd_, buffer_.get() + done, used_ - done);
    if (put < 0) {
      if (errno == EINTR) continue;
      failed_ = true;
      return Status::error(Code::kOutput, display_, "write failed: " + errno_text(errno));
    }
    done += static_cast<size_t>(put);
  }
  used_ = 0;
  return {};
}

Status OutputFile::write(const void* data, size_t size) {
  if (failed_) return Status::error(Code::kOutput, display_, "write after an earlier failure");
  const char* bytes = static_cast<const char*>(data);
  total_ += size;
  while (size > 0) {
    if (used_ == kBufferSize) GM_RETURN_IF_ERROR(flush());
    size_t take = std::min(size, kBufferSize - used_);
    std::memcpy(buffer_.get() + used_, bytes, take);
    used_ += take;
    bytes += take;
    size -= take;
  }
  return {};
}

Status OutputFile::commit() {
  if (committed_) return {};
  GM_RETURN_IF_ERROR(flush());
  if (temp_.empty()) {
    committed_ = true;
    return {};
  }
  // Regular files take the usual permissions (umask applied by open); fsync before the rename
  // so a crash cannot leave a renamed but empty file.
  if (::fsync(fd_) != 0 && errno != EINVAL) {
    failed_ = true;
    return Status::error(Code::kOutput, display_, "fsync failed: " + errno_text(errno));
  }
  if (::close(fd_) != 0) {
    fd_ = -1;
    failed_ = true;
    return Status::error(Code::kOutput, display_, "close failed: " + errno_text(errno));
  }
  fd_ = -1;
  if (::rename(temp_.c_str(), target_.c_str()) != 0) {
    failed_ = true;
    return Status::error(Code::kOutput, display_, "cannot rename into place: " + errno_text(errno));
  }
  committed_ = true;
  return {};
}

}  // namespace gaussmesh::format
