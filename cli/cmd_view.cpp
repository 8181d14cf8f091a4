// gaussmesh view: shows a mesh file in the viewer page (viewer/), served on a loopback port
// until interrupted, or written as one self-contained HTML file (--html OUT). docs/viewer.md.
#include <cctype>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <thread>

#include <pthread.h>

#include <httplib.h>

#include "cli/commands.h"

namespace gaussmesh::cli {
namespace {

namespace fs = std::filesystem;

struct ViewOptions {
  std::string input;
  std::string html;
  int port = 0;
  CommonFlags common;
};

std::string executable_dir() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return error ? std::string(".") : self.parent_path().string();
}

// A path segment as a URL holds it.
std::string url_encoded(const std::string& text) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out.push_back(static_cast<char>(c));
    } else {
      out += {'%', kHex[c >> 4], kHex[c & 15]};
    }
  }
  return out;
}

// Serves the viewer's folder and the model until SIGINT or SIGTERM. The model is read from its
// file at each request, in pieces, so a large one is never held whole.
int serve(const ViewOptions& o, const std::string& viewer, std::uintmax_t model_size) {
  // The signals are taken by a thread that stops the server, not by the default handlers.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  httplib::Server server;
  if (!server.set_mount_point("/", viewer)) {
    return report_error(Status::error(Code::kUsage, viewer, "cannot serve this folder"));
  }
  const std::string name = fs::path(o.input).filename().string();
  const std::string model_path = "/model/" + url_encoded(name);
  const std::string input = o.input;
  server.Get(model_path, [input, model_size](const httplib::Request&, httplib::Response& response) {
    auto file = std::make_shared<std::ifstream>(input, std::ios::binary);
    response.set_content_provider(static_cast<std::size_t>(model_size), "application/octet-stream",
                                  [file](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                                    char buffer[1 << 16];
                                    file->seekg(static_cast<std::streamoff>(offset));
                                    file->read(buffer, static_cast<std::streamsize>(std::min(length, sizeof buffer)));
                                    const std::streamsize got = file->gcount();
                                    return got > 0 && sink.write(buffer, static_cast<std::size_t>(got));
                                  });
  });
  const int port = o.port == 0 ? server.bind_to_any_port("127.0.0.1") : (server.bind_to_port("127.0.0.1", o.port) ? o.port : -1);
  if (port <= 0) {
    return report_error(Status::error(Code::kUsage, "--port", "cannot listen on 127.0.0.1:" + std::to_string(o.port)));
  }
  std::printf("http://127.0.0.1:%d/?model=%s\n", port, model_path.substr(1).c_str());
  std::fflush(stdout);
  if (verbosity() >= 1) std::fprintf(stderr, "gaussmesh: serving %s and the viewer on 127.0.0.1:%d (Ctrl-C stops)\n", o.input.c_str(), port);
  std::thread stopper([&server, stop_signals] {
    int signal = 0;
    sigwait(&stop_signals, &signal);
    server.stop();
  });
  stopper.detach();
  server.listen_after_bind();
  return 0;
}

int run_view(const ViewOptions& o) {
  apply_verbosity(o.common);
  std::error_code error;
  const auto size = fs::file_size(o.input, error);
  if (error || !fs::is_regular_file(o.input, error)) {
    return report_error(Status::error(Code::kBadInput, o.input, "cannot read: not a regular file"));
  }
  if (o.port < 0 || o.port > 65535) {
    return report_error(Status::error(Code::kUsage, "--port", "a port is 0..65535, got " + std::to_string(o.port)));
  }
  auto viewer = find_viewer(executable_dir());
  if (!viewer) return report_error(viewer.status());
  if (!o.html.empty()) {
    if (Status s = write_viewer_page(*viewer, o.input, o.html); !s) return report_error(s);
    if (verbosity() >= 1 && o.html != "-") std::fprintf(stderr, "gaussmesh: %s -> %s (viewer page)\n", o.input.c_str(), o.html.c_str());
    return 0;
  }
  return serve(o, *viewer, size);
}

}  // namespace

void register_view(CLI::App& app, Runner& run) {
  auto args = std::make_shared<ViewOptions>();
  CLI::App* sub = app.add_subcommand("view", "show a mesh file in the browser viewer (served on 127.0.0.1, or --html OUT)");
  sub->add_option("input", args->input, ".glb, .gltf, .drc, .ply or .obj file")->required();
  sub->add_option("--html", args->html, "write one self-contained HTML page instead of serving ('-': stdout)");
  sub->add_option("--port", args->port, "loopback port to serve on (default 0: any free port)");
  sub->add_flag("-q,--quiet", args->common.quiet, "Print nothing on stderr but errors");
  sub->callback([&run, args] { run = [args] { return run_view(*args); }; });
}

}  // namespace gaussmesh::cli
