// The stitch's on-disk joins (stream/stitch/piece_joins.h): border edges spilled by several chunks into
// buckets are joined exactly once each, whatever the bucket count and however many reads a
// large bucket takes; face answers are found in their owners' files; a damaged, missing or forged
// file, an edge seen once or three times, an answer out of order or from the wrong chunk is a
// kBadInput error.
#include "stream/stitch/piece_joins.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>
#include <tuple>

#include "format/record_file.h"
#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

using format::Code;
using Joined = std::tuple<std::uint64_t, std::uint64_t, PieceId, PieceId, bool>;  // lower face, higher, their pieces, feature

// n random manifold border edges between faces of `chunks` chunks (face f owned by chunk f % chunks),
// each side emitted by its face's owner. Returns the chunks and the joins expected.
std::vector<ChunkPieces> random_edges(std::size_t n, std::size_t chunks, std::uint32_t seed, std::vector<Joined>& want) {
  std::mt19937_64 rng(seed);
  std::vector<ChunkPieces> out(chunks);
  std::set<std::pair<std::uint64_t, std::uint64_t>> pairs;
  while (pairs.size() < n) {
    const std::uint64_t a = rng() % (8 * n), b = rng() % (8 * n);
    if (a % chunks == b % chunks) continue;  // a border edge joins faces of two chunks
    pairs.emplace(std::min(a, b), std::max(a, b));
  }
  for (const auto& [a, b] : pairs) {
    const PieceId pa = PieceId{a % chunks} << 32 | (a & 15), pb = PieceId{b % chunks} << 32 | (b & 15);
    const bool feature = (a ^ b) & 1;
    out[a % chunks].border.push_back({a, b, pa, feature});
    out[b % chunks].border.push_back({b, a, pb, feature});
    want.emplace_back(a, b, pa, pb, feature);
  }
  std::sort(want.begin(), want.end());
  return out;
}

format::Result<std::unique_ptr<PieceJoinFiles>> spilled(const std::string& dir, std::vector<ChunkPieces> chunks,
                                                        std::size_t buckets) {
  auto joins = PieceJoinFiles::create(dir, chunks.size(), buckets);
  if (!joins) return joins.status();
  for (std::size_t c = 0; c < chunks.size(); ++c) GM_RETURN_IF_ERROR((*joins)->spill(static_cast<std::uint32_t>(c), chunks[c]));
  GM_RETURN_IF_ERROR((*joins)->finish());
  return joins;
}

format::Status join(const PieceJoinFiles& joins, std::vector<Joined>& got, std::uint64_t memory = 64 << 20) {
  got.clear();
  GM_RETURN_IF_ERROR(joins.join_border_edges(MemoryBudget(memory), [&](const BorderEdgeRecord& x, const BorderEdgeRecord& y) {
    EXPECT_LT(x.face, y.face);
    got.emplace_back(x.face, y.face, x.piece, y.piece, x.feature);
    return format::Status();
  }));
  std::sort(got.begin(), got.end());
  return {};
}

// Writes a record file of the given kind at path, replacing what is there.
void forge(const std::string& path, std::uint32_t kind, std::uint32_t record_size, const std::vector<std::byte>& bytes) {
  auto writer = format::RecordWriter::create(path, kind, record_size);
  ASSERT_TRUE(writer.is_ok());
  ASSERT_TRUE((*writer)->append(bytes).is_ok());
  ASSERT_TRUE((*writer)->finish().is_ok());
}

// Appends a forged record file to the segments file holding chunk's part and points the part at it.
void forge_part(PieceJoinFiles& joins, PieceJoinFiles::Part part, std::uint32_t chunk, std::uint32_t kind,
                std::uint32_t record_size, const std::vector<std::byte>& bytes, const testing::ScratchDir& dir) {
  forge(dir.file("forged.rec"), kind, record_size, bytes);
  const std::string forged = testing::read_file(dir.file("forged.rec"));
  const std::string path = joins.segment_path(joins.placed(part, chunk).file);
  const std::string held = testing::read_file(path);
  testing::write_file(path, held + forged);
  joins.replace_segment_for_test(part, chunk, {held.size(), forged.size()});
}

// Cuts the segments file holding chunk's part `cut` bytes before the part's end.
void truncate_part(const PieceJoinFiles& joins, PieceJoinFiles::Part part, std::uint32_t chunk, std::uint64_t cut) {
  const PieceJoinFiles::Placed placed = joins.placed(part, chunk);
  ASSERT_NE(placed.file, PieceJoinFiles::Placed{}.file);
  std::filesystem::resize_file(joins.segment_path(placed.file), placed.segment.offset + placed.segment.bytes - cut);
}

std::vector<std::byte> border_bytes(const std::vector<BorderEdgeRecord>& records, std::uint8_t feature_byte) {
  std::vector<std::byte> bytes(records.size() * kBorderEdgeRecordBytes);
  for (std::size_t k = 0; k < records.size(); ++k) {
    std::byte* at = bytes.data() + k * kBorderEdgeRecordBytes;
    std::memcpy(at, &records[k].face, 8);
    std::memcpy(at + 8, &records[k].other, 8);
    std::memcpy(at + 16, &records[k].piece, 8);
    at[24] = std::byte{feature_byte};
  }
  return bytes;
}

std::vector<std::byte> answer_bytes(const std::vector<FacePieceRecord>& records) {
  std::vector<std::byte> bytes(records.size() * kFaceAnswerRecordBytes);
  for (std::size_t k = 0; k < records.size(); ++k) {
    std::memcpy(bytes.data() + 16 * k, &records[k].face, 8);
    std::memcpy(bytes.data() + 16 * k + 8, &records[k].piece, 8);
  }
  return bytes;
}

TEST(PieceJoins, EveryEdgeIsJoinedOnceWhateverTheBuckets) {
  for (std::size_t buckets : {std::size_t{1}, std::size_t{5}, kMaxBorderBuckets}) {
    SCOPED_TRACE("buckets " + std::to_string(buckets) + ", seed 7");
    testing::ScratchDir dir;
    std::vector<Joined> want, got;
    auto joins = spilled(dir.path().string(), random_edges(3000, 4, 7, want), buckets);
    ASSERT_TRUE(joins.is_ok()) << joins.status().to_string();
    EXPECT_EQ((*joins)->border_records(), 2 * want.size());
    ASSERT_TRUE(join(**joins, got).is_ok());
    EXPECT_EQ(got, want);
  }
}

TEST(PieceJoins, ALargeBucketIsJoinedInParts) {
  // 2 x 60k records of 32 B in memory in one bucket: ~3.8 MB against 1 MiB a read (the floor).
  SCOPED_TRACE("seed 9");
  testing::ScratchDir dir;
  std::vector<Joined> want, got;
  auto joins = spilled(dir.path().string(), random_edges(60000, 3, 9, want), 1);
  ASSERT_TRUE(joins.is_ok()) << joins.status().to_string();
  ASSERT_GT((*joins)->border_records() * sizeof(BorderEdgeRecord), 3 * bucket_bytes(MemoryBudget()));
  ASSERT_TRUE(join(**joins, got, 0).is_ok());
  EXPECT_EQ(got, want);
}

// The edges in the order on_edge saw them, joined on `threads` threads.
format::Status join_in_order(const PieceJoinFiles& joins, std::uint32_t threads, std::uint64_t memory,
                             std::vector<Joined>& got) {
  got.clear();
  return joins.join_border_edges(
      MemoryBudget(memory),
      [&](const BorderEdgeRecord& x, const BorderEdgeRecord& y) {
        got.emplace_back(x.face, y.face, x.piece, y.piece, x.feature);
        return format::Status();
      },
      threads);
}

TEST(PieceJoins, ThreadsJoinInTheOrderOfOneThread) {
  // Buckets read and sorted on two threads are joined in the one-thread order; with the buckets
  // in parts too. Damage: the first bad bucket in that order is the error, whatever the threads.
  for (std::uint64_t memory : {std::uint64_t{64} << 20, std::uint64_t{0}}) {
    SCOPED_TRACE("memory " + std::to_string(memory) + ", seed 13");
    testing::ScratchDir dir;
    std::vector<Joined> want, one, two;
    auto joins = spilled(dir.path().string(), random_edges(memory ? 3000 : 60000, 4, 13, want), memory ? 7 : 2);
    ASSERT_TRUE(joins.is_ok()) << joins.status().to_string();
    ASSERT_TRUE(join_in_order(**joins, 1, memory, one).is_ok());
    ASSERT_TRUE(join_in_order(**joins, 2, memory, two).is_ok());
    EXPECT_EQ(one, two);
    std::sort(one.begin(), one.end());
    EXPECT_EQ(one, want);
  }
  testing::ScratchDir dir;
  std::vector<Joined> want, got;
  auto joins = spilled(dir.path().string(), random_edges(3000, 4, 13, want), 7);
  ASSERT_TRUE(joins.is_ok());
  for (std::size_t b : {std::size_t{5}, std::size_t{2}}) {
    const std::string bytes = testing::read_file((*joins)->bucket_path(b));
    testing::write_file((*joins)->bucket_path(b), bytes.substr(0, bytes.size() - 9));
  }
  const format::Status serial = join_in_order(**joins, 1, 64 << 20, got);
  EXPECT_EQ(serial.code(), Code::kBadInput);
  EXPECT_NE(serial.to_string().find((*joins)->bucket_path(2)), std::string::npos) << serial.to_string();
  for (int run = 0; run < 5; ++run) EXPECT_EQ(join_in_order(**joins, 2, 64 << 20, got).to_string(), serial.to_string());
}

TEST(PieceJoins, BucketCountFollowsTheBudget) {
  EXPECT_EQ(border_bucket_count(0, MemoryBudget(64 << 20)), 1u);
  EXPECT_EQ(border_bucket_count(1000, MemoryBudget(64 << 20)), 1u);
  // 4 MiB a bucket at 64 MiB: 10M records of 32 B make 77 buckets.
  EXPECT_EQ(border_bucket_count(10'000'000, MemoryBudget(64 << 20)), 77u);
  EXPECT_EQ(border_bucket_count(std::uint64_t{1} << 40, MemoryBudget(64 << 20)), kMaxBorderBuckets);
  EXPECT_EQ(bucket_bytes(MemoryBudget()), std::uint64_t{1} << 20);
  EXPECT_EQ(PieceJoinFiles::create("/nonexistent", 1, 0).status().code(), Code::kUsage);
  EXPECT_EQ(PieceJoinFiles::create("/nonexistent/dir", 1, 1).status().code(), Code::kOutput);
  // Either order of the faces, the same bucket and part.
  for (std::uint64_t a = 0; a < 50; ++a) {
    EXPECT_EQ(border_bucket(a, 1000 - a, 13), border_bucket(1000 - a, a, 13));
    EXPECT_EQ(border_bucket_part(a, 1000 - a, 5), border_bucket_part(1000 - a, a, 5));
  }
}

TEST(PieceJoins, MissingOrRepeatedSidesAreBadInput) {
  std::vector<ChunkPieces> chunks(2);
  chunks[0].border = {{1, 2, PieceId{0} << 32, false}};
  testing::ScratchDir dir;
  std::vector<Joined> got;
  auto one_side = spilled(dir.file("a"), {}, 1);  // nonexistent dir: kOutput
  EXPECT_EQ(one_side.status().code(), Code::kOutput);
  std::filesystem::create_directory(dir.file("a"));
  one_side = spilled(dir.file("a"), chunks, 2);
  ASSERT_TRUE(one_side.is_ok());
  EXPECT_EQ(join(**one_side, got).code(), Code::kBadInput);
  chunks[1].border = {{2, 1, PieceId{1} << 32, false}, {2, 1, PieceId{1} << 32, false}};
  std::filesystem::create_directory(dir.file("b"));
  auto three = spilled(dir.file("b"), chunks, 2);
  ASSERT_TRUE(three.is_ok());
  EXPECT_EQ(join(**three, got).code(), Code::kBadInput);
  chunks[1].border = {{2, 1, PieceId{1} << 32, true}};
  std::filesystem::create_directory(dir.file("c"));
  auto disagree = spilled(dir.file("c"), chunks, 2);
  ASSERT_TRUE(disagree.is_ok());
  EXPECT_EQ(join(**disagree, got).code(), Code::kBadInput);
  // Both sides from one face.
  chunks[1].border = {{1, 2, PieceId{1} << 32, false}};
  std::filesystem::create_directory(dir.file("d"));
  auto same = spilled(dir.file("d"), chunks, 2);
  ASSERT_TRUE(same.is_ok());
  EXPECT_EQ(join(**same, got).code(), Code::kBadInput);
}

TEST(PieceJoins, DamagedBucketFilesAreBadInput) {
  std::vector<Joined> want, got;
  auto fresh = [&](testing::ScratchDir& dir) {
    want.clear();
    auto joins = spilled(dir.path().string(), random_edges(2000, 3, 11, want), 1);
    EXPECT_TRUE(joins.is_ok());
    return std::move(*joins);
  };
  {
    testing::ScratchDir dir;
    auto joins = fresh(dir);
    const std::string bytes = testing::read_file(joins->bucket_path(0));
    std::string flipped = bytes;
    flipped[bytes.size() / 2] ^= 0x20;
    testing::write_file(joins->bucket_path(0), flipped);
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "flipped byte";
    testing::write_file(joins->bucket_path(0), bytes.substr(0, bytes.size() - 9));
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "truncated";
    std::filesystem::remove(joins->bucket_path(0));
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "missing";
    // A whole record lost: one edge seen once.
    const std::vector<BorderEdgeRecord> lone = {{1, 2, 0, false}, {2, 1, PieceId{1} << 32, false}, {4, 5, 0, false}};
    forge(joins->bucket_path(0), kBorderEdgeRecordKind, kBorderEdgeRecordBytes, border_bytes(lone, 0));
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "lost record";
    // A feature byte other than 0 or 1.
    forge(joins->bucket_path(0), kBorderEdgeRecordKind, kBorderEdgeRecordBytes, border_bytes({lone[0], lone[1]}, 2));
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "feature byte";
    // The right records under the wrong kind.
    forge(joins->bucket_path(0), kFaceAnswerRecordKind, kBorderEdgeRecordBytes, border_bytes({lone[0], lone[1]}, 0));
    EXPECT_EQ(join(*joins, got).code(), Code::kBadInput) << "kind";
    forge(joins->bucket_path(0), kBorderEdgeRecordKind, kBorderEdgeRecordBytes, border_bytes({lone[0], lone[1]}, 0));
    ASSERT_TRUE(join(*joins, got).is_ok());
    ASSERT_EQ(got.size(), 1u);
  }
  {
    // A record in a bucket its faces do not hash to.
    testing::ScratchDir dir;
    std::vector<ChunkPieces> none(2);
    auto joins = spilled(dir.path().string(), none, 8);
    ASSERT_TRUE(joins.is_ok());
    const std::size_t b = border_bucket(1, 2, 8);
    const std::vector<BorderEdgeRecord> edge = {{1, 2, 0, false}, {2, 1, PieceId{1} << 32, false}};
    forge((*joins)->bucket_path((b + 1) % 8), kBorderEdgeRecordKind, kBorderEdgeRecordBytes, border_bytes(edge, 0));
    EXPECT_EQ(join(**joins, got).code(), Code::kBadInput);
  }
}

TEST(PieceJoins, AnswersComeFromTheOwnersFiles) {
  testing::ScratchDir dir;
  std::vector<ChunkPieces> chunks(3);
  chunks[0].border_faces = {{0, PieceId{0} << 32}, {3, PieceId{0} << 32 | 1}, {9, PieceId{0} << 32}};
  chunks[2].border_faces = {{4, PieceId{2} << 32 | 7}};
  auto joins = PieceJoinFiles::create(dir.path().string(), 3, 1);
  ASSERT_TRUE(joins.is_ok());
  ASSERT_TRUE((*joins)->spill(0, chunks[0]).is_ok());
  ASSERT_TRUE((*joins)->spill(2, chunks[2]).is_ok());
  ASSERT_TRUE((*joins)->finish().is_ok());  // chunk 1: an empty file
  EXPECT_EQ((*joins)->answer_records(), 4u);
  const std::vector<std::uint32_t> owners = {2, 0, 0, 1, 0, 0, 2};
  const std::vector<std::uint64_t> faces = {4, 9, 3, 1, 3, 5, 0};
  std::vector<PieceId> pieces(faces.size());
  ASSERT_TRUE((*joins)->look_up(owners, faces, pieces).is_ok());
  const std::vector<PieceId> want = {PieceId{2} << 32 | 7, PieceId{0} << 32, PieceId{0} << 32 | 1, kNoPiece,
                                     PieceId{0} << 32 | 1, kNoPiece, kNoPiece};
  EXPECT_EQ(pieces, want);
  // An owner that does not exist.
  const std::vector<std::uint32_t> bad_owner = {3};
  const std::vector<std::uint64_t> one_face = {4};
  std::vector<PieceId> one(1);
  EXPECT_EQ((*joins)->look_up(bad_owner, one_face, one).code(), Code::kBadInput);
  // Damaged, forged or missing answer files.
  using Part = PieceJoinFiles::Part;
  const std::vector<std::uint32_t> owner2 = {2};
  testing::ScratchDir forged;
  forge_part(**joins, Part::kAnswers, 2, kFaceAnswerRecordKind, kFaceAnswerRecordBytes,
             answer_bytes({{3, PieceId{2} << 32}, {2, PieceId{2} << 32}}), forged);
  EXPECT_EQ((*joins)->look_up(owner2, one_face, one).code(), Code::kBadInput) << "not ascending";
  forge_part(**joins, Part::kAnswers, 2, kFaceAnswerRecordKind, kFaceAnswerRecordBytes, answer_bytes({{4, PieceId{1} << 32}}), forged);
  EXPECT_EQ((*joins)->look_up(owner2, one_face, one).code(), Code::kBadInput) << "piece of another chunk";
  forge_part(**joins, Part::kAnswers, 2, kFaceAnswerRecordKind, kFaceAnswerRecordBytes, answer_bytes({{4, PieceId{2} << 32 | 7}}),
             forged);
  ASSERT_TRUE((*joins)->look_up(owner2, one_face, one).is_ok());
  EXPECT_EQ(one[0], PieceId{2} << 32 | 7);
  truncate_part(**joins, Part::kAnswers, 2, (*joins)->placed(Part::kAnswers, 2).segment.bytes / 2);
  EXPECT_EQ((*joins)->look_up(owner2, one_face, one).code(), Code::kBadInput) << "truncated";
  std::filesystem::remove((*joins)->segment_path((*joins)->placed(Part::kAnswers, 2).file));
  EXPECT_EQ((*joins)->look_up(owner2, one_face, one).code(), Code::kBadInput) << "missing";
  // Answers that are not ascending are refused at spill time (our own bug, not bad input).
  ChunkPieces unsorted;
  unsorted.border_faces = {{5, PieceId{1} << 32}, {2, PieceId{1} << 32}};
  testing::ScratchDir other;
  auto fresh = PieceJoinFiles::create(other.path().string(), 3, 1);
  ASSERT_TRUE(fresh.is_ok());
  EXPECT_EQ((*fresh)->spill(1, unsorted).code(), Code::kProcessing);
}

TEST(PieceJoins, StarsComeBackAsSpilledAndDamageIsBadInput) {
  testing::ScratchDir dir;
  std::vector<ChunkPieces> chunks(2);
  StarEntry a, b;
  a.face = 7;
  a.next = 9;
  a.owner = 1;
  a.next_owner = 0x7FFFFFFFu;
  a.entering_break = 1;
  b.face = 1ull << 40;
  b.owner = 0;
  chunks[1].star = {a, b};
  chunks[1].candidates = {{5, 0, 2}};
  auto joins = PieceJoinFiles::create(dir.path().string(), 2, 1);
  ASSERT_TRUE(joins.is_ok());
  ASSERT_TRUE((*joins)->spill(0, chunks[0]).is_ok());
  ASSERT_TRUE((*joins)->spill(1, chunks[1]).is_ok());
  EXPECT_TRUE(chunks[1].star.empty());
  ASSERT_TRUE((*joins)->finish().is_ok());
  std::vector<StarEntry> got;
  ASSERT_TRUE((*joins)->read_stars(0, got).is_ok());
  EXPECT_TRUE(got.empty());
  ASSERT_TRUE((*joins)->read_stars(1, got).is_ok());
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].face, 7u);
  EXPECT_EQ(got[0].next, 9u);
  EXPECT_EQ(got[0].owner, 1u);
  EXPECT_EQ(got[0].next_owner, 0x7FFFFFFFu);
  EXPECT_EQ(got[0].entering_break, 1u);
  EXPECT_EQ(got[1].face, 1ull << 40);
  EXPECT_EQ(got[1].next, kNoFaceId);
  EXPECT_EQ(got[1].entering_break, 0u);
  EXPECT_EQ((*joins)->read_stars(2, got).code(), Code::kBadInput) << "no such chunk";
  using Part = PieceJoinFiles::Part;
  EXPECT_EQ((*joins)->placed(Part::kStars, 0).file, PieceJoinFiles::Placed{}.file) << "no stars, no file";
  truncate_part(**joins, Part::kStars, 1, 5);
  EXPECT_EQ((*joins)->read_stars(1, got).code(), Code::kBadInput) << "truncated";
  std::filesystem::remove((*joins)->segment_path((*joins)->placed(Part::kStars, 1).file));
  EXPECT_EQ((*joins)->read_stars(1, got).code(), Code::kBadInput) << "missing";
}

TEST(PieceJoins, PiecesAndTheirAdjacencyComeBackAsSpilled) {
  testing::ScratchDir dir;
  ChunkPieces chunk;
  chunk.pieces = {{PieceId{1} << 32, 7, 120, 1ull << 35, 0xFEDCBA9876543210ull}, {PieceId{1} << 32 | 1, 0xFFFFFFFFu, 3, 9}};
  chunk.adjacency = {{PieceId{1} << 32, PieceId{1} << 32 | 1, 4}};
  auto joins = PieceJoinFiles::create(dir.path().string(), 2, 1);
  ASSERT_TRUE(joins.is_ok());
  ASSERT_TRUE((*joins)->spill(1, chunk).is_ok());
  EXPECT_TRUE(chunk.pieces.empty());
  EXPECT_TRUE(chunk.adjacency.empty());
  ASSERT_TRUE((*joins)->finish().is_ok());
  std::vector<PieceRecord> pieces;
  std::vector<PieceAdjacencyRecord> adjacency;
  ASSERT_TRUE((*joins)->read_pieces(0, pieces, adjacency).is_ok());
  EXPECT_TRUE(pieces.empty() && adjacency.empty());
  ASSERT_TRUE((*joins)->read_pieces(1, pieces, adjacency).is_ok());
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_EQ(pieces[0].piece, PieceId{1} << 32);
  EXPECT_EQ(pieces[0].label, 7u);
  EXPECT_EQ(pieces[0].faces, 120u);
  EXPECT_EQ(pieces[0].min_face, 1ull << 35);
  EXPECT_EQ(pieces[0].min_key, 0xFEDCBA9876543210ull);
  EXPECT_EQ(pieces[1].label, 0xFFFFFFFFu);
  ASSERT_EQ(adjacency.size(), 1u);
  EXPECT_EQ(adjacency[0].b, PieceId{1} << 32 | 1);
  EXPECT_EQ(adjacency[0].edges, 4u);
  // The adjacency follows the pieces in the same file: cutting it off leaves the pieces whole.
  truncate_part(**joins, PieceJoinFiles::Part::kAdjacency, 1, 1);
  EXPECT_TRUE((*joins)->read_pieces(1, pieces).is_ok());
  EXPECT_EQ((*joins)->read_pieces(1, pieces, adjacency).code(), Code::kBadInput) << "adjacency truncated";
  truncate_part(**joins, PieceJoinFiles::Part::kPieces, 1, 1);
  EXPECT_EQ((*joins)->read_pieces(1, pieces).code(), Code::kBadInput) << "pieces truncated";
}

TEST(PieceJoins, FacePiecesComeBackForTheOwnedFaces) {
  testing::ScratchDir dir;
  ChunkMesh mesh;
  mesh.chunk = 0;
  mesh.triangles.resize(4);
  mesh.owned_face = {1, 0, 1, 1};
  auto joins = PieceJoinFiles::create(dir.path().string(), 1, 1);
  ASSERT_TRUE(joins.is_ok());
  ASSERT_TRUE((*joins)->write_face_pieces(0, mesh, {2, 0xFFFFFFFFu, 0, 1}).is_ok());
  std::vector<std::uint32_t> back;
  ASSERT_TRUE((*joins)->read_face_pieces(0, mesh, back).is_ok());
  EXPECT_EQ(back, (std::vector<std::uint32_t>{2, 0xFFFFFFFFu, 0, 1}));
  ChunkMesh other = mesh;
  other.owned_face = {1, 1, 1, 1};  // a mesh that owns another number of faces than the file holds
  EXPECT_EQ((*joins)->read_face_pieces(0, other, back).code(), Code::kBadInput);
  EXPECT_EQ((*joins)->read_face_pieces(1, mesh, back).code(), Code::kBadInput) << "no such chunk";
  truncate_part(**joins, PieceJoinFiles::Part::kFacePieces, 0, 2);
  EXPECT_EQ((*joins)->read_face_pieces(0, mesh, back).code(), Code::kBadInput) << "truncated";
}

}  // namespace
}  // namespace gaussmesh::stream
