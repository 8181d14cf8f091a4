// Tests of temporary entries' ownership: a held entry is never taken for a dead run's, a
// released one is removed, names outside the prefix, half-made entries and symlinks are left,
// and OutputFile clears what a killed run left beside its output.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "format/output_file.h"
#include "format/temp_ownership.h"
#include "tests/support/test_util.h"

namespace gaussmesh::format {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDir;

TEST(TempOwnership, AHeldEntryStaysAndAReleasedOneGoes) {
  ScratchDir dir;
  const std::string parent = dir.path().string();
  std::string made;
  auto owned_dir = create_owned_directory(parent, "gm-test-", made);
  ASSERT_TRUE(owned_dir.is_ok()) << owned_dir.status().to_string();
  EXPECT_EQ(fs::path(made).parent_path(), dir.path());
  EXPECT_EQ(fs::path(made).filename().string().rfind("gm-test-", 0), 0u) << made;
  testing::write_file(made + "/data.bin", "spilled");
  bool exists = true;
  auto owned_file = create_owned_file(parent + "/gm-test-file.rec", exists);
  ASSERT_TRUE(owned_file.is_ok()) << owned_file.status().to_string();
  EXPECT_FALSE(exists);

  // A second create of the same file is refused as existing.
  auto again = create_owned_file(parent + "/gm-test-file.rec", exists);
  EXPECT_FALSE(again.is_ok());
  EXPECT_TRUE(exists);

  EXPECT_EQ(remove_dead_runs_temps(parent, "gm-test-"), 0u);
  EXPECT_TRUE(fs::exists(made + "/data.bin"));
  EXPECT_TRUE(fs::exists(parent + "/gm-test-file.rec"));

  *owned_dir = {};  // as if the run had died: the kernel drops the lock with the descriptor
  *owned_file = {};
  EXPECT_EQ(remove_dead_runs_temps(parent, "gm-test-"), 2u);
  EXPECT_FALSE(fs::exists(made));
  EXPECT_FALSE(fs::exists(parent + "/gm-test-file.rec"));
}

TEST(TempOwnership, OtherNamesHalfMadeEntriesAndSymlinksAreLeft) {
  ScratchDir dir, elsewhere;
  const std::string parent = dir.path().string();
  testing::write_file(parent + "/keep-me.txt", "x");
  testing::write_file(parent + "/gm-test-half.creating", "x");  // a file between create and lock
  fs::create_directory(parent + "/creating-gm-test-abcdef");     // a directory between mkdtemp and rename
  const std::string target = elsewhere.file("precious");
  fs::create_directory(target);
  testing::write_file(target + "/file", "x");
  fs::create_directory_symlink(target, parent + "/gm-test-link");
  EXPECT_EQ(remove_dead_runs_temps(parent, "gm-test-"), 0u);
  EXPECT_TRUE(fs::exists(parent + "/keep-me.txt"));
  EXPECT_TRUE(fs::exists(parent + "/gm-test-half.creating"));
  EXPECT_TRUE(fs::exists(parent + "/creating-gm-test-abcdef"));
  EXPECT_TRUE(fs::exists(target + "/file"));
  EXPECT_TRUE(fs::is_symlink(parent + "/gm-test-link"));
}

TEST(TempOwnership, AnOutputFileClearsWhatAKilledRunLeftBesideIt) {
  ScratchDir dir;
  const std::string out = dir.file("mesh.drc");
  // A killed run's temporary file of this output (nobody holds it), and a live run's, held here
  // through a descriptor of its own as another process would hold it.
  const std::string dead = dir.file(".mesh.drc.gaussmesh-run-4242-0badf00d.tmp");
  testing::write_file(dead, "half an output");
  bool exists = false;
  auto live = create_owned_file(dir.file(".mesh.drc.gaussmesh-run-4343-12345678.tmp"), exists);
  ASSERT_TRUE(live.is_ok());
  const std::string other = dir.file(".other.drc.gaussmesh-run-4242-0badf00d.tmp");
  testing::write_file(other, "another output's");
  const std::string unlocked_kind = dir.file(".mesh.drc.gaussmesh-4242-0badf00d.tmp");
  testing::write_file(unlocked_kind, "an older version's, maybe alive");

  auto file = OutputFile::create(out, true);
  ASSERT_TRUE(file.is_ok()) << file.status().to_string();
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(dir.file(".mesh.drc.gaussmesh-run-4343-12345678.tmp")));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(unlocked_kind));
  ASSERT_TRUE((*file)->write("bytes", 5).is_ok());
  ASSERT_TRUE((*file)->commit().is_ok());
  EXPECT_EQ(testing::read_file(out), "bytes");
}

}  // namespace
}  // namespace gaussmesh::format
