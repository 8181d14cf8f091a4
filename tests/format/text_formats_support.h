// Test helpers for the OFF / OBJ / STL reader tests: a sink that keeps the mesh and checks the
// MeshSink contract, tiny writers that turn a mesh into each format's bytes, and a way to feed
// bytes through standard input (a pipe, so the size is unknown, or a regular file).
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "format/mesh_reader.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {

using format::MeshFormat;
using format::Triangle;
using format::Vec3f;

struct Mesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
};

// Keeps everything a reader delivers; records the first violation of the sink contract.
class CollectSink final : public format::MeshSink {
 public:
  format::Status on_header(const format::MeshHeader& header) override {
    if (headers_ != 0 || ended_) note("on_header called twice or late");
    ++headers_;
    header_ = header;
    return {};
  }
  format::Status on_vertices(std::span<const Vec3f> batch) override {
    if (headers_ != 1 || ended_) note("on_vertices outside header..end");
    if (batch.empty()) note("empty vertex batch");
    ++vertex_batches;
    mesh.positions.insert(mesh.positions.end(), batch.begin(), batch.end());
    return {};
  }
  format::Status on_triangles(std::span<const Triangle> batch) override {
    if (headers_ != 1 || ended_) note("on_triangles outside header..end");
    if (batch.empty()) note("empty triangle batch");
    ++triangle_batches;
    for (const Triangle& t : batch) {
      for (auto v : t.v) {
        if (v >= mesh.positions.size()) note("triangle refers to an undelivered vertex");
      }
    }
    mesh.triangles.insert(mesh.triangles.end(), batch.begin(), batch.end());
    return {};
  }
  format::Status on_end() override {
    if (headers_ != 1 || ended_) note("on_end without header or twice");
    ended_ = true;
    return {};
  }

  Mesh mesh;
  size_t vertex_batches = 0, triangle_batches = 0;
  const format::MeshHeader& header() const { return header_; }
  bool ended() const { return ended_; }
  // Empty when the reader kept the contract.
  const std::string& contract_error() const { return contract_error_; }

 private:
  void note(const char* what) {
    if (contract_error_.empty()) contract_error_ = what;
  }
  int headers_ = 0;
  bool ended_ = false;
  format::MeshHeader header_;
  std::string contract_error_;
};

struct ReadOutcome {
  format::Status status;
  Mesh mesh;
  format::MeshHeader header;
  bool ended = false;
  std::string contract_error;
  size_t vertex_batches = 0, triangle_batches = 0;
};

inline ReadOutcome finish(format::Status status, CollectSink& sink) {
  ReadOutcome r;
  r.status = std::move(status);
  r.mesh = std::move(sink.mesh);
  r.header = sink.header();
  r.ended = sink.ended();
  r.contract_error = sink.contract_error();
  r.vertex_batches = sink.vertex_batches;
  r.triangle_batches = sink.triangle_batches;
  return r;
}

// Reads bytes from memory (size known) through read_mesh.
inline ReadOutcome read_bytes(const std::string& bytes, const std::string& name,
                              MeshFormat format = MeshFormat::kUnknown,
                              size_t batch_size = size_t{1} << 16) {
  auto source = format::ByteSource::from_memory(bytes, name);
  format::ReadOptions options;
  options.format = format;
  options.batch_size = batch_size;
  CollectSink sink;
  format::Status s = format::read_mesh(*source, options, sink);
  return finish(std::move(s), sink);
}

inline ReadOutcome read_path(const std::string& path, MeshFormat format = MeshFormat::kUnknown) {
  format::ReadOptions options;
  options.format = format;
  CollectSink sink;
  format::Status s = format::read_mesh_file(path, options, sink);
  return finish(std::move(s), sink);
}

// Runs read_mesh_file("-") with standard input replaced by the bytes: through a pipe fed by a
// thread (no size known, reads arrive in pieces) or, with via_pipe false, a regular file.
inline ReadOutcome read_stdin(const std::string& bytes, bool via_pipe,
                              MeshFormat format = MeshFormat::kUnknown) {
  int saved = ::dup(STDIN_FILENO);
  std::thread writer;
  ScratchDir dir;
  if (via_pipe) {
    int fds[2];
    if (::pipe(fds) != 0) {
      ReadOutcome failed;
      failed.status = format::Status::error(format::Code::kBadInput, "test", "pipe failed");
      return failed;
    }
    ::dup2(fds[0], STDIN_FILENO);
    ::close(fds[0]);
    int out = fds[1];
    writer = std::thread([out, &bytes] {
      size_t done = 0;
      while (done < bytes.size()) {
        // Small writes so the reader sees partial windows.
        size_t n = std::min<size_t>(bytes.size() - done, 1000);
        ssize_t w = ::write(out, bytes.data() + done, n);
        if (w <= 0) break;
        done += static_cast<size_t>(w);
      }
      ::close(out);
    });
  } else {
    std::string path = dir.file("stdin.bin");
    write_file(path, bytes);
    int fd = ::open(path.c_str(), O_RDONLY);
    ::dup2(fd, STDIN_FILENO);
    ::close(fd);
  }
  ReadOutcome r = read_path("-", format);
  // Drain what the reader left so the writer thread can finish, then restore stdin.
  if (via_pipe) {
    char sink_buffer[4096];
    while (::read(STDIN_FILENO, sink_buffer, sizeof sink_buffer) > 0) {
    }
    writer.join();
  }
  ::dup2(saved, STDIN_FILENO);
  ::close(saved);
  return r;
}

// ---- tiny writers -------------------------------------------------------------------------

inline void append_float(std::string& out, float f) {
  char buffer[32];
  out.append(buffer, std::to_chars(buffer, buffer + sizeof buffer, f).ptr);
}

inline std::string to_off(const Mesh& m) {
  std::string s = "OFF\n" + std::to_string(m.positions.size()) + " " +
                  std::to_string(m.triangles.size()) + " 0\n";
  for (const Vec3f& p : m.positions) {
    append_float(s, p.x);
    s += ' ';
    append_float(s, p.y);
    s += ' ';
    append_float(s, p.z);
    s += '\n';
  }
  for (const Triangle& t : m.triangles) {
    s += "3 " + std::to_string(t.v[0]) + " " + std::to_string(t.v[1]) + " " + std::to_string(t.v[2]) + "\n";
  }
  return s;
}

inline void append_obj_vertex(std::string& s, const Vec3f& p) {
  s += "v ";
  append_float(s, p.x);
  s += ' ';
  append_float(s, p.y);
  s += ' ';
  append_float(s, p.z);
  s += '\n';
}

// corner(i) renders the 1-based index i of a face corner ("7/7/7", "7//7", ...).
template <class Corner>
std::string to_obj(const Mesh& m, Corner corner) {
  std::string s = "# written by a test\nmtllib none.mtl\no mesh\n";
  for (const Vec3f& p : m.positions) append_obj_vertex(s, p);
  for (size_t i = 0; i < m.positions.size(); ++i) s += "vt 0.5 0.5\nvn 0 0 1\n";
  s += "g all\ns 1\nusemtl none\n";
  for (const Triangle& t : m.triangles) {
    s += "f";
    for (auto v : t.v) {
      s += ' ';  // not " " + corner(...): GCC 12 at -O3 warns (-Wrestrict) on literal + temporary
      s += corner(uint64_t{v} + 1);
    }
    s += '\n';
  }
  return s;
}

inline std::string to_binary_stl(const Mesh& m, const std::string& header_text = "binary stl from a test") {
  std::string s(80, ' ');
  std::memcpy(s.data(), header_text.data(), std::min<size_t>(header_text.size(), 80));
  uint32_t n = static_cast<uint32_t>(m.triangles.size());
  s.append(reinterpret_cast<const char*>(&n), 4);  // the test machine is little-endian
  for (const Triangle& t : m.triangles) {
    float record[12] = {0, 0, 1};
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = m.positions[t.v[k]];
      record[3 + 3 * k] = p.x;
      record[4 + 3 * k] = p.y;
      record[5 + 3 * k] = p.z;
    }
    s.append(reinterpret_cast<const char*>(record), sizeof record);
    s.append(2, '\0');
  }
  return s;
}

inline std::string to_ascii_stl(const Mesh& m) {
  std::string s = "solid test\n";
  for (const Triangle& t : m.triangles) {
    s += "  facet normal 0 0 1\n    outer loop\n";
    for (auto v : t.v) {
      s += "      vertex ";
      append_float(s, m.positions[v].x);
      s += ' ';
      append_float(s, m.positions[v].y);
      s += ' ';
      append_float(s, m.positions[v].z);
      s += '\n';
    }
    s += "    endloop\n  endfacet\n";
  }
  s += "endsolid test\n";
  return s;
}

// ---- comparisons --------------------------------------------------------------------------

// A triangle rotated so its smallest index comes first (same orientation).
inline std::array<uint32_t, 3> canonical(const Triangle& t) {
  int k = 0;
  if (t.v[1] < t.v[k]) k = 1;
  if (t.v[2] < t.v[k]) k = 2;
  return {t.v[k], t.v[(k + 1) % 3], t.v[(k + 2) % 3]};
}

inline std::vector<std::array<uint32_t, 3>> canonical_sorted(const std::vector<Triangle>& ts) {
  std::vector<std::array<uint32_t, 3>> c;
  c.reserve(ts.size());
  for (const Triangle& t : ts) c.push_back(canonical(t));
  std::sort(c.begin(), c.end());
  return c;
}

inline bool single_line(const format::Status& s) {
  return s.to_string().find('\n') == std::string::npos && !s.message().empty();
}

inline Mesh load_fixture(const std::string& relative) {
  ReadOutcome r = read_path(fixture(relative));
  return r.mesh;
}

}  // namespace gaussmesh::testing
