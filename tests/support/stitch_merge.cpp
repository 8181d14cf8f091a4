// See stitch_merge.h.
#include "tests/support/stitch_merge.h"

namespace gaussmesh::testing {

stream::PatchMergeResult merge_stitched_copy(const stream::StitchedPatches& stitched) {
  stream::CandidateEdges edges;
  stream::StitchedPatches taken = stitched;
  stream::PatchGraphInput input = stream::take_merge_input(taken, edges);
  return stream::merge_stitched_patches(edges, std::move(input));
}

}  // namespace gaussmesh::testing
