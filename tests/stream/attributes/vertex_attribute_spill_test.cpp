// The input's vertex spill: what the ingest adds comes back in order, frame after frame, whether
// read on the caller's thread or a frame ahead on one of its own, and near a box every vertex
// inside it without every frame; a batch's error ends the pass and is returned; the file goes
// with the spill.
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "stream/attributes/vertex_attribute_spill.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

TEST(VertexAttributeSpill, GivesBackItsVerticesInOrderReadAheadOrNot) {
  testing::ScratchDir dir;
  {
    auto spill = VertexAttributeSpill::create(dir.path().string(), {true, true, false});
    ASSERT_TRUE(spill) << spill.status().to_string();
    constexpr std::size_t kVertices = 70000;  // several frames
    std::vector<format::Vec3f> positions(kVertices);
    std::vector<format::VertexAttributes> values(kVertices);
    for (std::size_t v = 0; v < kVertices; ++v) {
      positions[v] = {float(v), -float(v), 0.5f};
      values[v].color = {float(v % 256) / 255, 0, 1, 1};
      values[v].normal = {0, 0, float(v)};
    }
    for (std::size_t at = 0; at < kVertices; at += 9999) {
      const std::size_t n = std::min<std::size_t>(9999, kVertices - at);
      ASSERT_TRUE((*spill)->add(std::span(positions).subspan(at, n), std::span(values).subspan(at, n)).is_ok());
    }
    ASSERT_TRUE((*spill)->finish().is_ok());
    for (const bool ahead : {false, true}) {
      SCOPED_TRACE(ahead ? "read ahead" : "read in line");
      std::size_t seen = 0, batches = 0, wrong = 0;
      const format::Status read = (*spill)->each(
          [&](std::span<const format::Vec3f> p, std::span<const format::VertexAttributes> a) {
            EXPECT_EQ(p.size(), a.size());
            for (std::size_t i = 0; i < p.size() && seen + i < kVertices; ++i) {
              wrong += p[i].x != positions[seen + i].x || a[i].normal.z != values[seen + i].normal.z ||
                       a[i].color.r != values[seen + i].color.r;
            }
            seen += p.size();
            ++batches;
            return format::Status();
          },
          ahead);
      ASSERT_TRUE(read.is_ok()) << read.to_string();
      EXPECT_EQ(seen, kVertices);
      EXPECT_GT(batches, 1u);
      EXPECT_EQ(wrong, 0u);
      // A batch's error ends the pass, and comes back.
      std::size_t calls = 0;
      const format::Status stopped = (*spill)->each(
          [&](std::span<const format::Vec3f>, std::span<const format::VertexAttributes>) {
            return ++calls == 2 ? format::Status::error(format::Code::kProcessing, "test", "stop") : format::Status();
          },
          ahead);
      EXPECT_EQ(stopped.code(), format::Code::kProcessing);
      EXPECT_EQ(calls, 2u);
    }
    // Near a box: every vertex inside it, in order, and not every frame.
    PositionBox box;
    box.add({30000.5f, -40000.5f, 0});
    box.add({40000.5f, -30000.5f, 1});
    for (const bool ahead : {false, true}) {
      std::size_t inside = 0, seen = 0;
      float last = -1;
      bool ordered = true;
      ASSERT_TRUE((*spill)
                      ->each(
                          [&](std::span<const format::Vec3f> p, std::span<const format::VertexAttributes>) {
                            for (const format::Vec3f& q : p) {
                              inside += q.x >= 30000.5f && q.x <= 40000.5f;
                              ordered = ordered && q.x > last;
                              last = q.x;
                            }
                            seen += p.size();
                            return format::Status();
                          },
                          ahead, &box)
                      .is_ok());
      EXPECT_EQ(inside, 10000u);
      EXPECT_TRUE(ordered);
      EXPECT_LT(seen, kVertices / 2);
    }
    EXPECT_FALSE(std::filesystem::is_empty(dir.path()));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));  // gone with the spill
}

}  // namespace
}  // namespace gaussmesh::stream
