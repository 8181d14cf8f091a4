// The stitch's merge on a copy of stitched patches, for tests that compare it with the in-core
// sampler's merge (the pipeline takes the patches apart instead: take_merge_input).
#pragma once

#include "stream/stitch/chunk_pieces.h"

namespace gaussmesh::testing {

// The untriangulatable-patch merge on the stitched patches, for the exact sample test: a
// touched candidate keeps its candidacy when its star, with the patches' current labels, still
// counts >= 3 feature edges. Returns the merged patches in find_patches' numbering (lowest
// face), as the in-core run's final face_patch numbers them.
stream::PatchMergeResult merge_stitched_copy(const stream::StitchedPatches& stitched);

}  // namespace gaussmesh::testing
