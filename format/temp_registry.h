// Paths of temporary files and directories that must disappear if the process is interrupted.
// install_signal_cleanup() makes SIGINT, SIGTERM, SIGHUP and SIGPIPE remove every registered
// path (async-signal-safe: fixed slots, unlink/rmdir only) and then re-raise the signal.
#pragma once

#include <string>

namespace gaussmesh::format {

void install_signal_cleanup();
// Removes every registered path now, as a signal would (for a process about to _exit).
void remove_registered_temp_paths();
// Returns a slot id, or -1 when all slots are taken (the path is then not protected).
int register_temp_path(const std::string& path, bool is_directory);
void unregister_temp_path(int slot);

}  // namespace gaussmesh::format
