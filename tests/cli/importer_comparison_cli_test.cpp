// Real exporters' files against an independent importer: every PLY, OBJ, OFF and STL file of
// assimp's test models (Debian's assimp-testmodels: Blender, 3ds Max, VCG and hand-made files)
// read by `gaussmesh info` and by `assimp info` (assimp-utils), triangle counts compared.
// scripts/bootstrap installs both for the test suite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

namespace fs = std::filesystem;

// Where Debian's assimp-testmodels puts them; GAUSSMESH_IMPORTER_CORPUS overrides.
fs::path corpus_dir() {
  const char* dir = std::getenv("GAUSSMESH_IMPORTER_CORPUS");
  return dir ? fs::path(dir) : fs::path("/usr/share/assimp/models");
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Files that gaussmesh refuses and assimp reads, with what gaussmesh's one line must say and
// why refusing is right: each is ambiguous or broken, and reading it would mean guessing.
struct Refusal {
  const char* message;
  const char* why;
};
const std::map<std::string, Refusal>& expected_refusals() {
  static const std::map<std::string, Refusal> refusals = {
      {"OBJ/box_UTF16BE.obj", {"text encoded as UTF-16 (big-endian byte-order mark)", "an encoding the text readers do not take"}},
      {"OBJ/number_formats.obj", {"vertex z: '3.1+e2' is not a number", "assimp reads '3.1+e2' as 3.1"}},
      {"OFF/invalid.off", {"declares 3 vertices and 4 faces", "its body ends after 2 of the 4 faces it declares"}},
      {"PLY/issue623.ply", {"line ends before property vertex_indices", "the header gives each vertex a list its body does not hold"}},
      {"PLY/pond.0.ply", {"vertex 714 has a coordinate that is not a finite number", "NaN coordinates are refused (docs/cli.md)"}},
  };
  return refusals;
}

// The triangles assimp finds: its importer with triangulation and meshes split by primitive type
// (-tri -sbpt, nothing else), summed over the meshes of triangles. Empty when it fails.
std::optional<std::uint64_t> assimp_triangles(const fs::path& file) {
  CommandResult r = run_command("assimp info " + shell_quote(file.string()) + " -tri -sbpt 2>&1");
  if (r.exit_code != 0) return std::nullopt;
  static const std::regex mesh_line(R"(^\s+\d+ \(.*\): \[\d+ / \d+ / (\d+) \| (\w+)\]\s*$)");
  std::uint64_t triangles = 0;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_match(line, m, mesh_line) && m[2] == "triangle") triangles += std::stoull(m[1]);
  }
  return triangles;
}

// The corpus's PLY, OBJ, OFF and STL files (the STL and OFF folders hold one without extension).
std::vector<fs::path> corpus_files(const fs::path& corpus) {
  std::vector<fs::path> files;
  for (const char* folder : {"PLY", "OBJ", "OFF", "STL"}) {
    for (const fs::directory_entry& e : fs::directory_iterator(corpus / folder)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (e.is_regular_file() && (ext.empty() || ext == ".ply" || ext == ".obj" || ext == ".off" || ext == ".stl")) {
        files.push_back(e.path());
      }
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ImporterComparison, FaceCountsMatchAssimpOnRealExportedFiles) {
  const fs::path corpus = corpus_dir();
  if (run_command("command -v assimp").exit_code != 0 || !fs::is_directory(corpus / "PLY")) {
    GTEST_SKIP() << "needs assimp-utils and assimp-testmodels (scripts/bootstrap test installs them), or "
                    "GAUSSMESH_IMPORTER_CORPUS naming a copy of assimp's models";
  }
  const std::vector<fs::path> files = corpus_files(corpus);
  ASSERT_GE(files.size(), 40u) << "the corpus is smaller than assimp-testmodels' 43 files";

  size_t compared = 0, refused = 0;
  bool saw_blender_ply = false;
  for (const fs::path& file : files) {
    const std::string name = fs::relative(file, corpus).string();
    SCOPED_TRACE(name);
    CommandResult ours = run_command(shell_quote(gaussmesh_binary()) + " info " + shell_quote(file.string()) + " --report -");
    std::optional<std::uint64_t> theirs = assimp_triangles(file);
    auto refusal = expected_refusals().find(name);
    if (refusal != expected_refusals().end()) {
      EXPECT_EQ(ours.exit_code, 2) << ours.err;
      EXPECT_NE(ours.err.find(refusal->second.message), std::string::npos) << ours.err;
      EXPECT_EQ(std::count(ours.err.begin(), ours.err.end(), '\n'), 1) << ours.err;
      ++refused;
      continue;
    }
    ASSERT_EQ(ours.exit_code, 0) << ours.err;
    std::uint64_t faces = nlohmann::json::parse(ours.out).at("input_faces").get<std::uint64_t>();
    if (!theirs) continue;  // assimp refuses it: nothing to compare
    EXPECT_EQ(faces, *theirs);
    ++compared;
    if (name == "PLY/Wuson.ply") {
      saw_blender_ply = true;
      EXPECT_EQ(faces, 3732u);
      EXPECT_NE(ours.err.find("warning: line 3: header line with no PLY keyword skipped: 'Created by Blender3D 247"),
                std::string::npos)
          << ours.err;
    }
  }
  EXPECT_TRUE(saw_blender_ply);
  EXPECT_EQ(refused, expected_refusals().size());
  EXPECT_GE(compared, 35u);
  std::printf("compared %zu files with assimp, %zu refused as expected, of %zu\n", compared, refused, files.size());
}

// Every file of the corpus that gaussmesh reads and that has faces, simplified in core plain and
// at 50 % and 10 %: exit 0, and an output that is a manifold without degenerate or duplicate
// faces, whatever the exporter left in the input (non-manifold vertices, fins, degenerate and
// duplicate faces, polygons).
TEST(ImporterComparison, SimplifyKeepsItsPromisesOnRealExportedFiles) {
  const fs::path corpus = corpus_dir();
  if (!fs::is_directory(corpus / "PLY")) {
    GTEST_SKIP() << "needs assimp-testmodels (scripts/bootstrap test installs it), or GAUSSMESH_IMPORTER_CORPUS";
  }
  ScratchDir dir;
  std::size_t simplified = 0;
  for (const fs::path& file : corpus_files(corpus)) {
    const std::string name = fs::relative(file, corpus).string();
    if (expected_refusals().count(name)) continue;
    const auto info = run_command(shell_quote(gaussmesh_binary()) + " info " + shell_quote(file.string()) + " --report -");
    ASSERT_EQ(info.exit_code, 0) << name << ": " << info.err;
    if (nlohmann::json::parse(info.out).at("input_faces").get<std::uint64_t>() < 4) continue;
    for (const std::string target : {"", " --ratio 0.5", " --ratio 0.1"}) {
      SCOPED_TRACE(name + target);
      const std::string out = dir.file("out.ply");
      const auto run = run_command(shell_quote(gaussmesh_binary()) + " simplify " + shell_quote(file.string()) + " -o " + shell_quote(out) +
                                   " --engine in-core -q" + target);
      ASSERT_EQ(run.exit_code, 0) << run.err;
      const auto after = run_command(shell_quote(gaussmesh_binary()) + " info " + shell_quote(out) + " --report -");
      ASSERT_EQ(after.exit_code, 0) << after.err;
      const nlohmann::json t = nlohmann::json::parse(after.out);
      EXPECT_EQ(t.at("degenerate_faces"), 0);
      EXPECT_EQ(t.at("duplicate_faces"), 0);
      EXPECT_EQ(t.at("non_manifold_edges"), 0);
      EXPECT_EQ(t.at("non_manifold_vertices"), 0);
      EXPECT_TRUE(t.at("consistently_oriented").get<bool>());
    }
    ++simplified;
  }
  EXPECT_GE(simplified, 25u);
  std::printf("simplified %zu files plain, at 50 %% and at 10 %%\n", simplified);
}

}  // namespace
}  // namespace gaussmesh::testing
