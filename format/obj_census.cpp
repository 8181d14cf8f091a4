// The OBJ census (obj_census.h): one forward pass over the bytes, a small state machine per
// statement, no number parsed.
#include "format/obj_census.h"

#include <cstring>

namespace gaussmesh::format {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

}  // namespace

Result<ObjCensus> census_obj(ByteSource& source, std::uint64_t enough) {
  enum class State { kLineStart, kKeyword, kSkip, kFaceGap, kFaceToken };
  ObjCensus census;
  State state = State::kLineStart;
  char keyword[2] = {};
  std::size_t keyword_length = 0, token_length = 0;
  std::uint64_t corners = 0;
  char last = 0;  // the line's last character but '\r': a '\' continues the statement
  const auto end_face = [&] {
    if (corners >= 3) census.triangles += corners - 2;
    corners = 0;
  };
  for (;;) {
    Result<size_t> got = source.ensure(ByteSource::kMaxWindow);
    if (!got) return got.status();
    if (*got == 0) break;
    const char* p = source.cursor();
    const char* const end = p + *got;
    while (p < end) {
      if (state == State::kSkip) {
        // Most bytes are in vertex statements: find their ends without looking at each byte.
        const char* newline = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
        const char* upto = newline ? newline : end;
        for (const char* q = upto; q > p;) {
          if (*--q != '\r') {
            last = *q;
            break;
          }
        }
        if (!newline) {
          p = end;
          break;
        }
        p = newline + 1;
        if (last != '\\') state = State::kLineStart;
        last = 0;
        continue;
      }
      const char c = *p++;
      if (c == '\n') {
        const bool continued = last == '\\';
        last = 0;
        if (state == State::kFaceToken || state == State::kFaceGap) {
          if (continued) {
            // The '\' ends the line as a blank would: alone it was counted as a corner.
            if (state == State::kFaceToken && token_length == 1) --corners;
            state = State::kFaceGap;
            continue;
          }
          end_face();
        }
        if (state == State::kKeyword && continued) {
          state = State::kSkip;  // a keyword alone, continued: not a face (the reader refuses it)
          continue;
        }
        state = State::kLineStart;
        continue;
      }
      if (c != '\r') last = c;
      switch (state) {
        case State::kLineStart:
          if (is_blank(c)) break;
          keyword[0] = c;
          keyword_length = 1;
          state = State::kKeyword;
          break;
        case State::kKeyword:
          if (is_blank(c)) {
            state = keyword_length == 1 && keyword[0] == 'f' ? State::kFaceGap : State::kSkip;
            corners = 0;
            if (keyword[0] == 'v') {
              if (keyword_length == 1) ++census.vertices;
              else if (keyword[1] == 't') ++census.texcoords;
              else if (keyword[1] == 'n') ++census.normals;
            }
          } else if (keyword_length < 2) {
            keyword[keyword_length++] = c;
          } else {
            state = State::kSkip;  // no keyword this long names a face
          }
          break;
        case State::kFaceGap:
          if (is_blank(c)) break;
          if (c == '#') {  // a comment to the end of the statement
            end_face();
            state = State::kSkip;
            break;
          }
          ++corners;
          token_length = 1;
          state = State::kFaceToken;
          if (c == '/') census.corner_values = true;
          break;
        case State::kFaceToken:
          if (is_blank(c)) {
            state = State::kFaceGap;
          } else {
            ++token_length;
            if (c == '/') census.corner_values = true;
          }
          break;
        case State::kSkip: break;
      }
    }
    source.advance(*got);
    if (census.triangles > enough) return census;
  }
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
