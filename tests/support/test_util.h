// Helpers for tests: scratch directories, running the gaussmesh binary, reading files.
#pragma once

#include <filesystem>
#include <string>

namespace gaussmesh::testing {

// Path of a file under fixtures/ (the project's committed fixtures).
std::string fixture(const std::string& relative);
// Path of the built gaussmesh binary.
std::string gaussmesh_binary();

// A fresh directory removed (with its contents) on destruction.
class ScratchDir {
 public:
  ScratchDir();
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

struct CommandResult {
  int exit_code = -1;  // exit status, or 128 + signal
  std::string out, err;
};
// Runs a shell command line (/bin/sh -c), capturing stdout and stderr.
CommandResult run_command(const std::string& command_line);

std::string read_file(const std::string& path);
void write_file(const std::string& path, const std::string& bytes);

}  // namespace gaussmesh::testing
