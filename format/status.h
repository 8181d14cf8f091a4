// Error values that every layer returns upward; only cli/ prints them and picks the exit code.
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace gaussmesh::format {

// Failure classes. The numeric value is the process exit code the CLI uses (docs/cli.md).
enum class Code : int {
  kOk = 0,
  kUsage = 1,       // bad command line
  kBadInput = 2,    // unreadable, malformed, truncated or hostile input
  kProcessing = 3,  // the algorithm could not produce a valid result
  kOutput = 4,      // output or temporary file could not be written (disk full, permissions)
  kResources = 5,   // a limit was hit: memory budget, index range, interrupted
};

// An expected failure: a code, where it happened (file and byte offset or line, chunk, ...)
// and what went wrong. Default-constructed Status is success.
class [[nodiscard]] Status {
 public:
  Status() = default;
  static Status error(Code code, std::string where, std::string message) {
    Status s;
    s.code_ = code;
    s.where_ = std::move(where);
    s.message_ = std::move(message);
    return s;
  }
  bool is_ok() const { return code_ == Code::kOk; }
  explicit operator bool() const { return is_ok(); }
  Code code() const { return code_; }
  const std::string& where() const { return where_; }
  const std::string& message() const { return message_; }
  // "where: message" on one line (or just the message when where is empty).
  std::string to_string() const;

 private:
  Code code_ = Code::kOk;
  std::string where_;
  std::string message_;
};

// A value or the Status that explains why there is none.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design
  bool is_ok() const { return value_.has_value(); }
  explicit operator bool() const { return is_ok(); }
  const Status& status() const { return status_; }
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() { return *value_; }

 private:
  std::optional<T> value_;
  Status status_;
};

}  // namespace gaussmesh::format

// Propagates a failed Status from an expression that yields one.
#define GM_RETURN_IF_ERROR(expr)                  \
  do {                                            \
    ::gaussmesh::format::Status gm_status_ = (expr); \
    if (!gm_status_.is_ok()) return gm_status_;   \
  } while (0)
