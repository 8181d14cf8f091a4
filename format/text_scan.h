// Line and number scanning shared by the text readers (OFF, OBJ, ascii STL): no allocation,
// no locale, std::from_chars underneath. Internal to format/.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

#include "format/byte_source.h"

namespace gaussmesh::format::text {

inline bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// Why a number could not be read; kOk when it could.
enum class NumberError { kOk, kMissing, kMalformed, kOutOfRange, kNotFinite };

// A forward cursor over one line. The line must outlive the scanner.
class LineScanner {
 public:
  explicit LineScanner(std::string_view line) : p_(line.data()), end_(line.data() + line.size()) {}

  void skip_space() {
    while (p_ != end_ && is_space(*p_)) ++p_;
  }
  // True when only whitespace is left.
  bool at_end() {
    skip_space();
    return p_ == end_;
  }
  // The next whitespace-delimited token (empty at the end of the line), consumed.
  std::string_view token() {
    skip_space();
    const char* start = p_;
    while (p_ != end_ && !is_space(*p_)) ++p_;
    return {start, static_cast<size_t>(p_ - start)};
  }
  // The next token without consuming it.
  std::string_view peek_token() {
    const char* saved = p_;
    std::string_view t = token();
    p_ = saved;
    return t;
  }
  // What is left of the line, leading whitespace skipped.
  std::string_view rest() {
    skip_space();
    return {p_, static_cast<size_t>(end_ - p_)};
  }

  // A finite float that must end at whitespace or the end of the line. Values beyond float
  // range are kOutOfRange; values below it round to zero or a subnormal.
  NumberError read_float(float& out) {
    std::string_view t = token();
    if (t.empty()) return NumberError::kMissing;
    last_ = t;
    return parse_float(t, out);
  }
  // A non-negative decimal integer that must end at whitespace or the end of the line.
  NumberError read_uint(uint64_t& out) {
    std::string_view t = token();
    if (t.empty()) return NumberError::kMissing;
    last_ = t;
    const char* b = t.data();
    const char* e = b + t.size();
    if (*b == '+') ++b;
    const char* ptr = b;
    NumberError error = parse_digits(ptr, e, out);
    if (error != NumberError::kOk) return error;
    return ptr == e ? NumberError::kOk : NumberError::kMalformed;
  }
  // A signed decimal integer at the cursor that may be followed by a non-space character
  // (OBJ's "7/2/3"); the cursor stops right after the digits.
  NumberError read_int_prefix(int64_t& out) {
    skip_space();
    if (p_ == end_) return NumberError::kMissing;
    const char* ptr = p_;
    bool negative = *ptr == '-';
    if (negative || *ptr == '+') ++ptr;
    uint64_t magnitude = 0;
    NumberError error = parse_digits(ptr, end_, magnitude);
    constexpr uint64_t kMaxPositive = uint64_t{std::numeric_limits<int64_t>::max()};
    if (error == NumberError::kOk && magnitude > kMaxPositive + (negative ? 1 : 0)) {
      error = NumberError::kOutOfRange;
    }
    if (error != NumberError::kOk) {
      const char* e = p_;
      while (e != end_ && !is_space(*e)) ++e;
      last_ = std::string_view(p_, static_cast<size_t>(e - p_));
      return error;
    }
    out = negative ? static_cast<int64_t>(0 - magnitude) : static_cast<int64_t>(magnitude);
    last_ = std::string_view(p_, static_cast<size_t>(ptr - p_));
    p_ = ptr;
    return NumberError::kOk;
  }
  // The token the last read_* call looked at (for messages).
  std::string_view last_token() const { return last_; }
  // Consumes characters up to the next whitespace.
  void skip_token() {
    while (p_ != end_ && !is_space(*p_)) ++p_;
  }
  bool at_token_end() const { return p_ == end_ || is_space(*p_); }
  char peek() const { return p_ == end_ ? '\0' : *p_; }
  void advance() { ++p_; }

  // Decimal digits at p (at least one), stopping at the first non-digit; kOutOfRange past
  // 2^64 - 1. A hand loop: std::from_chars for integers is several times slower here.
  static NumberError parse_digits(const char*& p, const char* end, uint64_t& out) {
    const char* start = p;
    uint64_t value = 0;
    while (p != end && static_cast<unsigned>(*p - '0') < 10u) {
      uint64_t digit = static_cast<unsigned>(*p - '0');
      if (value > (~uint64_t{0} - digit) / 10) return NumberError::kOutOfRange;
      value = value * 10 + digit;
      ++p;
    }
    if (p == start) return NumberError::kMalformed;
    out = value;
    return NumberError::kOk;
  }

  static NumberError parse_float(std::string_view t, float& out) {
    const char* b = t.data();
    const char* e = b + t.size();
    if (b != e && *b == '+') ++b;
    auto [ptr, ec] = std::from_chars(b, e, out);
    if (ec == std::errc::result_out_of_range) {
      // Too large or too small for float: decide with a double.
      double d = 0;
      auto [dptr, dec] = std::from_chars(b, e, d);
      if (dec != std::errc() || dptr != e) return NumberError::kOutOfRange;
      if (std::fabs(d) > static_cast<double>(std::numeric_limits<float>::max())) {
        return NumberError::kOutOfRange;
      }
      out = static_cast<float>(d);
      return NumberError::kOk;
    }
    if (ec != std::errc() || ptr != e || b == e) return NumberError::kMalformed;
    if (!std::isfinite(out)) return NumberError::kNotFinite;
    return NumberError::kOk;
  }

 private:
  const char* p_;
  const char* end_;
  std::string_view last_;
};

// Quotes a token for a message, shortened to a readable length and with control bytes shown
// as '?', so that a message stays one printable line whatever the input holds.
inline std::string quote(std::string_view token) {
  constexpr size_t kMaxShown = 40;
  std::string q = "'";
  for (size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    unsigned char c = static_cast<unsigned char>(token[i]);
    q += (c < 0x20 || c >= 0x7f) ? '?' : static_cast<char>(c);
  }
  if (token.size() > kMaxShown) q += "...";
  q += "'";
  return q;
}

// "what: 'tok' is not a number" and friends: the message for a failed number read.
inline std::string number_problem(NumberError error, std::string_view what, std::string_view token) {
  std::string m(what);
  switch (error) {
    case NumberError::kOk: return m;
    case NumberError::kMissing: return m + ": missing";
    case NumberError::kMalformed: return m + ": " + quote(token) + " is not a number";
    case NumberError::kOutOfRange: return m + ": " + quote(token) + " is out of range";
    case NumberError::kNotFinite: return m + ": " + quote(token) + " is not a finite number";
  }
  return m;
}

// Drops a '#' comment and everything after it.
inline std::string_view strip_comment(std::string_view line) {
  const void* hash = std::memchr(line.data(), '#', line.size());
  if (hash == nullptr) return line;
  return line.substr(0, static_cast<size_t>(static_cast<const char*>(hash) - line.data()));
}

inline bool is_blank(std::string_view line) {
  for (char c : line) {
    if (!is_space(c)) return false;
  }
  return true;
}

// The next line that holds something besides whitespace and '#' comments, comment stripped;
// empty optional at the end of input.
inline Result<std::optional<std::string_view>> next_data_line(ByteSource& source) {
  for (;;) {
    Result<std::optional<std::string_view>> line = source.next_line();
    if (!line.is_ok() || !line->has_value()) return line;
    std::string_view data = strip_comment(**line);
    if (!is_blank(data)) return std::optional<std::string_view>(data);
  }
}

// ASCII case-insensitive equality (keywords).
inline bool equals_nocase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

}  // namespace gaussmesh::format::text
