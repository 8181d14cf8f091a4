// Segmentation for spherical parameterization (paper §6, §6.1, Figs. 20-22; docs/segment.md):
// cut a closed genus-g mesh into g+1 connected segments whose normal fields each wrap the
// Gaussian sphere once. In core: the whole mesh, its adjacency and a few per-face arrays are in memory.
#pragma once

#include <cstdint>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/gauss_sphere.h"

namespace gaussmesh::stream {

struct SegmentationOptions {
  // Smoothing iterations to start from (--smooth N); the search only adds iterations.
  std::uint32_t min_smooth = 0;
  // Cap on the low-pass filter iterations (--max-smooth N). When reached, the remaining steps
  // run on the capped normals and SegmentationResult::smooth_cap_hit says so.
  std::uint32_t max_smooth = 1024;
};

// The steps, in the terms of the paper (Fig. 20):
//  1. g from χ = 2 − 2g (one closed, orientable, manifold component).
//  2. Low-pass filter the face normals ([Tau01]; the sampler's filter: a face's normal becomes
//     the normalized area-weighted sum of its own and its edge neighbours' normals), one
//     iteration at a time from min_smooth, until every Gaussian triangle has at most g+1
//     pre-image patches, or max_smooth is reached. A patch is a maximal edge-connected set of
//     faces with one label (label = Gaussian triangle of the smoothed normal).
//  3. Poles: Gaussian triangles with 1 .. g pre-image patches (fewer than g+1). Their patches
//     are pole patches; the others are non-pole patches.
//  4. Greedy aggregation of non-pole patches over the patch adjacency graph: seeds are taken in
//     order of decreasing face count (ties: lower patch id); an aggregate grows breadth-first,
//     neighbours in increasing patch id, and takes a non-pole patch only if no patch of the same
//     label is in it yet. Patches refused by one aggregate seed later ones.
//  5. Pole faces go to the nearest aggregate in the L2,1 metric: multi-source Dijkstra over
//     faces from every non-pole face, edge weight |n_f − n_g| (smoothed unit normals) plus
//     1e-3 × the centroid distance over the bounding-box diagonal (a tie-break on flat parts).
//     A face takes the segment of its Dijkstra predecessor, so every segment stays connected.
//  6. Fallback, outside the paper: while there are more than g+1 segments, the segment with the
//     fewest faces (ties: lower id) is merged into the face-adjacent segment with which it shares
//     the fewest labels (ties: the longest shared boundary, then lower id). Merges are counted;
//     merged segments may hold two patches of one label (counted in duplicate_labels). If there
//     are no non-pole patches at all, the whole mesh is one segment.
// Segments are numbered in order of their lowest face.
struct SegmentationResult {
  long long euler_characteristic = 0;
  std::uint32_t genus = 0;
  std::uint32_t smooth_iterations = 0;  // iterations the labels below were computed with
  bool smooth_cap_hit = false;          // max_smooth reached with some label over g+1 patches
  std::uint32_t max_preimages = 0;      // most patches of one label, after smoothing

  // Per face (one entry per input face).
  std::vector<std::uint32_t> face_label;    // Gaussian triangle of the smoothed normal
  std::vector<std::uint32_t> face_patch;    // patch id
  std::vector<std::uint8_t> face_pole;      // 1: the face lies in a pole patch
  std::vector<std::uint32_t> face_segment;  // segment id, 0 .. segment_count-1

  std::size_t patch_count = 0;
  std::vector<std::uint32_t> patch_label;
  std::size_t noise_patches = 0;  // islands relabelled by the noise filter (step 2), last iteration
  std::size_t poles = 0;         // Gaussian triangles with 1 .. g pre-image patches
  std::size_t empty_labels = 0;  // Gaussian triangles with no face at all
  std::size_t pole_patches = 0;
  std::size_t pole_faces = 0;

  std::size_t greedy_aggregates = 0;  // aggregates the greedy step made (step 4)
  std::size_t merges = 0;             // fallback merges (step 6); 0 when the paper's steps suffice
  std::size_t segment_count = 0;
  std::vector<std::size_t> segment_faces;  // faces per segment
  // Per segment: non-pole labels carried by two or more of its pieces (edge-connected faces of
  // one label); 0 everywhere when each segment's non-pole part is one sheet over the sphere.
  std::vector<std::size_t> duplicate_labels;
};

// Segments mesh over gauss (a coarse G is enough: icosahedral frequency 1-2; the count of
// pre-images per Gaussian triangle is what matters). Memory: about 60 bytes per face plus the
// adjacency (~40 bytes per face).
// Errors (kBadInput, where "segment"): an empty mesh; a face with a repeated vertex (collapsed);
// an open, non-manifold, non-orientable or inconsistently oriented mesh; more than one
// component (each would need its own genus); those of build_mesh_adjacency. kUsage:
// min_smooth > max_smooth.
format::Result<SegmentationResult> segment_mesh(format::MeshView mesh, const GaussSphere& gauss,
                                                const SegmentationOptions& options);

}  // namespace gaussmesh::stream
