// Every file in fixtures/bad/ gives one clear, located, single-line kBadInput error through
// detection (as the CLI reads files) and through the reader its extension names.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "tests/format/text_formats_support.h"

namespace gaussmesh::testing {
namespace {

using format::Code;

struct BadFixture {
  const char* file;
  const char* where_suffix;  // after the path: "" or ":LINE"
  const char* message;       // a substring the message must hold
  // Through a pipe no size is known, so the OFF size plausibility check cannot run and the
  // error comes from the line where the data stops making sense.
  const char* pipe_where;
  const char* pipe_message;
};

// invalid.off declares 3 vertices and 4 faces in 53 bytes, then gives a face of 0 vertices.
// malformed.obj is a real cube with broken faces: "f 4 12 2 1" names a vertex past the 8 it
// defines (and later lines use 0 and a relative -1), so it is invalid OBJ, not just unusual.
// malformed2.obj has a bare "f" with no vertices. nan-vertex.ply and inf-vertex.ply are binary
// tetrahedra whose first vertex is (nan, 0, 0) and (inf, 0, 0), made for this project.
const BadFixture kBadFixtures[] = {
    {"empty.obj", "", "empty", "<stdin>", "empty"},
    {"empty.off", "", "empty", "<stdin>", "empty"},
    {"empty.ply", "", "empty", "<stdin>", "empty"},
    {"invalid.off", ":2", "declares 3 vertices and 4 faces", "<stdin>:6", "face 0 has 0 vertices"},
    {"malformed.obj", ":23", "refers to vertex 12 but only 8 vertices are defined so far", "<stdin>:23",
     "refers to vertex 12"},
    {"malformed2.obj", ":23", "face has 0 vertices", "<stdin>:23", "face has 0 vertices"},
    {"nan-vertex.ply", ": byte 233", "vertex 0 has a coordinate that is not a finite number", "<stdin>: byte 233",
     "vertex 0 has a coordinate that is not a finite number"},
    {"inf-vertex.ply", ": byte 233", "vertex 0 has a coordinate that is not a finite number", "<stdin>: byte 233",
     "vertex 0 has a coordinate that is not a finite number"},
    {"OutOfMemory.off", ":2", "declares 353535235358 vertices", "<stdin>:2",
     "declares 353535235358 vertices; at most 4294967295 are supported"},
};

TEST(BadFixtures, EachGivesOneLocatedErrorThroughDetection) {
  for (const BadFixture& b : kBadFixtures) {
    std::string path = fixture(std::string("bad/") + b.file);
    ReadOutcome r = read_path(path);
    ASSERT_FALSE(r.status.is_ok()) << b.file;
    std::printf("  %s\n", r.status.to_string().c_str());  // what a user would see
    EXPECT_EQ(r.status.code(), Code::kBadInput) << b.file;
    EXPECT_EQ(r.status.where(), path + b.where_suffix) << r.status.to_string();
    EXPECT_NE(r.status.message().find(b.message), std::string::npos) << r.status.to_string();
    EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
    EXPECT_FALSE(r.ended) << b.file;
  }
}

TEST(BadFixtures, EachGivesOneLocatedErrorThroughAPipe) {
  for (const BadFixture& b : kBadFixtures) {
    ReadOutcome r = read_stdin(read_file(fixture(std::string("bad/") + b.file)), /*via_pipe=*/true);
    ASSERT_FALSE(r.status.is_ok()) << b.file;
    std::printf("  %s\n", r.status.to_string().c_str());
    EXPECT_EQ(r.status.code(), Code::kBadInput) << b.file;
    EXPECT_EQ(r.status.where(), b.pipe_where) << r.status.to_string();
    EXPECT_NE(r.status.message().find(b.pipe_message), std::string::npos) << r.status.to_string();
    EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
  }
}

TEST(BadFixtures, EachFailsInTheReaderItsExtensionNames) {
  for (const BadFixture& b : kBadFixtures) {
    std::string path = fixture(std::string("bad/") + b.file);
    MeshFormat f = format::format_from_extension(path);
    ASSERT_NE(f, MeshFormat::kUnknown) << b.file;
    ReadOutcome r = read_path(path, f);
    ASSERT_FALSE(r.status.is_ok()) << b.file;
    EXPECT_EQ(r.status.code(), Code::kBadInput) << b.file;
    EXPECT_EQ(r.status.where().rfind(path, 0), 0u) << r.status.to_string();
    EXPECT_TRUE(single_line(r.status)) << r.status.to_string();
  }
}

TEST(BadFixtures, TheListCoversTheDirectory) {
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(fixture("bad"))) {
    ++files;
    bool listed = false;
    for (const BadFixture& b : kBadFixtures) listed |= entry.path().filename() == b.file;
    EXPECT_TRUE(listed) << entry.path() << " has no expectation here";
  }
  EXPECT_EQ(files, std::size(kBadFixtures));
}

}  // namespace
}  // namespace gaussmesh::testing
