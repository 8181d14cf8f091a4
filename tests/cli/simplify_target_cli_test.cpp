// Tests for `gaussmesh simplify` with a target (--target-faces, --ratio, --max-error,
// --measure; docs/finish.md) as a user runs it: every real fixture lands on the face target or
// says why not, keeps its topology, gives the same bytes in core, out of core and through a
// pipe; bad targets are one line and exit 1 with nothing written.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "gaussmesh/gaussmesh.h"
#include "stream/core/mesh.h"
#include "stream/core/mesh_topology.h"
#include "tests/support/test_util.h"

namespace gaussmesh::testing {
namespace {

std::string q(const std::string& text) { return "'" + text + "'"; }
std::string binary() { return q(gaussmesh_binary()); }

const char* const kFixtures[] = {"cow.off",           "fandisk.off",  "homer.off",       "knot1.off",
                                 "mech-holes-shark.off", "mushroom.off", "bunny-lowres.ply"};

stream::MeshTopology topology_of(const std::string& path) {
  auto mesh = stream::load_mesh(path);
  EXPECT_TRUE(mesh.is_ok()) << path;
  if (!mesh) return {};
  auto t = stream::compute_topology(mesh->view());
  EXPECT_TRUE(t.is_ok()) << path;
  return t ? *t : stream::MeshTopology{};
}

TEST(SimplifyTargetCli, EveryFixtureLandsOnTheTargetAndKeepsItsTopology) {
  ScratchDir dir;
  for (const char* name : kFixtures) {
    const std::string in = fixture(std::string("real/") + name);
    const stream::MeshTopology before = topology_of(in);
    for (double ratio : {0.5, 0.1, 0.01, 0.001}) {
      SCOPED_TRACE(std::string(name) + " --ratio " + std::to_string(ratio));
      const std::string out = dir.file("out.ply"), report = dir.file("r.json");
      auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(out) + " --ratio " + std::to_string(ratio) +
                             " --report " + q(report));
      ASSERT_EQ(run.exit_code, 0) << run.err;
      const auto json = nlohmann::json::parse(read_file(report));
      const long target = json["target_faces"].get<long>(), faces = json["output_faces"].get<long>();
      EXPECT_EQ(target, std::max(1L, std::lround(ratio * json["input_faces"].get<double>())));
      EXPECT_LE(json["output_faces"].get<long>(), json["approximation_faces"].get<long>());
      if (json["stopped_by"] == "topology") {
        // Short of it only where every further collapse would break the topology: said on stderr.
        EXPECT_GT(faces, target);
        EXPECT_NE(run.err.find("above the target"), std::string::npos) << run.err;
      } else if (json["stopped_by"] == "approximation") {
        // Or where the finest automatic approximation has fewer faces than asked: said too.
        EXPECT_LT(faces, target);
        EXPECT_EQ(json["gauss_frequency"].get<long>(), long(kMaxAutoFrequency));
        EXPECT_EQ(faces, json["approximation_faces"].get<long>());
        EXPECT_NE(run.err.find("below the target"), std::string::npos) << run.err;
      } else {
        EXPECT_EQ(json["stopped_by"], "target");
        EXPECT_LE(faces, target);
        // Within 1 %, or one face below an odd target (a closed mesh has an even face count).
        EXPECT_GE(faces, std::min(target - 1, long(std::floor(0.99 * double(target)))));
      }
      const stream::MeshTopology after = topology_of(out);
      EXPECT_EQ(after.faces, std::size_t(faces));
      EXPECT_TRUE(after.is_manifold());
      EXPECT_EQ(after.degenerate_faces, 0u);
      EXPECT_EQ(after.zero_area_faces, 0u);
      EXPECT_EQ(after.duplicate_faces, 0u);
      EXPECT_EQ(after.is_closed(), before.is_closed());
      if (before.genus) {
        EXPECT_EQ(after.genus, before.genus);
      }
    }
  }
}

TEST(SimplifyTargetCli, InCoreOutOfCoreAndPipeGiveTheSameBytes) {
  ScratchDir dir, tmp;
  for (const char* name : kFixtures) {
    const std::string in = q(fixture(std::string("real/") + name));
    for (const std::string target : {"--ratio 0.1", "--target-faces 300 --max-error 1%"}) {
      SCOPED_TRACE(std::string(name) + " " + target);
      ASSERT_EQ(run_command(binary() + " simplify " + in + " " + target + " -o " + q(dir.file("a.drc"))).exit_code, 0);
      // 64M: under 16M some of these targets take the chunked finish, whose output follows the
      // chunks (the next test).
      const auto ooc = run_command(binary() + " simplify " + in + " " + target + " -o " + q(dir.file("b.drc")) +
                                   " --memory 64M --engine out-of-core --tmp " + q(tmp.path().string()));
      ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
      const std::string ext = std::string(name).substr(std::string(name).rfind('.') + 1);
      const auto piped = run_command("cat " + in + " | " + binary() + " simplify - --input-format " + ext + " " + target +
                                     " -o - --memory 64M --engine out-of-core --threads 1 --tmp " + q(tmp.path().string()) + " > " +
                                     q(dir.file("c.drc")));
      ASSERT_EQ(piped.exit_code, 0) << piped.err;
      const std::string a = read_file(dir.file("a.drc"));
      EXPECT_GT(a.size(), 50u);
      EXPECT_EQ(a, read_file(dir.file("b.drc")));
      EXPECT_EQ(a, read_file(dir.file("c.drc")));
      EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
    }
  }
}

TEST(SimplifyTargetCli, AnInputAboveTheBudgetIsCollapsedInChunksAndDracoOfItRefused) {
  ScratchDir dir, tmp;
  // mech-holes-shark at 50 %: collapsing it whole needs more than 16 MiB, so the chunked finish.
  const std::string in = q(fixture("real/mech-holes-shark.off"));
  const std::string common = " simplify " + in + " --ratio 0.5 --memory 16M --tmp " + q(tmp.path().string());
  // Draco needs the whole output in memory, more than 16 MiB here: refused before any collapse.
  const std::string drc = dir.file("o.drc");
  auto refused = run_command(binary() + common + " -o " + q(drc));
  EXPECT_EQ(refused.exit_code, 5) << refused.err;
  EXPECT_NE(refused.err.find("write PLY or OBJ (streamed), raise --memory or lower the target"), std::string::npos)
      << refused.err;
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(drc));
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  // PLY streams: the same job runs, within the budget's pieces, and leaves nothing behind.
  const std::string ply = dir.file("o.ply"), report = dir.file("r.json");
  auto streamed = run_command(binary() + common + " -o " + q(ply) + " --report " + q(report));
  ASSERT_EQ(streamed.exit_code, 0) << streamed.err;
  const auto json = nlohmann::json::parse(read_file(report));
  EXPECT_EQ(json["approximation"], "input");
  ASSERT_TRUE(json.contains("chunked_finish"));
  EXPECT_GE(json["chunked_finish"]["round_pieces"].size(), 2u);
  EXPECT_EQ(json["stopped_by"], "target");
  EXPECT_LE(json["output_faces"].get<long>(), json["target_faces"].get<long>());
  EXPECT_GE(json["output_faces"].get<double>(), 0.99 * json["target_faces"].get<double>() - 1);
  const stream::MeshTopology before = topology_of(fixture("real/mech-holes-shark.off")), after = topology_of(ply);
  EXPECT_EQ(after.faces, json["output_faces"].get<std::size_t>());
  EXPECT_TRUE(after.is_manifold());
  EXPECT_EQ(after.boundary_loops, before.boundary_loops);
  EXPECT_EQ(after.genus, before.genus);
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  // Without --memory the automatic budget holds the input whole, and Draco is written (from a
  // pipe, streamed as asked).
  auto automatic = run_command("cat " + in + " | " + binary() + " simplify - --input-format off --ratio 0.5 --engine out-of-core --tmp " +
                               q(tmp.path().string()) + " -o " + q(drc) + " --report " + q(dir.file("a.json")));
  EXPECT_EQ(automatic.exit_code, 0) << automatic.err;
  const auto whole = nlohmann::json::parse(read_file(dir.file("a.json")));
  EXPECT_EQ(whole["out_of_core"], true);
  EXPECT_FALSE(whole.contains("chunked_finish"));
  EXPECT_GT(whole["finish_memory_estimate_bytes"].get<double>(), 16.0 * (1 << 20));  // above what 16M would allow
}

// A mesh quantized more coarsely than its vertex spacing (as a Draco file at few bits) has many
// zero-area faces: the collapses may keep those degenerate until they go, so the target is
// reached, in core and out of core, and the output is a closed manifold of the same genus with
// no zero-area face.
TEST(SimplifyTargetCli, AMeshWithManyZeroAreaFacesReachesItsTarget) {
  ScratchDir dir, tmp;
  auto mesh = stream::load_mesh(fixture("real/homer.off"));
  ASSERT_TRUE(mesh.is_ok());
  for (auto& p : mesh->positions) {
    p = {std::round(p.x * 48) / 48, std::round(p.y * 48) / 48, std::round(p.z * 48) / 48};
  }
  const std::string in = dir.file("quantized.ply");
  {
    auto file = format::OutputFile::create(in, true);
    ASSERT_TRUE(file);
    ASSERT_TRUE(format::write_ply(**file, mesh->view(), {}).is_ok());
    ASSERT_TRUE((*file)->commit().is_ok());
  }
  const stream::MeshTopology before = topology_of(in);
  ASSERT_GT(before.zero_area_faces, before.faces / 5) << "the quantization makes many";
  for (const std::string engine : {"in-core", "out-of-core"}) {
    SCOPED_TRACE(engine);
    const std::string out = dir.file("out-" + engine + ".ply");
    auto run = run_command(binary() + " simplify " + q(in) + " -o " + q(out) + " --ratio 0.1 --engine " + engine +
                           " -q --tmp " + q(tmp.path().string()) + " --report " + q(dir.file("r.json")));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto report = nlohmann::json::parse(read_file(dir.file("r.json")));
    EXPECT_EQ(report["stopped_by"], "target");
    const stream::MeshTopology after = topology_of(out);
    EXPECT_LE(after.faces, report["target_faces"].get<std::size_t>());
    EXPECT_TRUE(after.is_manifold());
    EXPECT_TRUE(after.is_closed());
    EXPECT_EQ(after.genus, before.genus);
    EXPECT_EQ(after.zero_area_faces, 0u);
  }
}

TEST(SimplifyTargetCli, ANonManifoldInputIsSplitAndFinishedFromItself) {
  ScratchDir dir;
  // The cow with a fin on one edge: three faces there, which the finish on the input cannot
  // hold, so the run starts again with a vertex per fan (the fin comes loose) and the finish
  // collapses that. In core only: out of core such an input is refused with or without a target
  // (exit 3, docs/cli.md "Non-manifold input").
  auto cow = stream::load_mesh(fixture("real/cow.off"));
  ASSERT_TRUE(cow.is_ok());
  const auto t = cow->triangles[0];
  cow->positions.push_back({0, 0, 5});
  cow->triangles.push_back({{t.v[0], t.v[1], std::uint32_t(cow->positions.size() - 1)}});
  std::string off = "OFF\n" + std::to_string(cow->positions.size()) + " " + std::to_string(cow->triangles.size()) + " 0\n";
  for (const auto& p : cow->positions) off += std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
  for (const auto& f : cow->triangles)
    off += "3 " + std::to_string(f.v[0]) + " " + std::to_string(f.v[1]) + " " + std::to_string(f.v[2]) + "\n";
  const std::string in = dir.file("fin.off");
  write_file(in, off);
  auto run = run_command(binary() + " simplify " + q(in) + " --ratio 0.1 -o " + q(dir.file("a.drc")) + " --report " +
                         q(dir.file("r.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto json = nlohmann::json::parse(read_file(dir.file("r.json")));
  EXPECT_EQ(json["approximation"], "input");
  EXPECT_EQ(json["split_vertices"], 2);
  EXPECT_EQ(json["stopped_by"], "target");
  EXPECT_LE(json["target_faces"].get<long>() - json["output_faces"].get<long>(), 1);
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << "only the summary line: " << run.err;
}

TEST(SimplifyTargetCli, MeasureReportsTheDistanceToTheInput) {
  ScratchDir dir;
  const std::string in = q(fixture("real/cow.off")), report = dir.file("r.json");
  auto run = run_command(binary() + " simplify " + in + " --target-faces 600 --measure -o " + q(dir.file("o.ply")) +
                         " --report " + q(report));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto json = nlohmann::json::parse(read_file(report));
  ASSERT_TRUE(json.contains("measured"));
  const double hausdorff = json["measured"]["hausdorff"].get<double>(), rms = json["measured"]["rms"].get<double>();
  EXPECT_GT(hausdorff, 0);
  EXPECT_LE(rms, hausdorff);
  // The same figure `gaussmesh compare` gives for the written file (PLY: no quantization).
  auto cmp = run_command(binary() + " compare " + in + " " + q(dir.file("o.ply")) + " --report -");
  ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
  const auto compared = nlohmann::json::parse(cmp.out);
  EXPECT_NEAR(compared["hausdorff"].get<double>(), hausdorff, 1e-6 + 1e-3 * hausdorff);
  // So is the count of output faces facing away from the input (a face count: the same faces).
  ASSERT_TRUE(json["measured"].contains("facing_away_faces"));
  EXPECT_EQ(json["measured"]["facing_away_faces"].get<long>(), compared["b_to_a"]["facing_away_faces"].get<long>());
  // Out of core there is no input to measure against.
  auto ooc = run_command(binary() + " simplify " + in + " --target-faces 600 --measure --engine out-of-core -o " +
                         q(dir.file("p.drc")));
  EXPECT_EQ(ooc.exit_code, 1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("p.drc")));
}

TEST(SimplifyTargetCli, TheErrorBoundStopsEarlierThanATargetAndIsReported) {
  ScratchDir dir;
  const std::string in = q(fixture("real/homer.off")), report = dir.file("r.json");
  long last_faces = 0;
  for (const char* bound : {"0.1%", "0.5%", "2%"}) {
    auto run = run_command(binary() + " simplify " + in + " --max-error " + bound + " --target-faces 10 -o " +
                           q(dir.file("o.drc")) + " --report " + q(report));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto json = nlohmann::json::parse(read_file(report));
    EXPECT_EQ(json["stopped_by"], "max_error") << bound;
    const double diagonal_pct = std::stod(bound);
    EXPECT_GT(json["max_error"].get<double>(), 0);
    EXPECT_LE(json["estimated_error"].get<double>(), json["max_error"].get<double>() * (1 + 1e-12));
    const long faces = json["output_faces"].get<long>();
    EXPECT_GT(faces, 10) << bound;
    if (last_faces > 0) {
      EXPECT_LT(faces, last_faces) << "a looser bound keeps fewer faces: " << bound;
    }
    last_faces = faces;
    (void)diagonal_pct;
  }
}

TEST(SimplifyTargetCli, BadTargetsAreOneLineAndExitOne) {
  ScratchDir dir;
  const std::string in = q(fixture("real/cow.off")), out = q(dir.file("o.drc"));
  for (const char* bad : {"--target-faces 0", "--ratio 0", "--ratio 1.5", "--ratio -0.1", "--max-error -1",
                          "--max-error 0", "--max-error abc", "--max-error 1%%", "--target-faces 5805",
                          "--frequency nope", "--frequency 0", "--ratio 0.1 --orientations 2"}) {
    auto run = run_command(binary() + " simplify " + in + " " + bad + " -o " + out);
    EXPECT_EQ(run.exit_code, 1) << bad << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << bad << ": " << run.err;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << bad;
  }
  // Above the input's faces out of core too, once the partition has counted them.
  auto run = run_command(binary() + " simplify " + in + " --target-faces 5805 --engine out-of-core -o " + out);
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_NE(run.err.find("above the input's 5804 faces"), std::string::npos) << run.err;
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace gaussmesh::testing
