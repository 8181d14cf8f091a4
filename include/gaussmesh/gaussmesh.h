// gaussmesh: feature-sensitive simplification of triangle meshes far larger than memory
// ("Memoryless Gauss Mesh Sampling"). The whole public contract is this header, status.h and
// mesh.h: one function per job — simplify, sample, segment, info, compare — over a Source (a
// file, standard input or a mesh in memory) and a Sink, with one options struct each and a stats
// struct for what the run measured. Errors are values (Status, Result<T>); nothing throws.
//
// Memory: every job that can stream (simplify, sample) takes ResourceOptions::memory_bytes as a
// contract on its working set and chooses the engine from it (docs/api.md, "Choosing the
// engine"): small inputs run in core where that is faster, everything else streams through
// chunk files in a temporary directory, removed on success, error and interrupt.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gaussmesh/mesh.h"
#include "gaussmesh/status.h"

namespace gaussmesh {

inline constexpr const char* kVersion = "0.1.0";

// ---- Sources and sinks -----------------------------------------------------------------------

// Where an input mesh comes from. The format is detected from the content (so standard input
// needs no flag) unless `format` forces one.
struct Source {
  enum class Kind { kFile, kStandardInput, kMemory, kBytes };
  Kind kind = Kind::kStandardInput;
  std::string path;        // kFile; kBytes: the name messages give it
  MeshView mesh;           // kMemory: must stay valid during the call
  std::string_view bytes;  // kBytes: a file's contents in memory, valid during the call
  MeshFormat format = MeshFormat::kUnknown;

  static Source file(std::string path, MeshFormat format = MeshFormat::kUnknown);  // "-": standard input
  static Source standard_input(MeshFormat format = MeshFormat::kUnknown);
  // Checked as a file is (kBadInput): indices in range, finite values, attributes empty or one
  // per position.
  static Source memory(MeshView mesh);
  // A mesh file's bytes already in memory (received over a network, unpacked from an archive):
  // read by the same readers as a file, in core.
  static Source file_bytes(std::string_view bytes, std::string name = "<bytes>",
                           MeshFormat format = MeshFormat::kUnknown);
  // How messages name it: the path, "<stdin>", "<memory>" or the bytes' name.
  std::string name() const;
};

// Output file formats. kAuto: from the path's extension (.drc .ply .obj .glb .gltf), Draco
// otherwise. kGlb and kGltf: glTF 2.0 holding the Draco-compressed mesh (KHR_draco_mesh_compression).
enum class OutputFormat { kAuto, kDraco, kPlyBinary, kPlyAscii, kObj, kGlb, kGltf };

// "draco"/"drc", "ply", "ply-ascii", "obj", "glb", "gltf" (kAuto for an empty name); nullopt for
// anything else.
std::optional<OutputFormat> parse_output_format(const std::string& name);
const char* output_format_name(OutputFormat format);

// Where a result goes: a file (written to a temporary name and renamed on success, so a failed
// run never leaves a partial file), standard output (binary refused on a terminal), or a mesh
// in memory.
struct Sink {
  enum class Kind { kFile, kStandardOutput, kMemory };
  Kind kind = Kind::kStandardOutput;
  std::string path;                          // kFile
  OutputFormat format = OutputFormat::kAuto;  // kFile and kStandardOutput
  Mesh* mesh = nullptr;                      // kMemory: receives the result

  static Sink file(std::string path, OutputFormat format = OutputFormat::kAuto);  // "-": standard output
  static Sink standard_output(OutputFormat format = OutputFormat::kAuto);
  static Sink memory(Mesh* mesh);
  // The format this sink writes (kAuto resolved from the path); kDraco for memory sinks.
  OutputFormat resolved_format() const;
};

// ---- Options shared by the jobs ---------------------------------------------------------------

enum class GaussBase { kIcosahedron, kOctahedron, kTetrahedron };
enum class SampleTest { kExact, kPaper };  // exact winding (default) or the paper's filters

inline constexpr std::uint32_t kDefaultFrequency = 4;
// SamplingOptions::frequency: chosen from the target (docs/finish.md); kDefaultFrequency when the
// job has no target.
inline constexpr std::uint32_t kAutoFrequency = 0;
// The finest frequency auto picks: G's memory grows with f² (about 12 MB at 64, 800 MB at 512),
// and one choice for every --memory keeps the output the same in and out of core.
inline constexpr std::uint32_t kMaxAutoFrequency = 64;
inline constexpr std::uint32_t kMaxFrequency = 512;
inline constexpr std::uint64_t kDefaultSeed = 1;

// The tessellated Gaussian sphere G and how the mesh is sampled on it (docs/sampling.md).
struct SamplingOptions {
  GaussBase base = GaussBase::kIcosahedron;
  std::uint32_t frequency = kAutoFrequency;  // 1..kMaxFrequency sub-triangles per base edge, or auto
  std::uint64_t seed = kDefaultSeed;            // G's pseudo-random rotation
  std::optional<std::array<double, 4>> rotation;  // a quaternion w,x,y,z instead of the seed's
  std::uint32_t orientations = 1;  // try K rotations (seed, seed+1, …), keep the fewest samples
  std::uint32_t smooth = 0;        // low-pass iterations on face normals
  SampleTest sample_test = SampleTest::kExact;
};

// In core holds the whole mesh; out of core streams it through chunk files within the budget.
enum class Engine { kAuto, kInCore, kOutOfCore };

// Called now and then from the running job: the pass, units done of total, and the input
// triangles the pass covers in all (for a rate). From one thread at a time.
using ProgressFn = std::function<void(const char* pass, std::uint64_t done, std::uint64_t total,
                                      std::uint64_t triangles)>;

struct ResourceOptions {
  // Working-set budget in bytes; 0 = automatic (auto_memory_budget). At least kMinMemory.
  std::uint64_t memory_bytes = 0;
  Engine engine = Engine::kAuto;
  std::uint32_t threads = 0;  // 0 = every core
  std::string tmp_dir;        // empty: $TMPDIR, else /tmp
  ProgressFn progress;
};

inline constexpr std::uint64_t kMinMemory = std::uint64_t{16} << 20;

// The automatic streaming budget: 1/64 of usable memory (physical memory, or a memory cgroup's
// or an rlimit's limit if less), between 16 MiB and 64 MiB. Larger
// budgets make larger chunks, which stream no faster (docs/benchmarks.md).
std::uint64_t auto_memory_budget();

// The engine a job would run on `source` with these options, and the budget it would hold to:
// kInCore when the input is small enough that in core is faster (at most kInCoreMaxFaces
// faces) and its in-core working set (in_core_bytes) fits the budget — the explicit one, else a
// quarter of usable memory; kOutOfCore otherwise. An explicit budget above a memory cgroup's or
// an rlimit's limit is kResources. Standard input that is a regular file (`< file`) counts as
// that file; of unknown size (a pipe) it streams. A forced engine is returned as is. The face
// count is estimated from the file size (a Draco file's is read from its header). simplify also
// holds a textured OBJ or PLY when its counted faces fit (docs/api.md).
struct EngineChoice {
  Engine engine = Engine::kOutOfCore;
  std::uint64_t memory_bytes = 0;     // the budget of an out-of-core run
  std::uint64_t estimated_faces = 0;  // from the file size (0 for standard input of unknown size)
};
inline constexpr std::uint64_t kInCoreMaxFaces = std::uint64_t{4} << 20;
// The largest file the size rule may hold in core: kInCoreMaxFaces at the fewest bytes a face
// takes in any format read (16). A pipe no longer than this is worth copying to a file first,
// so that it is chosen as that file is (the command line does: docs/cli.md).
inline constexpr std::uint64_t kInCoreMaxFileBytes = kInCoreMaxFaces * 16;
std::uint64_t in_core_bytes(std::uint64_t faces);
Result<EngineChoice> choose_engine(const Source& source, const ResourceOptions& resources);

// ---- simplify ---------------------------------------------------------------------------------

enum class Mesher { kPatch, kVoronoi };  // per-patch with the topology guarantee, or Voronoi cells

struct DracoOptions {
  int quantization_bits = 14;  // 1..24
  int compression_level = 7;   // 0..10
  int normal_bits = 10;        // --qn, 1..30: normals (octahedral), when the output has them
  int texcoord_bits = 12;      // --qt, 1..30: texture coordinates, when the output has them
};

// The output's normals (docs/attributes.md): interpolated from the input's (none when it has
// none), computed from the output's faces, or left out.
enum class Normals { kKeep, kCompute, kNone };

// What the output should be (docs/finish.md). Any of the three turns on the quadric finish,
// which collapses the Gauss approximation with the input's plane quadrics until the first one
// is reached; without any, the output is the plain Gauss approximation.
struct TargetOptions {
  std::uint64_t faces = 0;  // --target-faces: at most this many faces (0: none)
  double ratio = 0;         // --ratio: at most this fraction of the input's faces, 0 < ratio <= 1 (0: none)
  // --max-error: no collapse whose estimated error passes this (0: none) — in the input's units,
  // or, when max_error_relative, in percent of the input's bounding-box diagonal.
  double max_error = 0;
  bool max_error_relative = false;
  bool measure = false;  // --measure: the output's Hausdorff and RMS distance to the input in the report (in core)
  bool any() const { return faces > 0 || ratio > 0 || max_error > 0; }
};

// Welding joins vertices at exactly the same position (every bit) before the run: kAuto welds
// an input with at least as many vertices as faces (a triangle soup, as STL and many exporters
// write; STL is read as one, unless kOff, when its reader welds it in a table that grows with the
// mesh). docs/partition.md, "Scattered input and soups".
enum class Weld { kAuto, kOn, kOff };

struct SimplifyOptions {
  TargetOptions target;
  Weld weld = Weld::kAuto;
  Normals normals = Normals::kKeep;
  // --color-weight: with a target, in core, how much a collapse that moves a vertex across the
  // input's colour ramps costs beside its distance to the surface (0: colours do not count;
  // 1: a full step of colour across a face costs like moving that face's width off the surface).
  // docs/attributes.md, "Colour edges".
  double color_weight = 0;
  SamplingOptions sampling;
  Mesher mesher = Mesher::kPatch;  // kVoronoi runs in core only
  ResourceOptions resources;
  DracoOptions draco;
};

// What a run measured. `report_json` is the whole record as one JSON object (the fields of
// docs/cli.md, "Reports"): what `gaussmesh … --report` writes.
struct SimplifyStats {
  std::uint64_t input_vertices = 0, input_faces = 0;
  std::uint64_t welded_vertices = 0;  // input vertices joined to another at the same position
  std::uint64_t target_faces = 0;  // the face target the run resolved (0: none)
  std::uint64_t approximation_faces = 0;  // the Gauss approximation's faces, before the finish
  double estimated_error = 0;      // the finish's largest estimated collapse error, input units
  // What ended the finish (empty without one): "target", "max_error", "topology" (the face
  // target is out of reach: every further collapse would change the topology or fold a face),
  // or "approximation" (the Gauss approximation at kMaxAutoFrequency, or at the frequency given,
  // has no more faces than the target: there was nothing to collapse).
  std::string stopped_by;
  // With TargetOptions::measure: the symmetric Hausdorff and RMS distance between input and
  // output (compare()'s defaults), in input units, and the input's diagonal they are relative to.
  bool measured = false;
  double hausdorff = 0, rms = 0, diagonal = 0;
  std::uint64_t output_vertices = 0, output_faces = 0, output_bytes = 0;
  std::uint64_t samples = 0;
  bool out_of_core = false;
  std::uint64_t memory_bytes = 0;  // the budget held to (out of core)
  std::uint64_t chunks = 0;
  std::uint64_t peak_rss_bytes = 0;
  double seconds = 0;  // the whole call
  // What the caller should hear about and the run went on without: parts of the input the reader
  // skipped (docs/formats.md), vertex values of the input that are not kept, each named once
  // (docs/attributes.md). One sentence each.
  std::vector<std::string> warnings;
  std::string report_json;
};

// Simplifies the mesh of `source` into `sink`. Errors: kUsage (options), kBadInput (the input;
// also an input without faces), kProcessing (an approximation without faces: raise the
// frequency), kOutput (writing), kResources (the budget, an interrupt).
Result<SimplifyStats> simplify(const Source& source, const Sink& sink, const SimplifyOptions& options = {});

// ---- sample -----------------------------------------------------------------------------------

enum class Characteristic : std::uint8_t { kNone = 0, kConvex = 1, kConcave = 2, kSaddle = 3 };
inline constexpr std::int32_t kNoGaussVertex = -1;

struct Sample {
  std::uint32_t vertex = 0;  // input vertex id (samples are input vertices)
  Vec3f position;
  std::int32_t gauss_vertex = kNoGaussVertex;  // the Gaussian vertex it represents
  Characteristic characteristic = Characteristic::kNone;
};

struct SampleOptions {
  SamplingOptions sampling;
  ResourceOptions resources;
  // Also write the input mesh coloured per patch, samples in red (PLY; in core only).
  std::string patches_path;
};

struct SampleStats {
  std::uint64_t input_vertices = 0, input_faces = 0, samples = 0;
  bool out_of_core = false;
  std::uint64_t memory_bytes = 0, chunks = 0, peak_rss_bytes = 0;
  double seconds = 0;
  std::string report_json;
};

// The samples of `source`, written to `path` as a binary point PLY (vertex ids, Gaussian vertex,
// characteristic; "-": standard output) when `path` is not empty, and into `samples` when not null.
Result<SampleStats> sample(const Source& source, const std::string& path, const SampleOptions& options = {},
                           std::vector<Sample>* samples = nullptr);

// ---- segment ----------------------------------------------------------------------------------

struct SegmentOptions {
  SamplingOptions sampling{.frequency = 1};  // its smooth is where the search starts
  std::uint32_t max_smooth = 1024;   // cap on the smoothing iterations
};

struct SegmentStats {
  std::uint64_t input_vertices = 0, input_faces = 0, segments = 0;
  std::vector<std::uint32_t> face_segment;  // segment of every input face
  std::string summary;  // genus, segments, smoothing, poles and patches in one line
  std::string note;     // set when the result is not the paper's ideal (a cap hit, merged aggregates)
  double seconds = 0;
  std::string report_json;
};

// Spherical segmentation (paper §6), in core: a closed genus-g mesh into g+1 segments. Writes
// the mesh with per-face segment ids and colours as a binary PLY to `path` unless it is empty.
Result<SegmentStats> segment(const Source& source, const std::string& path, const SegmentOptions& options = {});

// ---- info -------------------------------------------------------------------------------------

struct MeshInfo {
  std::string input;
  MeshFormat format = MeshFormat::kUnknown;
  std::uint64_t vertices = 0, unreferenced_vertices = 0;
  std::uint64_t faces = 0, degenerate_faces = 0, zero_area_faces = 0, duplicate_faces = 0;
  Vec3f bounds_min, bounds_max;
  double diagonal = 0;
  std::uint64_t edges = 0, boundary_edges = 0, boundary_loops = 0;
  std::uint64_t non_manifold_edges = 0, non_manifold_vertices = 0, components = 0;
  long long euler_characteristic = 0;
  std::optional<bool> orientable;  // unknown with non-manifold edges
  bool consistently_oriented = false;
  std::optional<long long> genus;  // defined for orientable manifolds
  bool manifold = false, closed = false;
  // The per-vertex attributes read (docs/attributes.md), and the vertex values the reader named
  // as not kept.
  bool normals = false, colors = false, texcoords = false;
  std::vector<std::string> ignored_vertex_values;
  // What the reader skipped and went on without (docs/formats.md), one sentence each.
  std::vector<std::string> warnings;
  double seconds_read = 0, seconds_analyse = 0;
  std::uint64_t peak_rss_bytes = 0;
  std::string report_json;
};

// Counts, bounds, boundary loops, manifoldness and genus of a mesh.
Result<MeshInfo> info(const Source& source);

// ---- compare ----------------------------------------------------------------------------------

struct CompareOptions {
  std::uint64_t samples = 400000;  // area samples on A (B gets the same density)
  std::uint64_t seed = 1;
  std::uint32_t threads = 0;       // 0 = every core
};

// From the samples of one mesh to the surface of the other.
struct OneSidedDistance {
  double max = 0;   // over area samples, vertices and edge midpoints (so sharp features count)
  std::array<double, 3> max_at{};  // where on the measured mesh the sample `max` away lies
  double rms = 0;   // over area samples (area-weighted)
  double mean = 0;  // over area samples
  std::uint64_t area_samples = 0, feature_samples = 0;
  // Faces whose normal points away from that of the other mesh's face nearest their centroid
  // (folds, flipped faces), and their share of this mesh's area in percent.
  std::uint64_t facing_away_faces = 0;
  double facing_away_area_pct = 0;
};

struct Distance {
  double diagonal = 0;              // of A's bounding box; the % figures divide by it
  OneSidedDistance a_to_b, b_to_a;
  double hausdorff = 0;  // max of the two sides
  double rms = 0;        // sqrt of the mean of the two sides' squared RMS
  // distance as a percentage of A's bounding-box diagonal
  double pct(double distance) const { return diagonal > 0 ? 100 * distance / diagonal : 0; }
  double seconds = 0;
  std::string report_json;
};

// Symmetric Hausdorff and RMS distance between two meshes by dense, seeded surface sampling.
Result<Distance> compare(const Source& a, const Source& b, const CompareOptions& options = {});

// ---- viewer -------------------------------------------------------------------------------------

// The viewer page (viewer/, built by `scripts/bootstrap viewer` into build/viewer): a folder with
// index.html, viewer.js and draco/. Looked for in $GAUSSMESH_VIEWER_DIR, then beside the
// executable in `executable_dir`/../viewer (the build tree) and
// `executable_dir`/../share/gaussmesh/viewer (an installed tree); kUsage when none holds it.
Result<std::string> find_viewer(const std::string& executable_dir);
// Writes `output` ("-": standard output): one HTML file that shows the mesh file `model` (.glb,
// .gltf, .drc, .ply or .obj) with no server and no network, the viewer's script, Draco's
// decoder and the file's bytes inlined. kBadInput for a model that cannot be read, kUsage for
// one larger than kMaxEmbeddedModelBytes.
inline constexpr std::uint64_t kMaxEmbeddedModelBytes = std::uint64_t{256} << 20;
Status write_viewer_page(const std::string& viewer_dir, const std::string& model, const std::string& output);

// ---- process ------------------------------------------------------------------------------------

// Removes the temporary files of running jobs on SIGINT, SIGTERM and SIGHUP, then exits with the
// signal's status. For programs that want the command's behaviour; call once, early.
void install_signal_cleanup();
// Removes the temporary files and directories of running jobs now, as those signals do: for a
// program about to end the process without unwinding (std::_Exit).
void remove_temporary_files();

// Writes a stats struct's report_json (and a newline) to `path` ("-": standard output) through a
// temporary name and a rename, as every output is written.
Status write_report(const std::string& path, const std::string& report_json);

// Peak resident set size of this process so far, in bytes (0 where unknown).
std::uint64_t peak_rss_bytes();

}  // namespace gaussmesh
