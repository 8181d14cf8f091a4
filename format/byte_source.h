// Buffered, forward-only input over a file, standard input or memory, with the position
// bookkeeping (byte offset, line number) that error messages need.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "format/status.h"

namespace gaussmesh::format {

// Fast parsers work on the window [cursor(), cursor() + available()) and advance(); the
// window is refilled by ensure(). The buffer never grows past kMaxWindow, so memory is
// bounded whatever the input.
class ByteSource {
 public:
  static constexpr size_t kMaxWindow = 4u << 20;  // 4 MiB: longest line or record we accept

  // Opens path for reading; "-" is standard input, named "<stdin>" in messages.
  static Result<std::unique_ptr<ByteSource>> open(const std::string& path);
  // Reads from a copy of bytes (tests, in-memory data). name appears in messages.
  static std::unique_ptr<ByteSource> from_memory(std::string_view bytes, std::string name);

  ~ByteSource();
  ByteSource(const ByteSource&) = delete;
  ByteSource& operator=(const ByteSource&) = delete;

  const std::string& name() const { return name_; }
  // Size of a regular file, empty for pipes and terminals.
  std::optional<uint64_t> total_size() const { return total_size_; }

  // Makes at least min(n, kMaxWindow) bytes available unless the input ends first.
  // Returns the number available (less than n only at end of input), or a read error.
  Result<size_t> ensure(size_t n);
  const char* cursor() const { return buffer_.get() + begin_; }
  size_t available() const { return end_ - begin_; }
  // Precondition: n <= available().
  void advance(size_t n) {
    begin_ += n;
    consumed_ += n;
  }
  // True when nothing is buffered and the underlying input is exhausted.
  bool at_end() const { return begin_ == end_ && eof_; }
  // Absolute byte offset of cursor() from the start of the input.
  uint64_t offset() const { return consumed_; }

  // Text mode: the next line without its terminator ("\n" or "\r\n"), or empty optional at
  // end of input. The view is valid until the next call on this source. A line longer than
  // kMaxWindow is an error. line_number() is the 1-based number of the line last returned.
  Result<std::optional<std::string_view>> next_line();
  uint64_t line_number() const { return line_; }

  // "name: byte N" for the current offset (or a given one), "name:LINE" for text formats.
  std::string at_byte() const { return at_byte(consumed_); }
  std::string at_byte(uint64_t offset) const;
  std::string at_line() const;

  // A Status of kind kBadInput located at the current byte offset / line.
  Status bad_at_byte(std::string message) const;
  Status bad_at_line(std::string message) const;

 private:
  ByteSource(int fd, bool owns_fd, std::string name);
  Status fill();

  int fd_ = -1;
  bool owns_fd_ = false;
  std::string name_;
  std::optional<uint64_t> total_size_;
  std::unique_ptr<char[]> buffer_;
  size_t capacity_ = 0;
  size_t begin_ = 0, end_ = 0;
  bool eof_ = false;
  uint64_t consumed_ = 0;
  uint64_t line_ = 0;
};

}  // namespace gaussmesh::format
