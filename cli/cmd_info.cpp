// gaussmesh info: counts, bounds, boundary loops, manifoldness and genus of a mesh.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"

namespace gaussmesh::cli {
namespace {

struct InfoOptions {
  std::string input = "-";
  std::string input_format;
  CommonFlags common;
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

void print_summary(const MeshInfo& t) {
  std::printf("input                  %s (%s)\n", t.input.c_str(), format_name(t.format));
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
  std::printf("closed manifold        %s\n", yes_no(t.closed && t.manifold).c_str());
  std::string attributes;
  for (const auto& [has, name] : {std::pair{t.normals, "normals"}, std::pair{t.colors, "colours"}, std::pair{t.texcoords, "texture coordinates"}}) {
    if (has) attributes += (attributes.empty() ? "" : ", ") + std::string(name);
  }
  std::printf("vertex attributes      %s\n", attributes.empty() ? "none" : attributes.c_str());
  if (!t.ignored_vertex_values.empty()) {
    std::string names;
    for (const std::string& name : t.ignored_vertex_values) names += (names.empty() ? "" : ", ") + name;
    std::printf("not read               %s\n", names.c_str());
  }
}

int run_info(const InfoOptions& options) {
  apply_verbosity(options.common);
  MeshFormat format = MeshFormat::kUnknown;
  if (!options.input_format.empty()) {
    format = parse_mesh_format(options.input_format);
    if (format == MeshFormat::kUnknown || format == MeshFormat::kDraco) {
      return report_error(Status::error(Code::kUsage, "--input-format",
                                        "expected ply, off, obj or stl, got '" + options.input_format + "'"));
    }
  }
  auto mesh_info = info(Source::file(options.input, format));
  if (!mesh_info) return report_error(mesh_info.status());
  if (verbosity() >= 1) {
    for (const std::string& warning : mesh_info->warnings) {
      std::fprintf(stderr, "gaussmesh: %s: warning: %s\n", options.input == "-" ? "<stdin>" : options.input.c_str(), warning.c_str());
    }
  }
  // With --report -, standard output carries the JSON only.
  if (options.common.report != "-") print_summary(*mesh_info);
  if (verbosity() >= 2) {
    std::fprintf(stderr, "gaussmesh: info: read %.3f s, analyse %.3f s, peak RSS %s bytes\n",
                 mesh_info->seconds_read, mesh_info->seconds_analyse, grouped(mesh_info->peak_rss_bytes).c_str());
  }
  return finish(options.common, mesh_info->report_json);
}

}  // namespace

void register_info(CLI::App& app, Runner& run) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand(
      "info", "Counts, bounds, boundary loops, manifoldness and genus of a mesh");
  sub->add_option("input", options->input, "Input mesh (PLY, OFF, OBJ, STL), '-' for stdin")
      ->capture_default_str();
  sub->add_option("--input-format", options->input_format,
                  "Force the input format (ply|off|obj|stl) instead of detecting it");
  add_common_flags(*sub, options->common, "Print timings on stderr");
  sub->callback([&run, options] { run = [options] { return run_info(*options); }; });
}

}  // namespace gaussmesh::cli
