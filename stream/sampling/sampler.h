// Memoryless Gauss mesh sampling (paper §4; docs/sampling.md): per-face normals, smoothing and
// labels, per-vertex feature edges, candidates, non-sample filter, represented Gaussian vertex,
// curvature characteristic and the exact winding sample test; then the patch-level filters
// (stream/sampling/patch_filters.h). The result is what the patch graph and the meshers consume.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "format/mesh_types.h"
#include "format/status.h"
#include "stream/core/gauss_sphere.h"
#include "stream/core/mesh_adjacency.h"
#include "stream/sampling/patch_filters.h"

namespace gaussmesh::stream {

inline constexpr std::uint32_t kNoLabel = 0xFFFFFFFFu;  // a face with no normal at all
inline constexpr std::uint32_t kNoGaussVertex = 0xFFFFFFFFu;

enum class SampleTest {
  kExact,  // v is a sample iff its normal polygon winds around some Gaussian vertex (Fig. 5)
  kPaper,  // quantized candidates + untriangulatable, non-sample and noisy filters (§4)
};
const char* sample_test_name(SampleTest test);

// Curvature characteristic of a vertex around a Gaussian vertex g (paper §4 "Convex, Concave
// and Saddle Samples"): the winding number w of its normal polygon around g. w > 0 (the Gauss
// map keeps orientation: Gaussian curvature > 0) is convex or concave, told apart by which side
// of the plane normal to g its neighbours lie on; w < 0 (orientation reversed, curvature < 0)
// is a saddle; w = 0 is kNone (the polygon does not enclose g).
enum class Characteristic : std::uint8_t { kNone = 0, kConvex = 1, kConcave = 2, kSaddle = 3 };

struct SamplerOptions {
  std::uint32_t smooth_iterations = 0;  // --smooth N: low-pass filter of face normals ([Tau01])
  SampleTest sample_test = SampleTest::kExact;
  // kPaper only. The paper's characteristic is the winding of the (true) normal polygon around
  // the represented v_G; a candidate whose polygon does not wind around it (kNone) cannot be
  // the sample of v_G, and is dropped by the non-sample filter when this is set. Without it the
  // filters keep about two candidates per Gaussian vertex on smooth shapes (docs/sampling.md).
  bool drop_unwinding_candidates = true;
};

// ---- Step 1: per face (a pure function of the face and its edge neighbours, one ring per
// smoothing iteration plus one for degenerate faces) -------------------------------------------

// Unit normals, one per face. A face whose area is zero to float precision (|cross| <= 1e-7 of
// its squared edge lengths) or that is collapsed is *degenerate*: it has no normal of its own
// and inherits the area-weighted mean normal of the faces across its manifold edges; when all
// of those are degenerate too it keeps the zero vector and gets kNoLabel. Then
// smooth_iterations times: n_f <- normalize(sum over f and its edge neighbours of area × n).
// Positions never move.
struct FaceNormals {
  std::vector<format::Vec3f> normal;  // unit, or zero for "no normal"
  std::vector<std::uint8_t> degenerate;  // 1: no normal of its own (skipped by the exact test)
  std::size_t degenerate_count = 0;
};
FaceNormals compute_face_normals(format::MeshView mesh, const MeshAdjacency& adjacency,
                                 std::uint32_t smooth_iterations);
// The same into `out`, reusing its arrays and two scratch arrays (per-face areas; the
// smoothing buffer). Parallel over faces (oneTBB); the result does not depend on threads.
void compute_face_normals(format::MeshView mesh, const MeshAdjacency& adjacency, std::uint32_t smooth_iterations,
                          FaceNormals& out, std::vector<float>& area, std::vector<format::Vec3f>& scratch);

// label[f] = G.locate(normal[f]), or kNoLabel for a zero normal.
std::vector<std::uint32_t> compute_face_labels(const FaceNormals& normals, const GaussSphere& gauss);
void compute_face_labels(const FaceNormals& normals, const GaussSphere& gauss, std::vector<std::uint32_t>& out);

// Bit i of feature[f] set iff edge i of f is a feature edge: a break edge (boundary,
// non-manifold, inconsistently oriented) or a manifold edge whose two faces differ in label.
std::vector<std::uint8_t> compute_feature_edges(const MeshAdjacency& adjacency,
                                                const std::vector<std::uint32_t>& labels);
void compute_feature_edges(const MeshAdjacency& adjacency, const std::vector<std::uint32_t>& labels,
                           std::vector<std::uint8_t>& out);

// ---- Step 2: per vertex (a pure function of the vertex's star: labels, normals, feature bits)

// One record per vertex that is a candidate (>= 3 incident feature edges) or an exact sample.
struct VertexRecord {
  std::uint32_t vertex = 0;
  // Paper decisions (candidates only).
  std::uint32_t gauss_vertex = kNoGaussVertex;  // represented v_G: all labels incident on it
  Characteristic characteristic = Characteristic::kNone;  // of the normal polygon around v_G
  std::int8_t winding = 0;  // winding number of the normal polygon around gauss_vertex
  std::uint16_t feature_edges = 0;  // incident feature edges, counted once per fan side
  bool is_candidate = false;   // >= 3 incident feature edges
  bool is_tree = false;        // non-sample filter: labels form a tree of edge-adjacent triangles
  // Exact test (when run): Gaussian vertices with winding != 0, the lowest-id one and its
  // winding and characteristic.
  bool is_exact_sample = false;
  std::uint8_t enclosed = 0;
  std::uint32_t exact_gauss_vertex = kNoGaussVertex;
  std::int8_t exact_winding = 0;
  Characteristic exact_characteristic = Characteristic::kNone;
  // Bit k set iff the vertex's faces carry the k-th triangle of
  // G.vertex_triangles(gauss_vertex) (for the noisy-sample minimum cover).
  std::uint8_t cover_mask = 0;
};

// Evaluates vertices [begin, end) and appends their records (in vertex order) to out. The exact
// winding test runs on every vertex whose star carries two or more labels when
// run_exact_test; the candidate-only decisions always run. Large ranges run in parallel blocks
// (oneTBB), concatenated in vertex order: the result does not depend on threads.
void evaluate_vertices(format::MeshView mesh, const MeshAdjacency& adjacency, const FaceNormals& normals,
                       const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                       const GaussSphere& gauss, bool run_exact_test, std::uint32_t begin, std::uint32_t end,
                       std::vector<VertexRecord>& out);

// The same for an explicit list of vertices (a chunk's owned vertices), appended in list order.
void evaluate_vertex_list(format::MeshView mesh, const MeshAdjacency& adjacency, const FaceNormals& normals,
                          const std::vector<std::uint32_t>& labels, const std::vector<std::uint8_t>& feature,
                          const GaussSphere& gauss, bool run_exact_test, std::span<const std::uint32_t> vertices,
                          std::vector<VertexRecord>& out);

// How many vertex rings around an owned vertex a chunk must hold for every decision of steps
// 1 and 2 about that vertex to equal the whole mesh's (docs/pipeline.md): its star, one ring
// for the edge neighbours of its faces (degenerate faces inherit across edges), one per
// smoothing iteration, one so that those faces' edges are classified with all their faces
// present.
inline std::uint32_t required_overlap_rings(std::uint32_t smooth_iterations) { return 3 + smooth_iterations; }

// ---- The whole in-core pass ------------------------------------------------------------------

struct Sample {
  std::uint32_t vertex = 0;        // input vertex id: positions are copied, never moved
  std::uint32_t gauss_vertex = kNoGaussVertex;
  Characteristic characteristic = Characteristic::kNone;
};

struct SamplingStats {
  std::size_t degenerate_faces = 0;
  std::size_t unlabelled_faces = 0;     // kNoLabel
  std::size_t break_edges = 0;          // directed break edges (MeshAdjacency)
  std::size_t candidates_initial = 0;   // before the untriangulatable-patch filter
  std::size_t merged_patches = 0;       // untriangulatable patches merged away
  std::size_t tree_filtered = 0;        // candidates removed by the non-sample filter
  std::size_t unwinding_filtered = 0;   // ... and for not winding around their v_G
  std::size_t noisy_filtered = 0;       // candidates removed by the noisy-sample filter
  std::size_t exact_samples = 0;        // vertices with a winding != 0 (either mode reports it)
  std::size_t merge_rounds = 0;         // rounds of the untriangulatable-patch merge that merged
};

// What the patch graph and the meshers consume. All per-face arrays have one entry per input
// face (collapsed faces included: they get kNoLabel and a patch of their own).
struct SamplingResult {
  // Gaussian triangle of each face after the untriangulatable-patch merge (a merged patch takes
  // the label of the neighbour it joined), or kNoLabel.
  std::vector<std::uint32_t> face_label;
  // Patch id of each face: patches are the connected sets of faces with one label joined
  // across manifold non-feature edges, numbered 0.. in order of their lowest face.
  std::vector<std::uint32_t> face_patch;
  // Bit i: edge (v[i], v[i+1]) of the face is a feature edge (after the merge). Feature edges
  // are exactly the patch boundaries plus the break edges.
  std::vector<std::uint8_t> face_feature;
  std::size_t patch_count = 0;
  std::vector<std::uint32_t> patch_label;  // label of each patch
  // Pairs (p, q), p < q, of patches that share at least one manifold feature edge; sorted.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> patch_adjacency;
  // Candidates that survive the untriangulatable-patch filter (the corners of the patch graph),
  // in vertex order, with the per-vertex decisions. A non-manifold vertex (several fans) is
  // evaluated fan by fan: feature edges add up, it is a tree only if every fan is, and its
  // windings add up over the fans.
  std::vector<VertexRecord> candidates;
  // The samples of the chosen test, in vertex order. kExact: every vertex whose normal polygon
  // encloses a Gaussian vertex (it need not be a candidate). kPaper: candidates that pass the
  // non-sample and noisy-sample filters.
  std::vector<Sample> samples;
  SamplingStats stats;
};

// Runs steps 1-2 and the patch filters over the whole mesh. Errors: those of
// build_mesh_adjacency (bad indices, size limits).
format::Result<SamplingResult> sample_mesh(format::MeshView mesh, const GaussSphere& gauss,
                                           const SamplerOptions& options);

// Buffers of the whole pass, reused across calls (chunks, orientations): refilling warm memory
// costs a fraction of first-touching new pages. One per thread; contents between calls are
// unspecified.
struct SamplerWorkspace {
  SamplerWorkspace();
  ~SamplerWorkspace();
  MeshAdjacency adjacency;
  FaceNormals normals;
  std::vector<float> area;
  std::vector<format::Vec3f> smoothed;
  std::vector<VertexRecord> records, fresh;
  std::vector<std::uint8_t> is_candidate;
  Patches patches;  // of the first find_patches (before the merge)
  std::vector<std::uint32_t> stack, touched, candidate_vertex, candidate_record;
  std::vector<std::uint64_t> face_key;  // face_order_keys: patches are numbered by them
  PatchGraphInput graph_input;
  PatchGraphBuildScratch graph_scratch;
  PatchMergeGraph graph;
  PatchMergeResult merge_result;
  // Seconds of the last call's patch stage, by part, in CPU time of the calling thread (all of
  // it when run on one thread): find_patches, building the patch graph's input, the merge
  // rounds (with the graph's reset), and the result (patches, labels, feature bits, adjacency);
  // and the whole stage in wall time.
  struct PatchStageSeconds {
    double find_patches = 0, build = 0, rounds = 0, result = 0, wall = 0;
    double cpu() const { return find_patches + build + rounds + result; }
  } patch_seconds;
};

// The same into `result`, reusing the workspace's and the result's arrays. Same decisions.
format::Status sample_mesh(format::MeshView mesh, const GaussSphere& gauss, const SamplerOptions& options,
                           SamplerWorkspace& workspace, SamplingResult& result);

// --orientations K: samples the mesh once per Gaussian sphere in `spheres` and keeps the one
// with the fewest samples (ties: the earliest); cheap because the pass is linear.
// Precondition: spheres is not empty. Errors: those of sample_mesh and GaussSphere::create.
struct OrientedSampling {
  std::optional<GaussSphere> gauss;  // the chosen sphere (always set on success)
  SamplingResult result;
  std::size_t chosen = 0;  // index into spheres
  std::vector<std::size_t> samples_per_orientation;
};
format::Result<OrientedSampling> sample_mesh_best_orientation(format::MeshView mesh,
                                                              const std::vector<GaussSphereOptions>& spheres,
                                                              const SamplerOptions& options);

}  // namespace gaussmesh::stream
