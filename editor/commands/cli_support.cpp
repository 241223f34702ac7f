#include "hdeform/stopwatch.h"
#include "cli_support.h"

#include <CLI/CLI.hpp>
#include <sstream>
#include "hdeform/constraint_io.h"
#include "hdeform/errors.h"
#include "hdeform/trace.h"

#include <unordered_map>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <iostream>
#include <mutex>

#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"

namespace hdeform::cli {

void MeshSource::add_options(CLI::App& command) {
  auto* mesh = command.add_option("--mesh", mesh_path, "Input mesh (OBJ, PLY, OFF or STL)");
  auto* shape = command.add_option("--shape", shape_name, "Built-in shape instead of --mesh: cactus, bar, cylinder, sphere");
  command.add_option("--resolution", resolution, "Built-in shape resolution (segments around; default 48)");
  mesh->excludes(shape);
  shape->excludes(mesh);
}

void MeshSource::require() const {
  if (mesh_path.empty() && shape_name.empty()) throw UsageError("give --mesh FILE or --shape NAME");
}

std::string MeshSource::describe() const {
  if (!is_shape()) return mesh_path;
  return "shape:" + shape_name + (resolution > 0 ? ":" + std::to_string(resolution) : "");
}

MeshSource MeshSource::from_name(const std::string& name) {
  MeshSource source;
  if (!names_builtin_shape(name)) {
    source.mesh_path = name;
    return source;
  }
  const std::string spec = name.substr(6);
  const auto colon = spec.find(':');
  source.shape_name = spec.substr(0, colon);
  if (!parse_shape(source.shape_name)) throw InputError("'" + name + "': unknown shape (cactus, bar, cylinder, sphere)");
  if (colon != std::string::npos) {
    const std::string digits = spec.substr(colon + 1);
    std::size_t used = 0;
    try {
      source.resolution = std::stoi(digits, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (digits.empty() || used != digits.size() || source.resolution <= 0) {
      throw InputError("'" + name + "': the resolution '" + digits + "' is not a positive number");
    }
  }
  return source;
}

std::pair<unsigned, unsigned> parse_size(const std::string& text, const std::string& option, unsigned min_width, unsigned min_height,
                                         unsigned max_side) {
  unsigned width = 0, height = 0;
  char separator = 0;
  std::stringstream stream(text);
  if (!(stream >> width >> separator >> height) || separator != 'x' || !stream.eof() || width < min_width || height < min_height ||
      width > max_side || height > max_side) {
    throw UsageError(option + " must be WIDTHxHEIGHT, from " + std::to_string(min_width) + "x" + std::to_string(min_height) + " to " +
                     std::to_string(max_side) + "x" + std::to_string(max_side) + " (got '" + text + "')");
  }
  return {width, height};
}

LoadedMesh load_mesh(const MeshSource& source) {
  LoadedMesh loaded;
  if (source.is_shape()) {
    const auto kind = parse_shape(source.shape_name);
    if (!kind) throw UsageError("unknown shape '" + source.shape_name + "' (cactus, bar, cylinder, sphere)");
    auto shape = make_shape(*kind, source.resolution > 0 ? source.resolution : kDefaultShapeResolution);
    loaded.mesh = std::move(shape.mesh);
    loaded.demo_constraints = std::move(shape.demo_constraints);
    loaded.demo_transform = shape.demo_transform;
  } else {
    if (source.resolution > 0) throw UsageError("--resolution applies to --shape only");
    loaded.mesh = read_mesh(source.mesh_path);
  }
  return loaded;
}

void SolverChoice::add_options(CLI::App& command) {
  command.add_option("--backend", backend, "Factorization backend: tree (ours, both cores), eigen or cholmod")->capture_default_str();
  command.add_option("--schedule", schedule, "Column solves: blocked, per-column or thread-groups")->capture_default_str();
  precision_option = add_precision_option(command, precision);
  command.add_option("--threads", threads, "Worker threads (default: all cores)");
}

void ResolutionChoice::add_options(CLI::App& command) {
  command.add_flag("--exact", exact,
                   "Solve on every vertex of the mesh, however large (default: from " + std::to_string(kMultiresolutionFrom) +
                       " vertices on, on a base mesh that carries the detail)");
  command.add_flag("--multiresolution", multiresolution, "Solve on a base mesh that carries the detail, whatever the mesh's size");
  command.add_option("--base-vertices", base_vertices, "Multiresolution: the base mesh's size in vertices")->capture_default_str();
}

Resolution ResolutionChoice::resolution() const {
  if (exact && multiresolution) throw UsageError("--exact and --multiresolution contradict each other: give one");
  return exact ? Resolution::Exact : multiresolution ? Resolution::Multiresolution : Resolution::Automatic;
}

void ResolutionChoice::apply(DeformerOptions& options) const {
  if (base_vertices < 4) throw UsageError("--base-vertices must be at least 4");
  options.resolution = resolution();
  options.base_vertices = base_vertices;
}

void TraceChoice::add_options(CLI::App& command) {
  command.add_option("--trace", path, "Write a timeline of the run to this file (Chrome trace-event JSON: Perfetto, chrome://tracing)");
}

void TraceChoice::begin() const {
  if (wanted()) trace::start();
}

void TraceChoice::finish() const {
  if (!wanted()) return;
  trace::stop();
  trace::write(path);
}

void RefineChoice::add_options(CLI::App& command) {
  command.add_option("--refine", iterations,
                     "As-rigid-as-possible iterations after each step's update: N, or 'auto' to run until converged (0: the paper's "
                     "method alone)")
      ->capture_default_str();
  command.add_option("--refine-tolerance", tolerance, "--refine auto: converged when the energy falls by less than this fraction")
      ->capture_default_str();
  command.add_option("--refine-settle", settle,
                     "--refine auto: also stop once a plain iteration would move no vertex by more than this fraction of the "
                     "bounding-box diagonal (the editor's stop: " + std::to_string(kEditorSettle).substr(0, 6) + "; 0: off)")
      ->capture_default_str();
  command.add_flag("--no-acceleration", plain, "Plain local/global iterations, without Anderson acceleration");
}

int RefineChoice::parsed_iterations() const {
  if (until_converged()) return options().max_iterations;
  int value = 0;
  const auto [end, error] = std::from_chars(iterations.data(), iterations.data() + iterations.size(), value);
  if (error != std::errc() || end != iterations.data() + iterations.size() || value < 0) {
    throw UsageError("--refine takes a number of iterations (0 or more) or 'auto', not '" + iterations + "'");
  }
  return value;
}

RefinementOptions RefineChoice::options() const {
  if (!(tolerance > 0.0 && tolerance < 1.0)) throw UsageError("--refine-tolerance must lie between 0 and 1");
  RefinementOptions options;
  if (!(settle >= 0.0 && settle < 1.0)) throw UsageError("--refine-settle must be 0 (off) or a fraction below 1");
  options.tolerance = tolerance;
  options.settle = settle;
  options.accelerate = !plain;
  return options;
}

CLI::Option* add_precision_option(CLI::App& command, std::string& precision) {
  return command.add_option("--precision", precision,
                     "How the factor is stored: double, or single (half the factor's memory; each solve then takes one or two "
                     "correction steps against the double matrix, to the same accuracy)")
      ->check(CLI::IsMember({"double", "single"}))
      ->capture_default_str();
}

bool SolverChoice::precision_given() const { return precision_option != nullptr && precision_option->count() > 0; }

FactorPrecision SolverChoice::parsed_precision() const { return parse_precision(precision).value_or(FactorPrecision::Double); }

SolverBackend SolverChoice::parsed_backend() const {
  const auto parsed = parse_backend(backend);
  if (!parsed) throw UsageError("unknown backend '" + backend + "' (tree, eigen, cholmod)");
  if (!backend_available(*parsed)) throw UsageError("this build has no " + backend + " backend");
  return *parsed;
}

SolveSchedule SolverChoice::parsed_schedule() const {
  const auto parsed = parse_schedule(schedule);
  if (!parsed) throw UsageError("unknown schedule '" + schedule + "' (blocked, per-column, thread-groups)");
  return *parsed;
}

std::unique_ptr<tbb::global_control> SolverChoice::apply_threads() const {
  if (threads < 0) throw UsageError("--threads must be positive");
  if (threads == 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}

int SolverChoice::effective_threads() const {
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

void Progress::operator()(std::string_view message) const {
  if (quiet_) return;
  const double seconds = seconds_since(start_);
  char stamp[32];
  std::snprintf(stamp, sizeof stamp, "[%6.2fs] ", seconds);
  std::cerr << "hdeform: " << stamp << message << '\n';
}

void Progress::warn(const std::vector<std::string>& warnings) const {
  if (quiet_) return;
  for (const auto& line : warnings) std::cerr << "hdeform: warning: " << line << '\n';
}

std::vector<int> read_vertex_list(const std::string& path, Eigen::Index vertex_count, const std::string& purpose) {
  auto vertices = read_vertex_indices(path, vertex_count);
  if (vertices.empty()) throw InputError(path + ": no vertex indices (" + purpose + ")");
  return vertices;
}

void refuse_contradictions(const EditConstraints& constraints, const std::string& fixed_path, const std::vector<std::string>& handle_paths) {
  std::unordered_map<int, std::string> owner;
  for (const int v : constraints.fixed) owner.emplace(v, fixed_path + " (fixed)");
  for (std::size_t h = 0; h < constraints.handles.size() && h < handle_paths.size(); ++h) {
    for (const int v : constraints.handles[h]) {
      const auto [it, inserted] = owner.emplace(v, handle_paths[h] + " (handle " + std::to_string(h + 1) + ")");
      if (!inserted) {
        throw InputError(handle_paths[h] + ": vertex " + std::to_string(v) + " is also listed in " + it->second +
                         "; a vertex is either fixed or in one handle");
      }
    }
  }
}

void refuse_unwritable_mesh_output(const std::string& option, const std::string& output) {
  const auto format = mesh_format_of(output);
  if (format != MeshFormat::Obj && format != MeshFormat::Ply) {
    throw UsageError(option + " " + output + ": meshes are written as .obj or .ply");
  }
}

void refuse_overwriting_inputs(const std::string& output, const std::vector<std::string>& inputs) {
  std::error_code error;
  for (const auto& input : inputs) {
    if (input.empty()) continue;
    if (input == output || std::filesystem::equivalent(input, output, error)) {
      throw UsageError("refusing to overwrite the input " + input + " (choose another output path)");
    }
  }
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

double resident_mb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  if (!(statm >> pages >> resident)) return 0.0;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// Weak: resolved only when jemalloc is in the process.
extern "C" int mallctl(const char* name, void* old_value, std::size_t* old_size, void* new_value, std::size_t new_size)
    __attribute__((weak));

std::string allocator_name() {
  if (mallctl == nullptr) return "glibc";
  const char* version = nullptr;
  std::size_t size = sizeof(version);
  if (mallctl("version", static_cast<void*>(&version), &size, nullptr, 0) != 0 || version == nullptr) return "jemalloc";
  return "jemalloc " + std::string(version);
}

nlohmann::json allocator_settings() {
  if (mallctl == nullptr) return nlohmann::json::object();
  nlohmann::json settings = nlohmann::json::object();
  const auto read_number = [&](const char* name, const char* key) {
    ssize_t value = 0;
    std::size_t size = sizeof(value);
    if (mallctl(name, static_cast<void*>(&value), &size, nullptr, 0) == 0) settings[key] = value;
  };
  read_number("opt.dirty_decay_ms", "dirty_decay_ms");
  read_number("opt.muzzy_decay_ms", "muzzy_decay_ms");
  read_number("opt.lg_extent_max_active_fit", "lg_extent_max_active_fit");
  const char* thp = nullptr;
  std::size_t size = sizeof(thp);
  if (mallctl("opt.thp", static_cast<void*>(&thp), &size, nullptr, 0) == 0 && thp != nullptr) settings["thp"] = thp;
  return settings;
}

void print_json_line(const nlohmann::json& value) {
  // Whole lines, also when the editor's threads report at once.
  static std::mutex mutex;
  const std::string line = value.dump() + '\n';
  const std::lock_guard lock(mutex);
  std::cout << line << std::flush;
}

Summary summarize(std::vector<double> samples) {
  Summary summary;
  if (samples.empty()) return summary;
  std::sort(samples.begin(), samples.end());
  const auto at = [&](double q) {
    return samples[std::min(samples.size() - 1, static_cast<std::size_t>(std::ceil(q * static_cast<double>(samples.size()))) - (q > 0 ? 1 : 0))];
  };
  const auto n = samples.size();
  summary.median = n % 2 == 1 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
  summary.p95 = at(0.95);
  summary.max = samples.back();
  return summary;
}

nlohmann::json to_json(const Summary& summary) {
  auto round3 = [](double v) { return std::round(v * 1000.0) / 1000.0; };
  return {{"median", round3(summary.median)}, {"p95", round3(summary.p95)}, {"max", round3(summary.max)}};
}

}  // namespace hdeform::cli
