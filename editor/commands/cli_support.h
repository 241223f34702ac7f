#pragma once
// What every batch command shares: where its mesh comes from, progress on stderr, thread
// control, and the usage error that maps to exit code 2.
#include "cli_fwd.h"
#include <nlohmann/json_fwd.hpp>
#include <tbb/global_control.h>

#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/deformer.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"
#include "hdeform/refinement.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform::cli {

// A command line that is wrong as such (exit code 2), as opposed to bad data (exit code 1).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// --mesh FILE or --shape NAME [--resolution N].
struct MeshSource {
  std::string mesh_path;
  std::string shape_name;
  int resolution = 0;

  void add_options(CLI::App& command);
  // Throws UsageError unless exactly one source was given.
  void require() const;
  bool is_shape() const { return !shape_name.empty(); }
  std::string describe() const;
  // A mesh as sessions and the editor name it: "shape:NAME[:RESOLUTION]" or a file path. Throws
  // InputError for an unknown shape or a resolution that is not a positive number.
  static MeshSource from_name(const std::string& name);
};

// Whether a session's or the editor's mesh name is a built-in shape ("shape:...").
inline bool names_builtin_shape(const std::string& name) { return name.starts_with("shape:"); }

// "WIDTHxHEIGHT", each side in [min, max] (min_width, min_height below): for --size. Throws
// UsageError naming `option` otherwise.
std::pair<unsigned, unsigned> parse_size(const std::string& text, const std::string& option, unsigned min_width, unsigned min_height,
                                         unsigned max_side);

// A loaded mesh; for a built-in shape also its demo edit.
struct LoadedMesh {
  Mesh mesh;
  std::optional<EditConstraints> demo_constraints;
  std::optional<HandleTransform> demo_transform;
};
LoadedMesh load_mesh(const MeshSource& source);

// --backend, --schedule, --precision, --threads.
struct SolverChoice {
  std::string backend = std::string(to_string(default_backend()));
  std::string schedule = std::string(to_string(default_schedule()));
  std::string precision = std::string(to_string(FactorPrecision::Double));
  int threads = 0;

  void add_options(CLI::App& command);
  SolverBackend parsed_backend() const;
  SolveSchedule parsed_schedule() const;
  FactorPrecision parsed_precision() const;
  // Whether --precision was on the command line (a session states its own).
  bool precision_given() const;
  CLI::Option* precision_option = nullptr;
  // Limits TBB to --threads for the lifetime of the returned object (none when 0).
  std::unique_ptr<tbb::global_control> apply_threads() const;
  int effective_threads() const;
};

// --precision double|single alone (the editor's and the benchmark's).
CLI::Option* add_precision_option(CLI::App& command, std::string& precision);

// --exact, --multiresolution, --base-vertices N: where the solves run (deformer.h, Resolution).
struct ResolutionChoice {
  bool exact = false;
  bool multiresolution = false;
  Eigen::Index base_vertices = kDefaultBaseVertices;

  void add_options(CLI::App& command);
  Resolution resolution() const;
  // Sets options.resolution and options.base_vertices; throws UsageError for a contradiction.
  void apply(DeformerOptions& options) const;
};

// --refine N|auto, --refine-tolerance, --no-acceleration: the as-rigid-as-possible refinement.
struct RefineChoice {
  std::string iterations = "0";
  double tolerance = RefinementOptions{}.tolerance;
  double settle = RefinementOptions{}.settle;
  bool plain = false;

  void add_options(CLI::App& command);
  // Iterations per step: 0 (the paper's method alone), N, or the cap of "auto" (run to convergence).
  int parsed_iterations() const;
  bool until_converged() const { return iterations == "auto"; }
  RefinementOptions options() const;
};

// --trace FILE: a timeline of the run in the Chrome trace-event format (trace.h).
struct TraceChoice {
  std::string path;

  void add_options(CLI::App& command);
  bool wanted() const { return !path.empty(); }
  // Starts recording when a file was asked for.
  void begin() const;
  // Writes it (after a successful run only: a failed command leaves no output file).
  void finish() const;
};

// Progress lines on stderr, with the time since the command started; silent with --quiet.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), start_(std::chrono::steady_clock::now()) {}
  void operator()(std::string_view message) const;
  void warn(const std::vector<std::string>& warnings) const;

 private:
  bool quiet_;
  std::chrono::steady_clock::time_point start_;
};

// A vertex list the user named on the command line: an empty one is refused (InputError naming
// the file), since a given file with nothing in it is a mistake; `purpose` says what it is for.
std::vector<int> read_vertex_list(const std::string& path, Eigen::Index vertex_count, const std::string& purpose);

// A vertex is fixed or in one handle, never both: refuses (InputError) naming the two files.
void refuse_contradictions(const EditConstraints& constraints, const std::string& fixed_path, const std::vector<std::string>& handle_paths);

// Refuses (UsageError) an output path that is one of the inputs: inputs are never overwritten.
void refuse_overwriting_inputs(const std::string& output, const std::vector<std::string>& inputs);

// Refuses (UsageError) a mesh output whose extension is not one that is written (.obj, .ply),
// before any work is done.
void refuse_unwritable_mesh_output(const std::string& option, const std::string& output);

// Largest resident set size of this process so far, in MB.
double peak_rss_mb();
// Resident set size now, in MB (0 where /proc is unavailable).
double resident_mb();
// The allocator this process runs with: "jemalloc VERSION" when it was linked or preloaded,
// else "glibc" (set-up times depend on it: see editor/main.cpp).
std::string allocator_name();
// The allocator's settings that benchmark figures depend on (editor/main.cpp says why each is
// set): decay times, how far a free range is split, huge pages. Empty for glibc.
nlohmann::json allocator_settings();

// Exactly one JSON object on one line of stdout (safe from any thread).
void print_json_line(const nlohmann::json& value);

// Median and maximum of a sample (empty: zeros).
struct Summary {
  double median = 0.0;
  double p95 = 0.0;
  double max = 0.0;
};
Summary summarize(std::vector<double> samples);
nlohmann::json to_json(const Summary& summary);

}  // namespace hdeform::cli
