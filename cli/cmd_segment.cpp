// gaussmesh segment: spherical segmentation of a closed mesh (paper §6): the input mesh as a PLY
// with a per-face segment id and colour, and the --report JSON (DESIGN §5).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/report.h"
#include "cli/sampling_options.h"
#include "format/mesh_writer.h"
#include "format/output_file.h"
#include "stream/core/mesh.h"
#include "stream/analysis/segmentation.h"

namespace gaussmesh::cli {
namespace {

using format::Code;
using format::Status;

// Segmentation wants a coarse G: what matters is the count of pre-images per Gaussian triangle.
constexpr std::uint32_t kSegmentFrequency = 1;

struct SegmentCommandOptions {
  std::string input = "-";
  std::string output;
  std::string report;
  std::uint32_t max_smooth = stream::SegmentationOptions{}.max_smooth;
  bool quiet = false;
  bool verbose = false;
  SamplingOptions sampling;
};

// Distinct colours for the first segments (g+1 is small), then a hash.
void segment_colour(std::uint32_t id, std::uint8_t rgb[3]) {
  static const std::uint8_t kPalette[][3] = {{220, 50, 47},  {60, 170, 60},  {38, 110, 210}, {230, 190, 30},
                                             {160, 80, 200}, {30, 180, 190}, {240, 120, 40}, {140, 140, 140}};
  if (id < 8) {
    for (int i = 0; i < 3; ++i) rgb[i] = kPalette[id][i];
    return;
  }
  std::uint32_t h = id * 2654435761u;
  h ^= h >> 15;
  for (int i = 0; i < 3; ++i) rgb[i] = static_cast<std::uint8_t>(64 + (h >> (8 * i) & 0xFF) * 3 / 4);
}

bool ends_with(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    const char c = s[s.size() - suffix.size() + i];
    if ((c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c) != suffix[i]) return false;
  }
  return true;
}

Status write_segments(const std::string& path, const stream::Mesh& mesh, const stream::SegmentationResult& r) {
  auto out = format::OutputFile::create(path, true);
  if (!out) return out.status();
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint8_t> red(nf), green(nf), blue(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    std::uint8_t rgb[3];
    segment_colour(r.face_segment[f], rgb);
    red[f] = rgb[0];
    green[f] = rgb[1];
    blue[f] = rgb[2];
  }
  format::PlyWriteOptions options;
  options.comments = {"gaussmesh segment: faces coloured per segment; label = Gaussian triangle of the smoothed "
                      "normal, pole = 1 for faces of pole patches"};
  options.face_attributes = {{"red", std::span<const std::uint8_t>(red)},
                             {"green", std::span<const std::uint8_t>(green)},
                             {"blue", std::span<const std::uint8_t>(blue)},
                             {"segment", std::span<const std::uint32_t>(r.face_segment)},
                             {"label", std::span<const std::uint32_t>(r.face_label)},
                             {"pole", std::span<const std::uint8_t>(r.face_pole)}};
  GM_RETURN_IF_ERROR(format::write_ply(**out, mesh.view(), options));
  return (*out)->commit();
}

int run_segment(SegmentCommandOptions o) {
  if (o.quiet) set_verbosity(0);
  if (o.verbose) set_verbosity(2);
  if (o.output != "-" && !ends_with(o.output, ".ply")) {
    return report_error(Status::error(Code::kUsage, "-o", "segment writes PLY (per-face segment and colour): give a .ply name or '-'"));
  }
  if (o.sampling.orientations != 1) {
    return report_error(Status::error(Code::kUsage, "--orientations", "segment uses one orientation of G"));
  }
  if (o.sampling.frequency < 0 && o.sampling.level < 0) o.sampling.frequency = kSegmentFrequency;  // not given
  auto spheres = gauss_sphere_options(o.sampling);
  if (!spheres) return report_error(spheres.status());
  if (o.sampling.smooth > o.max_smooth) {
    return report_error(Status::error(Code::kUsage, "--smooth", "the starting smoothing exceeds --max-smooth"));
  }
  auto gauss = stream::GaussSphere::create(spheres->front());
  if (!gauss) return report_error(gauss.status());
  if (o.input == "-" && ::isatty(0)) {
    return report_error(Status::error(Code::kUsage, "segment", "no input file, and standard input is a terminal"));
  }
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto mesh = stream::load_mesh(o.input);
  if (!mesh) return report_error(mesh.status());
  const auto t1 = Clock::now();
  stream::SegmentationOptions so;
  so.min_smooth = o.sampling.smooth;
  so.max_smooth = o.max_smooth;
  auto segmented = stream::segment_mesh(mesh->view(), *gauss, so);
  if (!segmented) {
    const std::string name = o.input == "-" ? "<stdin>" : o.input;
    const Status& s = segmented.status();
    return report_error(Status::error(s.code(), name + ": " + s.where(), s.message()));
  }
  const auto t2 = Clock::now();
  const stream::SegmentationResult& r = *segmented;
  if (Status s = write_segments(o.output, *mesh, r); !s) return report_error(s);
  const auto t3 = Clock::now();
  std::size_t duplicates = 0;
  for (std::size_t d : r.duplicate_labels) duplicates += d;
  if (verbosity() >= 1 && (r.smooth_cap_hit || r.merges > 0)) {
    std::fprintf(stderr,
                 "gaussmesh: segment: note: %s%s%zu greedy aggregates merged into %zu segments (genus %u); "
                 "%zu labels repeat inside a segment\n",
                 r.smooth_cap_hit ? "smoothing stopped at the cap " : "",
                 r.smooth_cap_hit ? std::to_string(r.smooth_iterations).append(" with some Gaussian triangle over g+1 pre-images; ").c_str() : "",
                 r.greedy_aggregates, r.segment_count, r.genus, duplicates);
  }
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: segment: genus %u, %zu segments, %u smoothing iterations, %zu poles, %zu patches\n",
                 r.genus, r.segment_count, r.smooth_iterations, r.poles, r.patch_count);
  }
  if (!o.report.empty()) {
    auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
    const stream::GaussSphere& g = *gauss;
    Json j;
    j["input"] = o.input == "-" ? "<stdin>" : o.input;
    j["input_vertices"] = mesh->positions.size();
    j["input_faces"] = mesh->triangles.size();
    j["euler_characteristic"] = r.euler_characteristic;
    j["genus"] = r.genus;
    j["base"] = stream::gauss_base_name(g.options().base);
    j["frequency"] = g.options().frequency;
    j["gauss_vertices"] = g.vertex_count();
    j["gauss_triangles"] = g.triangle_count();
    j["smooth_iterations"] = r.smooth_iterations;
    j["smooth_cap"] = o.max_smooth;
    j["smooth_cap_hit"] = r.smooth_cap_hit;
    j["max_preimages"] = r.max_preimages;
    j["patches"] = r.patch_count;
    j["noise_patches"] = r.noise_patches;
    j["poles"] = r.poles;
    j["empty_labels"] = r.empty_labels;
    j["pole_patches"] = r.pole_patches;
    j["pole_faces"] = r.pole_faces;
    j["greedy_aggregates"] = r.greedy_aggregates;
    j["merges"] = r.merges;
    j["segments"] = r.segment_count;
    j["segment_faces"] = r.segment_faces;
    j["duplicate_labels"] = r.duplicate_labels;
    j["peak_rss_bytes"] = peak_rss_bytes();
    j["seconds"] = {{"read", secs(t0, t1)}, {"segment", secs(t1, t2)}, {"write", secs(t2, t3)}};
    if (Status s = write_report(o.report, j); !s) return report_error(s);
  }
  return 0;
}

}  // namespace

void register_segment(CLI::App& app, Runner& run) {
  auto o = std::make_shared<SegmentCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "segment", "Spherical segmentation (paper §6): g+1 segments of a closed genus-g mesh, as a per-face coloured PLY");
  sub->add_option("input", o->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")->capture_default_str();
  sub->add_option("-o,--output", o->output, "Segmented mesh as a binary PLY ('-': stdout)")->required();
  sub->add_option("--report", o->report, "Write the figures as JSON to FILE ('-': stdout)");
  sub->add_option("--max-smooth", o->max_smooth, "Cap on the normal smoothing iterations")->capture_default_str();
  sub->add_flag("-q,--quiet", o->quiet, "Print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", o->verbose, "Print counts on stderr");
  // --frequency defaults to 1 here; --smooth is where the smoothing search starts.
  add_sampling_options(*sub, o->sampling);
  sub->callback([&run, o] { run = [o] { return run_segment(*o); }; });
}

}  // namespace gaussmesh::cli
