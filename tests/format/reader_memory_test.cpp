// Every reader's memory is independent of the input's size (docs/formats.md): reading a mesh
// four times larger holds no more heap, in every format and encoding a streaming run reads —
// except the STL weld's table, which grows with the unique vertices and therefore stops at half
// of ReadOptions::memory_limit with one kResources line. The probe is the allocator's own count
// of bytes in use (mallinfo2), sampled at every batch the reader delivers.
#include <malloc.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

// A wavy n × n grid of quads, two triangles each.
Mesh grid(std::uint32_t n) {
  Mesh m;
  for (std::uint32_t j = 0; j <= n; ++j)
    for (std::uint32_t i = 0; i <= n; ++i)
      m.positions.push_back({float(i) / float(n), float(j) / float(n), 0.05f * float((i * 7 + j * 3) % 11) / float(n)});
  for (std::uint32_t j = 0; j < n; ++j)
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.triangles.push_back({{a, b, d}});
      m.triangles.push_back({{a, d, c}});
    }
  return m;
}

std::string ply_header(const Mesh& m, const char* encoding) {
  return std::string("ply\nformat ") + encoding + " 1.0\nelement vertex " + std::to_string(m.positions.size()) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(m.triangles.size()) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string to_binary_ply(const Mesh& m) {
  std::string s = ply_header(m, "binary_little_endian");
  for (const Vec3f& p : m.positions) s.append(reinterpret_cast<const char*>(&p), sizeof(Vec3f));
  for (const Triangle& t : m.triangles) {
    s += char(3);
    for (std::uint32_t v : t.v) s.append(reinterpret_cast<const char*>(&v), 4);
  }
  return s;
}

std::string to_ascii_ply(const Mesh& m) {
  std::string s = ply_header(m, "ascii");
  for (const Vec3f& p : m.positions) {
    append_float(s, p.x), s += ' ', append_float(s, p.y), s += ' ', append_float(s, p.z), s += '\n';
  }
  for (const Triangle& t : m.triangles) s += "3 " + std::to_string(t.v[0]) + ' ' + std::to_string(t.v[1]) + ' ' + std::to_string(t.v[2]) + '\n';
  return s;
}

std::size_t heap_in_use() {
  const struct mallinfo2 info = ::mallinfo2();
  return info.uordblks + info.hblkhd;
}

// The most heap in use, above what was in use before the read, at any batch; keeps nothing.
class HeapProbe final : public format::MeshSink {
 public:
  HeapProbe() : base_(heap_in_use()) {}
  format::Status on_vertices(std::span<const Vec3f> batch) override { return sample(batch.size()); }
  format::Status on_triangles(std::span<const Triangle> batch) override { return sample(batch.size()); }
  std::size_t held() const { return held_; }

 private:
  format::Status sample(std::size_t) {
    const std::size_t now = heap_in_use();
    held_ = std::max(held_, now > base_ ? now - base_ : 0);
    return {};
  }
  std::size_t base_, held_ = 0;
};

struct Read {
  format::Status status;
  std::size_t held = 0;
};

Read read_file_probed(const std::string& path, const format::ReadOptions& options) {
  HeapProbe probe;
  Read r;
  r.status = format::read_mesh_file(path, options, probe);
  r.held = probe.held();
  return r;
}

struct Encoding {
  const char* name;
  std::string (*write)(const Mesh&);
  bool weld_stl = false;
};

std::string obj_plain(const Mesh& m) {
  return to_obj(m, [](std::uint64_t i) { return std::to_string(i); });
}

TEST(ReaderMemory, FourTimesTheMeshHoldsNoMoreHeapInAnyStreamingFormat) {
  ScratchDir dir;
  const Mesh small = grid(200), large = grid(400);  // 80k and 320k triangles
  const Encoding encodings[] = {{"binary ply", to_binary_ply},   {"ascii ply", to_ascii_ply},
                                {"off", to_off},                 {"obj", obj_plain},
                                {"binary stl", [](const Mesh& m) { return to_binary_stl(m); }},
                                {"ascii stl", to_ascii_stl}};
  for (const Encoding& e : encodings) {
    SCOPED_TRACE(e.name);
    format::ReadOptions options;
    options.weld_stl = e.weld_stl;
    write_file(dir.file("small"), e.write(small));
    write_file(dir.file("large"), e.write(large));
    const Read a = read_file_probed(dir.file("small"), options), b = read_file_probed(dir.file("large"), options);
    ASSERT_TRUE(a.status.is_ok()) << a.status.to_string();
    ASSERT_TRUE(b.status.is_ok()) << b.status.to_string();
    // The large file's vertices alone are 1.9 MB: a reader that kept them would show it.
    EXPECT_LE(b.held, a.held + 64 * 1024) << "small " << a.held << " B, large " << b.held << " B";
  }
}

TEST(ReaderMemory, TheStlWeldGrowsWithTheMeshAndStopsAtHalfTheLimit) {
  ScratchDir dir;
  write_file(dir.file("small.stl"), to_binary_stl(grid(300)));
  write_file(dir.file("large.stl"), to_binary_stl(grid(600)));
  format::ReadOptions options;  // welded, no limit: the probe sees the table grow
  const Read a = read_file_probed(dir.file("small.stl"), options), b = read_file_probed(dir.file("large.stl"), options);
  ASSERT_TRUE(a.status.is_ok() && b.status.is_ok());
  EXPECT_GT(b.held, a.held + (std::size_t{4} << 20)) << "small " << a.held << " B, large " << b.held << " B";
  options.memory_limit = std::uint64_t{16} << 20;  // the large one's 361k vertices need a 16 MiB table
  const Read refused = read_file_probed(dir.file("large.stl"), options);
  ASSERT_FALSE(refused.status.is_ok());
  EXPECT_EQ(refused.status.code(), format::Code::kResources);
  EXPECT_TRUE(single_line(refused.status)) << refused.status.to_string();
  EXPECT_NE(refused.status.to_string().find("--memory"), std::string::npos) << refused.status.to_string();
  EXPECT_LE(refused.held, options.memory_limit);  // the table's half and the reader's buffers
  EXPECT_TRUE(read_file_probed(dir.file("small.stl"), options).status.is_ok());  // 90k vertices fit
}

}  // namespace
}  // namespace gaussmesh::testing
