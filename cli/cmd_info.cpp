// gaussmesh info: counts, bounds, boundary loops, manifoldness and genus of a mesh.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "cli/commands.h"
#include "cli/report.h"
#include "format/mesh_reader.h"
#include "stream/core/mesh.h"
#include "stream/core/mesh_topology.h"

namespace gaussmesh::cli {
namespace {

using format::Code;
using format::Status;

struct InfoOptions {
  std::string input = "-";
  std::string report;
  std::string input_format;
  bool quiet = false;
  bool verbose = false;
};

// 1234567 -> "1,234,567".
std::string grouped(unsigned long long n) {
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out.push_back(',');
    out.push_back(digits[i]);
  }
  return out;
}

std::string yes_no(bool value) { return value ? "yes" : "no"; }

Json vec_json(const format::Vec3f& v) { return Json::array({v.x, v.y, v.z}); }

void print_summary(const std::string& name, format::MeshFormat format,
                   const stream::MeshTopology& t) {
  std::printf("input                  %s (%s)\n", name.c_str(), format::format_name(format));
  std::printf("vertices               %s (%s unreferenced)\n", grouped(t.vertices).c_str(),
              grouped(t.unreferenced_vertices).c_str());
  std::printf("faces                  %s (%s degenerate, %s zero-area, %s duplicate)\n",
              grouped(t.faces).c_str(), grouped(t.degenerate_faces).c_str(),
              grouped(t.zero_area_faces).c_str(), grouped(t.duplicate_faces).c_str());
  std::printf("bounds                 min (%g, %g, %g)  max (%g, %g, %g)  diagonal %g\n",
              t.bounds_min.x, t.bounds_min.y, t.bounds_min.z, t.bounds_max.x, t.bounds_max.y,
              t.bounds_max.z, t.diagonal);
  std::printf("edges                  %s\n", grouped(t.edges).c_str());
  std::printf("boundary edges         %s in %s loops\n", grouped(t.boundary_edges).c_str(),
              grouped(t.boundary_loops).c_str());
  std::printf("non-manifold edges     %s\n", grouped(t.non_manifold_edges).c_str());
  std::printf("non-manifold vertices  %s\n", grouped(t.non_manifold_vertices).c_str());
  std::printf("components             %s\n", grouped(t.components).c_str());
  std::printf("euler characteristic   %lld\n", t.euler_characteristic);
  std::printf("orientable             %s (%s)\n",
              t.orientable ? yes_no(*t.orientable).c_str() : "unknown: non-manifold edges",
              t.consistently_oriented ? "consistently oriented" : "not consistently oriented");
  if (t.genus) {
    std::printf("genus                  %lld\n", *t.genus);
  } else {
    std::printf("genus                  undefined: not an orientable manifold\n");
  }
  std::printf("closed manifold        %s\n", yes_no(t.is_closed() && t.is_manifold()).c_str());
}

Json report_json(const std::string& name, format::MeshFormat format,
                 const stream::MeshTopology& t, double read_s, double analyse_s) {
  Json j;
  j["input"] = name;
  j["format"] = format::format_name(format);
  j["input_vertices"] = t.vertices;
  j["input_faces"] = t.faces;
  j["unreferenced_vertices"] = t.unreferenced_vertices;
  j["degenerate_faces"] = t.degenerate_faces;
  j["zero_area_faces"] = t.zero_area_faces;
  j["duplicate_faces"] = t.duplicate_faces;
  j["edges"] = t.edges;
  j["boundary_edges"] = t.boundary_edges;
  j["boundary_loops"] = t.boundary_loops;
  j["non_manifold_edges"] = t.non_manifold_edges;
  j["non_manifold_vertices"] = t.non_manifold_vertices;
  j["components"] = t.components;
  j["euler_characteristic"] = t.euler_characteristic;
  j["manifold"] = t.is_manifold();
  j["closed"] = t.is_closed();
  j["consistently_oriented"] = t.consistently_oriented;
  j["orientable"] = t.orientable ? Json(*t.orientable) : Json(nullptr);
  j["genus"] = t.genus ? Json(*t.genus) : Json(nullptr);
  j["bounds"] = {{"min", vec_json(t.bounds_min)}, {"max", vec_json(t.bounds_max)},
                 {"diagonal", t.diagonal}};
  j["peak_rss_bytes"] = peak_rss_bytes();
  j["seconds"] = {{"read", read_s}, {"analyse", analyse_s}};
  return j;
}

int run_info(const InfoOptions& options) {
  if (options.quiet) set_verbosity(0);
  if (options.verbose) set_verbosity(2);
  format::ReadOptions read_options;
  if (!options.input_format.empty()) {
    read_options.format = format::parse_format_name(options.input_format);
    if (read_options.format == format::MeshFormat::kUnknown ||
        read_options.format == format::MeshFormat::kDraco) {
      return report_error(Status::error(Code::kUsage, "--input-format",
                                        "expected ply, off, obj or stl, got '" +
                                            options.input_format + "'"));
    }
  }
  if (options.input == "-" && ::isatty(0)) {
    return report_error(Status::error(Code::kUsage, "info",
                                      "no input file, and standard input is a terminal"));
  }

  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  stream::MeshBuilder builder;
  Status read = format::read_mesh_file(options.input, read_options, builder);
  if (!read) return report_error(read);
  stream::Mesh mesh = builder.take();
  auto t1 = Clock::now();
  auto topology = stream::compute_topology(mesh.view());
  if (!topology) return report_error(topology.status());
  auto t2 = Clock::now();
  double read_s = std::chrono::duration<double>(t1 - t0).count();
  double analyse_s = std::chrono::duration<double>(t2 - t1).count();

  const std::string name = options.input == "-" ? "<stdin>" : options.input;
  format::MeshFormat format = builder.header().format;
  // With --report -, standard output carries the JSON only.
  if (options.report != "-") print_summary(name, format, *topology);
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: info: read %.3f s, analyse %.3f s, peak RSS %s bytes\n",
                 read_s, analyse_s, grouped(peak_rss_bytes()).c_str());
  }
  if (!options.report.empty()) {
    Status written = write_report(options.report,
                                  report_json(name, format, *topology, read_s, analyse_s));
    if (!written) return report_error(written);
  }
  return 0;
}

}  // namespace

void register_info(CLI::App& app, Runner& run) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand(
      "info", "Counts, bounds, boundary loops, manifoldness and genus of a mesh");
  sub->add_option("input", options->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")
      ->capture_default_str();
  sub->add_option("--report", options->report, "Write the figures as JSON to FILE ('-': stdout)");
  sub->add_option("--input-format", options->input_format,
                  "Force the input format (ply|off|obj|stl) instead of detecting it");
  sub->add_flag("-q,--quiet", options->quiet, "Print nothing on stderr but errors");
  sub->add_flag("-v,--verbose", options->verbose, "Print timings on stderr");
  sub->callback([&run, options] { run = [options] { return run_info(*options); }; });
}

}  // namespace gaussmesh::cli
