// The OBJ census (obj_census.h): one forward pass over the bytes, a small state machine per
// statement, no number parsed.
#include "format/obj_census.h"

#include <algorithm>
#include <cstring>

namespace gaussmesh::format {
namespace {

// The reader's blanks (text::is_space).
bool text_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

}  // namespace

Result<ObjCensus> census_obj(ByteSource& source, std::uint64_t enough) {
  enum class State { kLineStart, kKeyword, kSkip, kFaceGap, kFaceToken };
  ObjCensus census;
  State state = State::kLineStart;
  char keyword[3] = {};
  std::size_t keyword_length = 0;
  std::uint64_t corners = 0;
  bool lone_backslash = false;  // the face's last token is a '\' alone (a continuation, no corner)
  // As the reader takes lines: a '\r' right before the '\n' is the line end's, not the line's
  // (held back until the next character says which), and a line that ends in '\' continues the
  // statement, the '\' read as a blank.
  char last = 0;
  bool pending_cr = false;
  const auto end_face = [&] {
    if (corners >= 3) census.triangles += corners - 2;
    corners = 0;
  };
  // The keyword read so far ends (a blank, or a continuing '\' after it).
  const auto end_keyword = [&] {
    corners = 0;
    lone_backslash = false;
    state = State::kSkip;
    if (keyword_length == 1 && keyword[0] == 'f') state = State::kFaceGap;
    if (keyword_length == 1 && keyword[0] == 'v') ++census.vertices;
    if (keyword_length == 2 && keyword[0] == 'v' && keyword[1] == 't') ++census.texcoords;
    if (keyword_length == 2 && keyword[0] == 'v' && keyword[1] == 'n') ++census.normals;
  };
  // One character of a line.
  const auto take = [&](char c) {
    last = c;
    switch (state) {
      case State::kLineStart:
        if (text_blank(c)) break;
        keyword[0] = c;
        keyword_length = 1;
        state = State::kKeyword;
        break;
      case State::kKeyword:
        if (text_blank(c)) end_keyword();
        else if (keyword_length < 3) keyword[keyword_length++] = c;
        else state = State::kSkip;  // no keyword this long is counted
        break;
      case State::kFaceGap:
        if (text_blank(c)) break;
        if (c == '#') {  // a comment to the end of the statement
          end_face();
          state = State::kSkip;
          break;
        }
        ++corners;
        lone_backslash = c == '\\';
        state = State::kFaceToken;
        if (c == '/') census.corner_values = true;
        break;
      case State::kFaceToken:
        if (text_blank(c)) {
          state = State::kFaceGap;
        } else {
          lone_backslash = false;
          if (c == '/') census.corner_values = true;
        }
        break;
      case State::kSkip: break;
    }
  };
  // A character other than '\n', with the held-back '\r' first.
  const auto feed = [&](char c) {
    if (pending_cr) take('\r');
    pending_cr = c == '\r';
    if (!pending_cr) take(c);
  };
  const auto end_line = [&] {
    pending_cr = false;
    const bool continued = last == '\\';
    last = 0;
    if (!continued) {
      if (state == State::kFaceToken || state == State::kFaceGap) end_face();
      state = State::kLineStart;
      return;
    }
    // The '\' is a blank: it ends the token or keyword it closes (alone, it was none).
    if (state == State::kFaceToken || state == State::kFaceGap) {
      if (lone_backslash && corners > 0) --corners;
      lone_backslash = false;
      state = State::kFaceGap;
    } else if (state == State::kKeyword) {
      --keyword_length;
      if (keyword_length == 0) state = State::kLineStart;
      else end_keyword();
    }
  };
  for (;;) {
    Result<size_t> got = source.ensure(ByteSource::kMaxWindow);
    if (!got) return got.status();
    if (*got == 0) break;
    const char* p = source.cursor();
    const char* const end = p + *got;
    while (p < end) {
      if (state == State::kSkip) {
        // Most bytes are in vertex statements: find their ends without looking at each byte
        // (only the last two can decide whether the statement goes on).
        const char* newline = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
        const char* upto = newline ? newline : end;
        for (const char* q = std::max(p, upto - 2); q < upto; ++q) feed(*q);
        p = upto;
        if (!newline) break;
      }
      // Face statements are the rest of the bytes: their plain characters in a tight loop, the
      // few that need the rules above ('\n', '\r', '#', '\\') through them.
      while (p < end && (state == State::kFaceGap || state == State::kFaceToken) && !pending_cr) {
        const char c = *p;
        if (c == '\n' || c == '\r' || c == '#' || c == '\\') break;
        ++p;
        last = c;
        const bool blank = c == ' ' || c == '\t' || c == '\v' || c == '\f';
        if (state == State::kFaceGap) {
          if (blank) continue;
          ++corners;
          lone_backslash = false;
          state = State::kFaceToken;
        } else if (blank) {
          state = State::kFaceGap;
          continue;
        }
        lone_backslash = false;
        if (c == '/') census.corner_values = true;
      }
      if (p == end) break;
      const char c = *p++;
      if (c == '\n') end_line();
      else feed(c);
    }
    source.advance(*got);
    if (census.triangles > enough) return census;
  }
  if (pending_cr) take('\r');
  if (state == State::kFaceToken || state == State::kFaceGap) end_face();  // no final newline
  census.complete = census.triangles <= enough;
  return census;
}

Result<bool> any_slash(ByteSource& source) {
  for (;;) {
    Result<size_t> got = source.ensure(ByteSource::kMaxWindow);
    if (!got) return got.status();
    if (*got == 0) return false;
    if (std::memchr(source.cursor(), '/', *got)) return true;
    source.advance(*got);
  }
}

}  // namespace gaussmesh::format
