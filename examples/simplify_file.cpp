// A program that embeds gaussmesh: simplifies a mesh file (or a generated one) into Draco, in
// core or streaming as the library chooses, and checks the result in memory.
//   simplify_file [IN OUT.drc]
#include <cstdio>
#include <string>

#include <gaussmesh/gaussmesh.h>

int main(int argc, char** argv) {
  gaussmesh::SimplifyOptions options;
  options.resources.memory_bytes = std::uint64_t{64} << 20;  // a contract on the working set
  if (argc == 3) {
    auto stats = gaussmesh::simplify(gaussmesh::Source::file(argv[1]), gaussmesh::Sink::file(argv[2]), options);
    if (!stats) {
      std::fprintf(stderr, "simplify_file: %s\n", stats.status().to_string().c_str());
      return static_cast<int>(stats.status().code());
    }
    std::printf("%llu -> %llu faces, %s\n", static_cast<unsigned long long>(stats->input_faces),
                static_cast<unsigned long long>(stats->output_faces), stats->out_of_core ? "streamed" : "in core");
    return 0;
  }
  // No arguments: an octahedron in memory, simplified into memory.
  gaussmesh::Mesh in;
  in.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  in.triangles = {{{0, 2, 4}}, {{2, 1, 4}}, {{1, 3, 4}}, {{3, 0, 4}}, {{2, 0, 5}}, {{1, 2, 5}}, {{3, 1, 5}}, {{0, 3, 5}}};
  gaussmesh::Mesh out;
  auto stats = gaussmesh::simplify(gaussmesh::Source::memory(in.view()), gaussmesh::Sink::memory(&out), options);
  if (!stats) {
    std::fprintf(stderr, "simplify_file: %s\n", stats.status().to_string().c_str());
    return 1;
  }
  std::printf("octahedron: %zu -> %zu faces\n", in.triangles.size(), out.triangles.size());
  return out.triangles.empty() ? 1 : 0;
}
