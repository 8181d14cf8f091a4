// read_by_ascending_id (stream/partition/id_indexed_file.h): the records it hands back, where it stops, and
// how it groups ids into reads (a run ends at a gap of more than kIdGapBytes of records, or
// kIdWindowRecords past its first id).
#include "stream/partition/id_indexed_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_util.h"

namespace gaussmesh::stream {
namespace {

constexpr std::size_t kRecordBytes = 12;
constexpr std::uint64_t kFirstByte = 5;  // a header before record 0, as the input's PLY body
constexpr std::uint32_t kCount = 20000;

struct Record {
  std::uint32_t a, b, c;
};

class IdIndexedFile : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string bytes(kFirstByte, 'h');
    for (std::uint32_t i = 0; i < kCount; ++i) {
      const Record r{i, 3 * i + 1, ~i};
      bytes.append(reinterpret_cast<const char*>(&r), sizeof r);
    }
    path_ = dir_.file("records.bin");
    testing::write_file(path_, bytes);
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    ASSERT_GE(fd_, 0);
  }
  void TearDown() override {
    if (fd_ >= 0) ::close(fd_);
  }
  // Reads ids and checks every record handed back; returns how many were served.
  std::size_t read(const std::vector<std::uint32_t>& ids, std::uint64_t count = kCount) {
    std::vector<std::size_t> seen;
    const std::size_t served = read_by_ascending_id(fd_, count, kRecordBytes, ids, window_, [&](std::size_t i, const std::byte* at) {
      Record r;
      std::memcpy(&r, at, sizeof r);
      EXPECT_EQ(r.a, ids[i]);
      EXPECT_EQ(r.b, 3 * ids[i] + 1);
      EXPECT_EQ(r.c, ~ids[i]);
      seen.push_back(i);
    }, kFirstByte);
    EXPECT_EQ(seen.size(), served);
    for (std::size_t k = 0; k < seen.size(); ++k) EXPECT_EQ(seen[k], k);
    return served;
  }

  testing::ScratchDir dir_;
  std::string path_;
  int fd_ = -1;
  std::vector<std::byte> window_;
};

TEST_F(IdIndexedFile, EveryIdGetsItsOwnRecordDenseSparseOrScattered) {
  std::vector<std::uint32_t> dense, sparse, scattered;
  for (std::uint32_t i = 100; i < 9000; ++i) dense.push_back(i);
  for (std::uint32_t i = 3; i < kCount; i += 997) sparse.push_back(i);
  std::uint64_t state = 5;
  for (std::uint32_t i = 0; i < kCount; ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    if ((state >> 60) == 0) scattered.push_back(i);
  }
  scattered.push_back(kCount - 1);
  for (const auto* ids : {&dense, &sparse, &scattered}) EXPECT_EQ(read(*ids), ids->size());
}

TEST_F(IdIndexedFile, ARunEndsAtAGapOrAWindowPastItsFirstId) {
  const std::uint32_t gap = static_cast<std::uint32_t>(kIdGapBytes / kRecordBytes);
  // A gap of exactly the limit keeps the run: one read, the window spans both ids.
  EXPECT_EQ(read({10, 10 + gap}), 2u);
  EXPECT_EQ(window_.size(), (gap + 1) * kRecordBytes);
  // One record more starts a new run: the last read holds the last id alone.
  EXPECT_EQ(read({10, 10 + gap + 1}), 2u);
  EXPECT_EQ(window_.size(), kRecordBytes);
  // Small gaps all the way: a run stops kIdWindowRecords past its first id.
  std::vector<std::uint32_t> ids;
  for (std::uint32_t i = 0; i < kIdWindowRecords + 10; i += 2) ids.push_back(i);
  EXPECT_EQ(read(ids), ids.size());
  EXPECT_EQ(window_.size(), (ids.back() - kIdWindowRecords + 1) * kRecordBytes);
}

TEST_F(IdIndexedFile, StopsAtTheFirstIdItCannotServe) {
  EXPECT_EQ(read({1, 2, 2, 3}), 2u);         // not ascending
  EXPECT_EQ(read({1, 5, 4}), 2u);            // going back
  EXPECT_EQ(read({1, kCount - 1, kCount}), 2u);  // beyond the records
  EXPECT_EQ(read({1, 50, 60}, 50), 1u);      // beyond the caller's count
  ::close(fd_);
  fd_ = ::open(path_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);  // cut: a short read
  ASSERT_GE(fd_, 0);
  ::close(fd_);
  fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  EXPECT_EQ(read({1, 2}), 0u);
}

}  // namespace
}  // namespace gaussmesh::stream
