// Error values: names and one-line rendering.
#include "gaussmesh/status.h"

namespace gaussmesh {

const char* code_name(Code code) {
  switch (code) {
    case Code::kOk: return "ok";
    case Code::kUsage: return "usage";
    case Code::kBadInput: return "bad input";
    case Code::kProcessing: return "processing";
    case Code::kOutput: return "output";
    case Code::kResources: return "resources";
  }
  return "unknown";
}

std::string Status::to_string() const {
  if (where_.empty()) return message_;
  return where_ + ": " + message_;
}

}  // namespace gaussmesh
