// Error values: the one-line rendering of a Status.
#include "format/status.h"

namespace gaussmesh::format {

std::string Status::to_string() const {
  if (where_.empty()) return message_;
  return where_ + ": " + message_;
}

}  // namespace gaussmesh::format
