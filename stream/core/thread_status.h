// Work on a thread of our own (the spill writer, the frame read-ahead) runs through
// status_of_work: an exception escaping such a thread ends the process (std::terminate), so an
// allocation that fails there must come back to the caller as a status, like any other error.
#pragma once

#include <exception>
#include <new>
#include <string>

#include "format/status.h"

namespace gaussmesh::stream {

// work() -> format::Status; std::bad_alloc becomes kResources ("out of memory"), any other
// exception kProcessing, both at `where`.
template <typename Work>
format::Status status_of_work(const char* where, Work&& work) {
  try {
    return work();
  } catch (const std::bad_alloc&) {
    return format::Status::error(format::Code::kResources, where, "out of memory");
  } catch (const std::exception& e) {
    return format::Status::error(format::Code::kProcessing, where, std::string("internal error: ") + e.what());
  }
}

}  // namespace gaussmesh::stream
