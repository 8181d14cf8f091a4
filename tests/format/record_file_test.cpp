// Tests of the record files between passes: round trip, frame cutting, and that every kind of
// damage (truncation, flipped bytes, wrong kind/size/version) is one clean kBadInput error.
#include "format/record_file.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

struct Item {
  std::uint64_t id;
  float xyz[3];
  std::uint32_t label;
};
static_assert(sizeof(Item) == 24);

std::vector<Item> make_items(size_t n) {
  std::vector<Item> items(n);
  for (size_t i = 0; i < n; ++i) items[i] = {i * 7919 + 3, {float(i), float(i) * 0.5f, -float(i)}, std::uint32_t(i % 20)};
  return items;
}

Status write_items(const std::string& path, const std::vector<Item>& items, size_t frame_bytes = 1 << 20) {
  auto writer = RecordWriter::create(path, 42, sizeof(Item), 1, frame_bytes);
  if (!writer) return writer.status();
  // Append in uneven pieces to exercise frame cutting.
  size_t at = 0, piece = 1;
  while (at < items.size()) {
    size_t take = std::min(piece, items.size() - at);
    GM_RETURN_IF_ERROR((*writer)->append(std::as_bytes(std::span(items.data() + at, take))));
    at += take;
    piece = piece * 3 + 1;
  }
  return (*writer)->finish();
}

// Every item of the record file at path, or at `segment` of it.
Result<std::vector<Item>> read_items(const std::string& path, const RecordSegment* segment = nullptr) {
  auto reader = segment ? RecordReader::open(path, 42, sizeof(Item), *segment) : RecordReader::open(path, 42, sizeof(Item));
  if (!reader) return reader.status();
  std::vector<Item> items;
  for (;;) {
    auto block = (*reader)->next();
    if (!block) return block.status();
    if (block->empty()) break;
    size_t n = block->size() / sizeof(Item);
    size_t old = items.size();
    items.resize(old + n);
    std::memcpy(items.data() + old, block->data(), block->size());
  }
  return items;
}

TEST(RecordFile, RoundTripAcrossManyFrames) {
  testing::ScratchDir dir;
  auto items = make_items(100000);
  ASSERT_TRUE(write_items(dir.file("r.bin"), items, 4096).is_ok());
  auto reader = RecordReader::open(dir.file("r.bin"), 42, sizeof(Item));
  ASSERT_TRUE(reader.is_ok());
  EXPECT_GT((*reader)->frame_count(), 256u);  // past the offsets a writer keeps: the rest are read back
  EXPECT_EQ((*reader)->records(), items.size());
  auto back = read_items(dir.file("r.bin"));
  ASSERT_TRUE(back.is_ok()) << back.status().to_string();
  ASSERT_EQ(back->size(), items.size());
  EXPECT_EQ(std::memcmp(back->data(), items.data(), items.size() * sizeof(Item)), 0);
}

TEST(RecordFile, ManyWritersShareOneContextWithoutHoldingFiles) {
  // 300 writers, one zstd context, no descriptor held between frames; records interleaved, some
  // appends a whole frame at once (compressed in place) — every file reads back exactly.
  testing::ScratchDir dir;
  auto compressor = RecordCompressor::create(1);
  ASSERT_TRUE(compressor.is_ok());
  RecordWriterOptions options;
  options.frame_bytes = 100 * sizeof(Item);
  options.shared = compressor->get();
  options.keep_open = false;
  const size_t writers = 300;
  auto writer_path = [&](size_t w) {
    std::string name = "w";  // appended, not "w" + ...: GCC 12 at -O3 warns (-Wrestrict) on that
    name += std::to_string(w);
    return dir.file(name);
  };
  std::vector<std::unique_ptr<RecordWriter>> open;
  for (size_t w = 0; w < writers; ++w) {
    auto writer = RecordWriter::create(writer_path(w), 42, sizeof(Item), options);
    ASSERT_TRUE(writer.is_ok()) << writer.status().to_string();
    EXPECT_EQ((*writer)->frame_limit(), 100 * sizeof(Item));
    open.push_back(std::move(*writer));
  }
  auto items = make_items(1000);
  for (size_t round = 0; round < 4; ++round)
    for (size_t w = 0; w < writers; ++w) {
      const size_t n = round == 2 ? 100 : 37;  // round 2: exactly one frame per append
      const size_t at = (round * 37 + w) % 800;
      ASSERT_TRUE(open[w]->append(std::as_bytes(std::span(items.data() + at, n))).is_ok());
    }
  for (auto& writer : open) ASSERT_TRUE(writer->finish().is_ok());
  for (size_t w = 0; w < writers; ++w) {
    auto back = read_items(writer_path(w));
    ASSERT_TRUE(back.is_ok()) << back.status().to_string();
    std::vector<Item> expected;
    for (size_t round = 0; round < 4; ++round) {
      const size_t n = round == 2 ? 100 : 37;
      const size_t at = (round * 37 + w) % 800;
      expected.insert(expected.end(), items.begin() + at, items.begin() + at + n);
    }
    ASSERT_EQ(back->size(), expected.size());
    EXPECT_EQ(std::memcmp(back->data(), expected.data(), expected.size() * sizeof(Item)), 0) << "writer " << w;
  }
}

TEST(RecordFile, SkippedFramesAreCountedNotDecompressed) {
  // Ten frames of 100 records: skip, read, skip the rest; the records read are the right ones,
  // each skip counts its frame, the end is 0 and an empty span, and a skipped frame whose header
  // disagrees with the seek table is an error.
  testing::ScratchDir dir;
  const auto items = make_items(1000);
  ASSERT_TRUE(write_items(dir.file("s.bin"), items, 100 * sizeof(Item)).is_ok());
  auto reader = RecordReader::open(dir.file("s.bin"), 42, sizeof(Item));
  ASSERT_TRUE(reader.is_ok()) << reader.status().to_string();
  ASSERT_EQ((*reader)->frame_count(), 10u);
  auto skipped = (*reader)->skip();
  ASSERT_TRUE(skipped.is_ok()) << skipped.status().to_string();
  EXPECT_EQ(*skipped, 100u);
  auto frame = (*reader)->next();
  ASSERT_TRUE(frame.is_ok()) << frame.status().to_string();
  ASSERT_EQ(frame->size(), 100 * sizeof(Item));
  EXPECT_EQ(std::memcmp(frame->data(), items.data() + 100, frame->size()), 0);
  std::uint64_t rest = 0;
  for (int k = 0; k < 8; ++k) {
    auto more = (*reader)->skip();
    ASSERT_TRUE(more.is_ok()) << more.status().to_string();
    rest += *more;
  }
  EXPECT_EQ(rest, 800u);
  auto end = (*reader)->skip();
  ASSERT_TRUE(end.is_ok());
  EXPECT_EQ(*end, 0u);
  auto last = (*reader)->next();
  ASSERT_TRUE(last.is_ok()) << last.status().to_string();  // every record accounted for
  EXPECT_TRUE(last->empty());

  // The first frame (after the 32-byte header) claiming 99 uncompressed bytes, not a whole
  // number of records; then its compressed size one larger than the seek table allows.
  const std::string bytes = testing::read_file(dir.file("s.bin"));
  for (const auto& [at, value] : {std::pair<std::size_t, std::uint32_t>{36, 99}, std::pair<std::size_t, std::uint32_t>{32, 0}}) {
    std::string damaged = bytes;
    std::uint32_t field = value;
    if (at == 32) {
      std::memcpy(&field, damaged.data() + 32, 4);
      ++field;
    }
    std::memcpy(damaged.data() + at, &field, 4);
    testing::write_file(dir.file("d.bin"), damaged);
    auto bad = RecordReader::open(dir.file("d.bin"), 42, sizeof(Item));
    ASSERT_TRUE(bad.is_ok()) << bad.status().to_string();
    auto refused = (*bad)->skip();
    ASSERT_FALSE(refused.is_ok()) << "byte " << at;
    EXPECT_EQ(refused.status().code(), Code::kBadInput) << refused.status().to_string();
  }
}

TEST(RecordFile, ColumnFramesRoundTripSmallerAndSayTheirLayout) {
  // Ids in order as differences, positions and labels as bytes: the reader needs no layout of
  // its own (the header carries it), gets every record back, and the file is smaller than rows.
  testing::ScratchDir dir;
  auto items = make_items(50000);
  items[777].id = 3;  // a difference that wraps below zero
  RecordWriterOptions options;
  options.level = 1;  // the rows' level (write_items): the layouts compared at one level
  options.frame_bytes = 4096 * sizeof(Item);
  options.columns = {{8, true}, {4, false}, {4, false}, {4, false}, {4, true}};
  auto writer = RecordWriter::create(dir.file("c.bin"), 42, sizeof(Item), options);
  ASSERT_TRUE(writer.is_ok()) << writer.status().to_string();
  ASSERT_TRUE((*writer)->append(std::as_bytes(std::span(items))).is_ok());
  ASSERT_TRUE((*writer)->finish().is_ok());
  ASSERT_TRUE(write_items(dir.file("r.bin"), items, 4096 * sizeof(Item)).is_ok());
  auto back = read_items(dir.file("c.bin"));
  ASSERT_TRUE(back.is_ok()) << back.status().to_string();
  ASSERT_EQ(back->size(), items.size());
  EXPECT_EQ(std::memcmp(back->data(), items.data(), items.size() * sizeof(Item)), 0);
  EXPECT_LT(testing::read_file(dir.file("c.bin")).size(), testing::read_file(dir.file("r.bin")).size());
  // Plain fields of every size the copies treat apart (1, 4 and 8 bytes) and of others, cut
  // across the record's own fields: the bytes come back as they were.
  options.columns = {{8, false}, {1, false}, {3, false}, {2, false}, {2, false}, {4, false}, {4, true}};
  auto mixed = RecordWriter::create(dir.file("m.bin"), 42, sizeof(Item), options);
  ASSERT_TRUE(mixed.is_ok()) << mixed.status().to_string();
  ASSERT_TRUE((*mixed)->append(std::as_bytes(std::span(items))).is_ok());
  ASSERT_TRUE((*mixed)->finish().is_ok());
  auto mixed_back = read_items(dir.file("m.bin"));
  ASSERT_TRUE(mixed_back.is_ok()) << mixed_back.status().to_string();
  ASSERT_EQ(mixed_back->size(), items.size());
  EXPECT_EQ(std::memcmp(mixed_back->data(), items.data(), items.size() * sizeof(Item)), 0);

  // Layouts that do not describe the record are refused when the writer is made...
  for (std::vector<RecordField> bad : {std::vector<RecordField>{{8, true}, {4, false}},  // 12 of 24 bytes
                                       std::vector<RecordField>{{12, true}, {12, false}},  // delta of 12 bytes
                                       std::vector<RecordField>{{0, false}, {24, false}},
                                       std::vector<RecordField>(12, RecordField{2, false})}) {
    options.columns = bad;
    auto refused = RecordWriter::create(dir.file("x.bin"), 42, sizeof(Item), options);
    ASSERT_FALSE(refused.is_ok());
    EXPECT_EQ(refused.status().code(), Code::kProcessing);
  }
  // ...and a damaged layout in a header is bad input naming the file.
  std::string bytes = testing::read_file(dir.file("c.bin"));
  for (auto [at, value] : {std::pair<size_t, char>{20, 12}, {21, char(0x80 | 3)}, {25, 5}}) {
    std::string damaged = bytes;
    damaged[at] = value;
    testing::write_file(dir.file("d.bin"), damaged);
    auto read = read_items(dir.file("d.bin"));
    ASSERT_FALSE(read.is_ok()) << "header byte " << at;
    EXPECT_EQ(read.status().code(), Code::kBadInput);
    EXPECT_NE(read.status().to_string().find("d.bin"), std::string::npos);
  }
}

TEST(RecordFile, EmptyFileIsValid) {
  testing::ScratchDir dir;
  ASSERT_TRUE(write_items(dir.file("e.bin"), {}).is_ok());
  auto back = read_items(dir.file("e.bin"));
  ASSERT_TRUE(back.is_ok()) << back.status().to_string();
  EXPECT_TRUE(back->empty());
}

TEST(RecordFile, WrongKindRecordSizeAndPartialRecordsAreRefused) {
  testing::ScratchDir dir;
  ASSERT_TRUE(write_items(dir.file("r.bin"), make_items(10)).is_ok());
  auto wrong_kind = RecordReader::open(dir.file("r.bin"), 43, sizeof(Item));
  ASSERT_FALSE(wrong_kind.is_ok());
  EXPECT_NE(wrong_kind.status().message().find("kind"), std::string::npos);
  auto wrong_size = RecordReader::open(dir.file("r.bin"), 42, 16);
  ASSERT_FALSE(wrong_size.is_ok());
  auto writer = RecordWriter::create(dir.file("p.bin"), 1, 24);
  ASSERT_TRUE(writer.is_ok());
  std::byte partial[10] = {};
  EXPECT_EQ((*writer)->append(partial).code(), Code::kProcessing);
}

TEST(RecordFile, EveryTruncationIsACleanError) {
  testing::ScratchDir dir;
  ASSERT_TRUE(write_items(dir.file("r.bin"), make_items(3000), 8192).is_ok());
  std::string bytes = testing::read_file(dir.file("r.bin"));
  for (size_t length = 0; length < bytes.size(); length += 1 + length / 50) {
    testing::write_file(dir.file("t.bin"), bytes.substr(0, length));
    auto back = read_items(dir.file("t.bin"));
    ASSERT_FALSE(back.is_ok()) << "prefix of " << length << " bytes read as valid";
    EXPECT_EQ(back.status().code(), Code::kBadInput);
    EXPECT_EQ(back.status().to_string().find('\n'), std::string::npos);
    EXPECT_NE(back.status().to_string().find("t.bin"), std::string::npos);
  }
}

TEST(RecordFile, FlippedBytesAreDetected) {
  testing::ScratchDir dir;
  ASSERT_TRUE(write_items(dir.file("r.bin"), make_items(3000), 8192).is_ok());
  std::string bytes = testing::read_file(dir.file("r.bin"));
  const std::uint32_t seed = 20261122;
  std::mt19937 rng(seed);
  size_t detected = 0, trials = 300;
  auto original = make_items(3000);
  for (size_t trial = 0; trial < trials; ++trial) {
    std::string damaged = bytes;
    size_t at = rng() % damaged.size();
    damaged[at] = static_cast<char>(damaged[at] ^ (1 + rng() % 255));
    testing::write_file(dir.file("d.bin"), damaged);
    auto back = read_items(dir.file("d.bin"));
    if (!back.is_ok()) {
      ++detected;
      EXPECT_EQ(back.status().code(), Code::kBadInput);
    } else {
      // A flip that goes unnoticed must not have changed what is read back.
      ASSERT_EQ(back->size(), original.size()) << "seed " << seed << " trial " << trial << " byte " << at;
      EXPECT_EQ(std::memcmp(back->data(), original.data(), original.size() * sizeof(Item)), 0)
          << "seed " << seed << " trial " << trial << " byte " << at << ": silent corruption";
    }
  }
  EXPECT_GT(detected, trials * 9 / 10);
}

Result<std::vector<Item>> read_segment(const std::string& path, RecordSegment segment) { return read_items(path, &segment); }

TEST(RecordFile, SegmentsAreWholeRecordFilesBackToBack) {
  // Three record files in one segment file: the second past the offsets a writer keeps (its seek
  // table is found again from the frame headers, at the segment's offset), the third empty; an
  // unfinished writer in between leaves nothing. Each segment reads back alone, byte for byte
  // what a file of its own holds.
  testing::ScratchDir dir;
  auto file = RecordSegmentFile::create(dir.file("segments.rec"));
  ASSERT_TRUE(file.is_ok());
  const std::vector<std::vector<Item>> items = {make_items(1000), make_items(40000), {}};
  RecordWriterOptions small;
  small.frame_bytes = 2048;
  std::vector<RecordSegment> segments;
  for (size_t k = 0; k < items.size(); ++k) {
    if (k == 1) {
      auto abandoned = RecordWriter::create_in(**file, 42, sizeof(Item));
      ASSERT_TRUE(abandoned.is_ok());
      EXPECT_EQ(RecordWriter::create_in(**file, 42, sizeof(Item)).status().code(), Code::kProcessing) << "two writers at once";
      ASSERT_TRUE((*abandoned)->append(std::as_bytes(std::span(items[0]))).is_ok());
    }  // destroyed unfinished
    auto writer = RecordWriter::create_in(**file, 42, sizeof(Item), small);
    ASSERT_TRUE(writer.is_ok());
    ASSERT_TRUE((*writer)->append(std::as_bytes(std::span(items[k]))).is_ok());
    ASSERT_TRUE((*writer)->finish().is_ok());
    segments.push_back((*writer)->segment());
    EXPECT_EQ(segments[k].offset + segments[k].bytes, (*file)->size());
    if (k > 0) {
      EXPECT_EQ(segments[k].offset, segments[k - 1].offset + segments[k - 1].bytes);
    }
  }
  auto many = RecordReader::open(dir.file("segments.rec"), 42, sizeof(Item), segments[1]);
  ASSERT_TRUE(many.is_ok());
  EXPECT_GT((*many)->frame_count(), 256u);
  const std::string all = testing::read_file(dir.file("segments.rec"));
  ASSERT_EQ(all.size(), (*file)->size());
  for (size_t k = 0; k < items.size(); ++k) {
    auto back = read_segment(dir.file("segments.rec"), segments[k]);
    ASSERT_TRUE(back.is_ok()) << back.status().to_string();
    ASSERT_EQ(back->size(), items[k].size());
    if (!items[k].empty()) {  // memcmp of an empty vector's data() would be a null pointer
      EXPECT_EQ(std::memcmp(back->data(), items[k].data(), items[k].size() * sizeof(Item)), 0);
    }
    // The same bytes as a file of its own.
    testing::write_file(dir.file("alone.rec"), all.substr(segments[k].offset, segments[k].bytes));
    auto alone = read_items(dir.file("alone.rec"));
    ASSERT_TRUE(alone.is_ok()) << alone.status().to_string();
    EXPECT_EQ(alone->size(), items[k].size());
  }
  // A segment that is not one, or runs past the end: kBadInput naming the file's byte.
  RecordSegment shifted = segments[1];
  shifted.offset += 1;
  EXPECT_EQ(read_segment(dir.file("segments.rec"), shifted).status().code(), Code::kBadInput);
  RecordSegment past = segments[2];
  past.bytes += 1;
  auto beyond = read_segment(dir.file("segments.rec"), past);
  EXPECT_EQ(beyond.status().code(), Code::kBadInput);
  EXPECT_NE(beyond.status().to_string().find("past the end"), std::string::npos) << beyond.status().to_string();
  // Damage inside one segment is that segment's error, and only its.
  std::string damaged = all;
  damaged[segments[0].offset + segments[0].bytes / 2] ^= 0x5A;
  testing::write_file(dir.file("segments.rec"), damaged);
  EXPECT_EQ(read_segment(dir.file("segments.rec"), segments[0]).status().code(), Code::kBadInput);
  EXPECT_TRUE(read_segment(dir.file("segments.rec"), segments[1]).is_ok());
}

}  // namespace
}  // namespace gaussmesh::format
