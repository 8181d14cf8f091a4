// Buffered input: one fixed window, refilled by read(2); memory never depends on the input.
#include "format/byte_source.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace gaussmesh::format {

ByteSource::ByteSource(int fd, bool owns_fd, std::string name)
    : fd_(fd), owns_fd_(owns_fd), name_(std::move(name)) {}

ByteSource::~ByteSource() {
  if (owns_fd_ && fd_ >= 0) ::close(fd_);
}

Result<std::unique_ptr<ByteSource>> ByteSource::open(const std::string& path) {
  if (path == "-") {
    std::unique_ptr<ByteSource> src(new ByteSource(STDIN_FILENO, false, "<stdin>"));
    src->capacity_ = kMaxWindow;
    src->buffer_.reset(new char[src->capacity_]);
    struct stat st {};
    if (::fstat(STDIN_FILENO, &st) == 0 && S_ISREG(st.st_mode)) {
      src->total_size_ = static_cast<uint64_t>(st.st_size);
    }
    return src;
  }
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    return Status::error(Code::kBadInput, path, std::string("cannot open: ") + std::strerror(errno));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    int err = errno;
    ::close(fd);
    return Status::error(Code::kBadInput, path, std::string("cannot stat: ") + std::strerror(err));
  }
  if (S_ISDIR(st.st_mode)) {
    ::close(fd);
    return Status::error(Code::kBadInput, path, "is a directory, not a mesh file");
  }
  std::unique_ptr<ByteSource> src(new ByteSource(fd, true, path));
  if (S_ISREG(st.st_mode)) {
    src->total_size_ = static_cast<uint64_t>(st.st_size);
#ifdef POSIX_FADV_SEQUENTIAL
    ::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
  }
  src->capacity_ = kMaxWindow;
  src->buffer_.reset(new char[src->capacity_]);
  return src;
}

std::unique_ptr<ByteSource> ByteSource::from_memory(std::string_view bytes, std::string name) {
  std::unique_ptr<ByteSource> src(new ByteSource(-1, false, std::move(name)));
  src->capacity_ = bytes.size() > 0 ? bytes.size() : 1;
  src->buffer_.reset(new char[src->capacity_]);
  if (!bytes.empty()) std::memcpy(src->buffer_.get(), bytes.data(), bytes.size());
  src->end_ = bytes.size();
  src->eof_ = true;
  src->total_size_ = bytes.size();
  return src;
}

Status ByteSource::fill() {
  if (eof_) return {};
  if (begin_ > 0) {
    size_t live = end_ - begin_;
    if (live > 0) std::memmove(buffer_.get(), buffer_.get() + begin_, live);
    begin_ = 0;
    end_ = live;
  }
  while (end_ < capacity_) {
    ssize_t got = ::read(fd_, buffer_.get() + end_, capacity_ - end_);
    if (got < 0) {
      if (errno == EINTR) continue;
      return Status::error(Code::kBadInput, at_byte(consumed_ + available()),
                           std::string("read failed: ") + std::strerror(errno));
    }
    if (got == 0) {
      eof_ = true;
      break;
    }
    end_ += static_cast<size_t>(got);
    // A pipe delivers small pieces; return once there is a useful amount.
    if (end_ - begin_ >= (64u << 10)) break;
  }
  return {};
}

Result<size_t> ByteSource::ensure(size_t n) {
  if (n > capacity_) n = capacity_;
  while (available() < n && !eof_) {
    size_t before = available();
    GM_RETURN_IF_ERROR(fill());
    if (available() == before && eof_) break;
  }
  return available();
}

Result<std::optional<std::string_view>> ByteSource::next_line() {
  size_t scanned = 0;
  for (;;) {
    const char* start = cursor();
    const void* nl = std::memchr(start + scanned, '\n', available() - scanned);
    if (nl != nullptr) {
      size_t len = static_cast<const char*>(nl) - start;
      advance(len + 1);
      ++line_;
      if (len > 0 && start[len - 1] == '\r') --len;
      return std::optional<std::string_view>(std::string_view(start, len));
    }
    if (eof_) {
      size_t len = available();
      if (len == 0) return std::optional<std::string_view>();
      advance(len);
      ++line_;
      if (start[len - 1] == '\r') --len;
      return std::optional<std::string_view>(std::string_view(start, len));
    }
    scanned = available();
    if (scanned >= capacity_) {
      return Status::error(Code::kBadInput, name_ + ":" + std::to_string(line_ + 1),
                           "line longer than " + std::to_string(capacity_ >> 20) + " MiB");
    }
    GM_RETURN_IF_ERROR(fill());
  }
}

std::string ByteSource::at_byte(uint64_t offset) const {
  return name_ + ": byte " + std::to_string(offset);
}

std::string ByteSource::at_line() const { return name_ + ":" + std::to_string(line_); }

Status ByteSource::bad_at_byte(std::string message) const {
  return Status::error(Code::kBadInput, at_byte(), std::move(message));
}

Status ByteSource::bad_at_line(std::string message) const {
  return Status::error(Code::kBadInput, at_line(), std::move(message));
}

}  // namespace gaussmesh::format
