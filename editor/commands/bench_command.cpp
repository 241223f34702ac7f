// hdeform bench: the figures of the README's Performance section, as one JSON object.
#include <CLI/CLI.hpp>
#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "batch_commands.h"
#include "cli_support.h"
#include "hdeform/atomic_file.h"
#include "hdeform/constraint_io.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/subdivision.h"
#include "hdeform/trace.h"
#include "hdeform/update_pipeline.h"
#include "hdeform/stopwatch.h"
#ifdef HDEFORM_WITH_ENGINE
#include "render_bench.h"
#endif

namespace hdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;

// Splits one handle into two by the median x of its vertices: the two-handle scenario.
std::vector<std::vector<int>> split_by_x(const Mesh& mesh, std::vector<int> handle) {
  std::sort(handle.begin(), handle.end(), [&](int a, int b) {
    return mesh.positions(a, 0) != mesh.positions(b, 0) ? mesh.positions(a, 0) < mesh.positions(b, 0) : a < b;
  });
  const auto half = handle.begin() + static_cast<std::ptrdiff_t>(handle.size() / 2);
  std::vector<int> first(handle.begin(), half), second(half, handle.end());
  std::sort(first.begin(), first.end());
  std::sort(second.begin(), second.end());
  return {first, second};
}

// Five handles of `size` vertices about vertices spread over the mesh (the nearest ones, fixed
// vertices left out): the re-selection scenario, a new stroke each time.
std::vector<std::vector<int>> spread_handles(const Mesh& mesh, const std::vector<int>& fixed, std::size_t size) {
  std::vector<bool> is_fixed(static_cast<std::size_t>(mesh.vertex_count()), false);
  for (const int v : fixed) is_fixed[static_cast<std::size_t>(v)] = true;
  std::vector<std::vector<int>> handles;
  for (int k = 1; k <= 5; ++k) {
    const Eigen::RowVector3d centre = mesh.positions.row(mesh.vertex_count() * k / 6);
    std::vector<std::pair<double, int>> by_distance;
    for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) {
      if (!is_fixed[static_cast<std::size_t>(v)]) by_distance.emplace_back((mesh.positions.row(v) - centre).squaredNorm(), static_cast<int>(v));
    }
    const std::size_t count = std::min(size, by_distance.size());
    std::partial_sort(by_distance.begin(), by_distance.begin() + static_cast<std::ptrdiff_t>(count), by_distance.end());
    std::vector<int> handle;
    for (std::size_t i = 0; i < count; ++i) handle.push_back(by_distance[i].second);
    std::sort(handle.begin(), handle.end());
    handles.push_back(std::move(handle));
  }
  return handles;
}

class BenchCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("bench", "Measure factorization, drag updates and solves (JSON on stdout)");
    source_.add_options(*command);
    command->add_option("--fixed", fixed_path_, "Fixed vertices: 0-based indices");
    command->add_option("--handle", handle_path_, "Handle vertices: 0-based indices");
    command->add_option("--transform", transform_path_, "Handle transform (as for edit)");
    command->add_option("--steps", steps_, "Drag updates per measurement")->capture_default_str();
    command->add_option("--subdivide", subdivide_,
                        "Split every triangle into four this many times first (new vertices after the originals, fixed or handle "
                        "where both parents are); measures the backends, the default schedule and the pipeline only")
        ->capture_default_str();
    command->add_option("--relief", relief_,
                        "After --subdivide: displace each vertex along its normal by this fraction of the bounding box's "
                        "diagonal times a fixed pattern of three frequencies, so that the detail is real (e.g. 0.001)");
    command->add_option("--threads", threads_, "Worker threads (default: all cores)");
    resolution_.add_options(*command);
    add_precision_option(*command, precision_);
    command->add_option("--out", out_path_, "Also write the JSON report to this file");
    command->add_flag("--quiet", quiet_, "No progress on stderr");
    trace_.add_options(*command);
#ifdef HDEFORM_WITH_ENGINE
    command->add_flag("--render", render_, "Measure rendering instead: frame times and publishing (offscreen)");
    command->add_option("--size", render_options_.size, "--render: image size")->capture_default_str();
    command->add_option("--samples", render_options_.samples, "--render: multisampling (default: the editor's for the device)");
    command->add_option("--frames", render_options_.frames, "--render: frames per measurement")->capture_default_str();
    command->add_option("--device", render_options_.device, "--render: Vulkan device");
    command->add_flag("--validation", render_options_.validation, "--render: Khronos validation layer");
#endif
    return command;
  }

  int run() override {
    source_.require();
    if (steps_ < 3) throw UsageError("--steps must be at least 3");
    const SolverChoice solver{.threads = threads_};
    const auto threads = solver.apply_threads();
    const Progress progress(quiet_);
    trace_.begin();

    auto start = Clock::now();
    LoadedMesh loaded = load_mesh(source_);
    const double read_ms = milliseconds_since(start);
    EditConstraints constraints;
    HandleTransform transform;
    if (!handle_path_.empty()) {
      if (transform_path_.empty()) throw UsageError("--handle needs --transform");
      constraints.handles = {read_vertex_list(handle_path_, loaded.mesh.vertex_count(), "a handle needs at least one vertex")};
      if (!fixed_path_.empty()) constraints.fixed = read_vertex_list(fixed_path_, loaded.mesh.vertex_count(), "the fixed vertices are the sinks");
      refuse_contradictions(constraints, fixed_path_, {handle_path_});
      transform = read_handle_transform(transform_path_);
    } else if (loaded.demo_constraints) {
      constraints = *loaded.demo_constraints;
      transform = *loaded.demo_transform;
    } else {
      throw UsageError("give --handle, --transform (and --fixed), or a --shape");
    }
    if (subdivide_ < 0 || subdivide_ > 4) throw UsageError("--subdivide must be between 0 and 4");
    if (!(relief_ >= 0.0 && relief_ <= 0.05)) throw UsageError("--relief must be between 0 and 0.05 (a fraction of the diagonal)");
    const Eigen::Index file_vertices = loaded.mesh.vertex_count(), file_triangles = loaded.mesh.triangle_count();
    double subdivide_ms = 0.0;
    for (int level = 0; level < subdivide_; ++level) {
      progress("subdividing: " + std::to_string(4 * loaded.mesh.triangle_count()) + " triangles");
      const auto subdivide_start = Clock::now();
      Subdivision subdivision = subdivide(loaded.mesh);
      constraints = subdivided_constraints(constraints, subdivision);
      loaded.mesh = std::move(subdivision.mesh);
      subdivide_ms += milliseconds_since(subdivide_start);
    }
    add_relief(loaded.mesh, relief_);
    // Shared by every deformer below, as the editor's set-ups share its document's mesh.
    shared_mesh_ = std::make_shared<const Mesh>(std::move(loaded.mesh));
    const Mesh& mesh = *shared_mesh_;
#ifdef HDEFORM_WITH_ENGINE
    if (render_) {
      progress("rendering benchmark");
      render_options_.quiet = quiet_;
      nlohmann::json report = bench_rendering(mesh, constraints, transform, render_options_);
      report["command"] = "bench";
      report["mesh"] = source_.describe();
      report["vertices"] = mesh.vertex_count();
      report["triangles"] = mesh.triangle_count();
      report["threads"] = solver.effective_threads();
      finish(report);
      return 0;
    }
#endif

    nlohmann::json report = {{"command", "bench"},
                             {"mesh", source_.describe()},
                             {"vertices", mesh.vertex_count()},
                             {"triangles", mesh.triangle_count()},
                             {"threads", solver.effective_threads()},
                             {"allocator", allocator_name()},
                             {"allocator_settings", allocator_settings()},
                             {"steps", steps_},
                             {"elimination_order", to_string(elimination_order_for(mesh.vertex_count()))},
                             {"read_ms", read_ms}};
    if (relief_ > 0.0) report["relief"] = relief_;
    if (subdivide_ > 0) {
      report["subdivide"] = {{"levels", subdivide_}, {"ms", subdivide_ms}, {"file_vertices", file_vertices}, {"file_triangles", file_triangles},
                             {"fixed", constraints.fixed.size()}, {"handle", constraints.handles[0].size()}};
    }

    // One drag of `steps_` updates, after one warm-up update; per-update milliseconds, and the
    // median of each stage in `stages` when given.
    auto drag = [&](Deformer& deformer, std::span<const HandleTransform> targets, Eigen::MatrixXd& positions,
                    nlohmann::json* stages = nullptr) {
      std::vector<HandleTransform> step(targets.size());
      std::vector<double> samples;
      std::map<std::string, std::vector<double>> stage_samples;
      for (int k = 0; k <= steps_; ++k) {
        for (std::size_t h = 0; h < targets.size(); ++h) step[h] = targets[h].at_fraction(std::max(k, 1) / static_cast<double>(steps_));
        const auto update_start = Clock::now();
        deformer.deform(step, positions);
        if (k == 0) continue;
        samples.push_back(milliseconds_since(update_start));
        const auto& t = deformer.last_update();
        for (const auto& [name, value] : {std::pair{"field", t.field_ms}, {"maps", t.maps_ms}, {"targets", t.targets_ms},
                                          {"rhs", t.rhs_ms}, {"solve", t.solve_ms}, {"write", t.write_ms}, {"detail", t.detail_ms}}) {
          stage_samples[name].push_back(value);
        }
      }
      if (stages != nullptr) {
        for (const auto& [name, values] : stage_samples) (*stages)[name] = std::round(summarize(values).median * 1000.0) / 1000.0;
      }
      return summarize(samples);
    };

    // Opening (read, then set up until the first drag can be answered) and re-selection (a new
    // handle on the same mesh: the mesh's operators reused, the factorization and field redone).
    {
      progress("open and re-selection");
      const auto setup_start = Clock::now();
      const Deformer opened(shared_mesh_, constraints, nullptr, options_for(default_backend(), default_schedule()));
      report["open_ms"] = read_ms + milliseconds_since(setup_start);
      report["resolution"] = to_string(opened.resolution());
      report["precision"] = to_string(opened.system().factor().precision());
      report["solved_vertices"] = opened.solved_mesh().vertex_count();
      report["base_ms"] = opened.timings().base_ms;
      report["warnings"] = opened.warnings();
      progress.warn(opened.warnings());
      // A base mesh is built once per mesh: every deformer below shares it (an exact one builds
      // its own operators, whose time each reports).
      if (opened.resolution() == Resolution::Multiresolution) shared_operators_ = opened.operators();
      std::vector<double> samples;
      for (auto& handle : spread_handles(mesh, constraints.fixed, constraints.handles[0].size())) {
        EditConstraints reselected = constraints;
        reselected.handles = {std::move(handle)};
        const auto reselect_start = Clock::now();
        const Deformer deformer(shared_mesh_, reselected, opened.operators(), options_for(default_backend(), default_schedule()));
        samples.push_back(milliseconds_since(reselect_start));
      }
      report["reselect_ms"] = to_json(summarize(samples));
      report["operators_ms"] = opened.operators()->ms;
    }

    // Backends: factorization and agreement of the final result.
    std::vector<Eigen::MatrixXd> results;
    for (const auto backend : kSolverBackends) {
      if (!backend_available(backend)) continue;
      progress("backend " + std::string(to_string(backend)));
      Deformer deformer(shared_mesh_, constraints, shared_operators_, options_for(backend, default_schedule()));
      Eigen::MatrixXd positions;
      const auto update = drag(deformer, std::span(&transform, 1), positions);
      report["backends"][std::string(to_string(backend))] = {
          {"laplacian_ms", deformer.timings().laplacian_ms},
          {"factor_ms", deformer.timings().factor_ms},
          {"field_ms", deformer.timings().field_ms},
          {"factor_nonzeros", deformer.system().factor().factor_nonzeros()},
          {"update_ms", to_json(update)},
      };
      report["free"] = deformer.system().free_count();
      if (deformer.system().factor().precision() == FactorPrecision::Single && backend == default_backend()) {
        DeformerOptions in_double = options_for(default_backend(), default_schedule());
        in_double.precision = FactorPrecision::Double;
        Deformer reference(shared_mesh_, constraints, shared_operators_, in_double);
        Eigen::MatrixXd expected;
        drag(reference, std::span(&transform, 1), expected);
        report["single_precision"] = single_precision_report(mesh, deformer, positions, expected);
      }
      results.push_back(std::move(positions));
    }
    // Largest difference of any backend's result from the first's.
    double backend_difference = 0.0;
    for (const auto& result : results) backend_difference = std::max(backend_difference, (result - results[0]).norm() / results[0].norm());
    report["backend_relative_difference"] = backend_difference;
    report["default_backend"] = to_string(default_backend());
    report["default_schedule"] = to_string(default_schedule());

    // Schedules: one handle (3 columns) and two handles (5 field columns + 3).
    const std::vector<HandleTransform> two_transforms{transform, transform.at_fraction(0.8)};
    EditConstraints two_handles = constraints;
    two_handles.handles = split_by_x(mesh, constraints.handles[0]);
    for (const auto schedule : {SolveSchedule::Blocked, SolveSchedule::PerColumn, SolveSchedule::ThreadGroups}) {
      if (subdivide_ > 0 && schedule != default_schedule()) continue;
      const std::string name(to_string(schedule));
      progress("schedule " + name);
      Eigen::MatrixXd positions;
      {
        Deformer deformer(shared_mesh_, constraints, shared_operators_, options_for(default_backend(), schedule));
        nlohmann::json stages;
        report["one_handle_update_ms"][name] = to_json(drag(deformer, std::span(&transform, 1), positions, &stages));
        if (schedule == default_schedule()) report["one_handle_stage_ms"] = stages;
        // The coordinate solve alone: 3 columns against the factor.
        ColumnBlocks blocks(deformer.system().free_count(), 3, schedule);
        std::mt19937 random(7);
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        std::vector<double> samples;
        for (int k = 0; k <= steps_; ++k) {
          for (Eigen::Index row = 0; row < blocks.rows(); ++row) {
            for (int c = 0; c < 3; ++c) blocks.at(row, c) = uniform(random);
          }
          const auto solve_start = Clock::now();
          blocks.solve(deformer.system().factor());
          if (k > 0) samples.push_back(milliseconds_since(solve_start));
        }
        report["solve_xyz_ms"][name] = to_json(summarize(samples));
      }
      {
        Deformer deformer(shared_mesh_, two_handles, shared_operators_, options_for(default_backend(), schedule));
        nlohmann::json stages;
        report["two_handle_update_ms"][name] = to_json(drag(deformer, two_transforms, positions, &stages));
        if (schedule == default_schedule()) report["two_handle_stage_ms"] = stages;
      }
    }

    if (subdivide_ == 0) {
      bench_refinement(constraints, transform, report, progress);
      bench_trace_overhead(constraints, transform, report, progress);
    }

    // The update as the editor runs it: posted to the pipeline's thread, one request at a time.
    {
      progress("pipeline");
      Deformer deformer(shared_mesh_, constraints, shared_operators_, options_for(default_backend(), default_schedule()));
      std::vector<double> samples;
      UpdatePipeline pipeline(deformer, [&](const UpdatePipeline::Result& result) { samples.push_back(result.update_ms); });
      for (int k = 0; k <= steps_; ++k) {
        const HandleTransform step = transform.at_fraction(std::max(k, 1) / static_cast<double>(steps_));
        pipeline.submit(std::span(&step, 1));
        pipeline.wait_idle();
      }
      samples.erase(samples.begin());  // the warm-up
      report["pipeline_update_ms"] = to_json(summarize(samples));
    }
    finish(report);
    return 0;
  }

 private:
  // A single-precision drag against the same drag in double: the largest deviation (a fraction of
  // the bounding box's diagonal) and what the refinement of the solves took.
  static nlohmann::json single_precision_report(const Mesh& mesh, const Deformer& single, const Eigen::MatrixXd& positions,
                                                const Eigen::MatrixXd& expected) {
    const auto& factor = single.system().factor();
    const auto refinement = factor.refinement();
    return {{"deviation_from_double", (positions - expected).cwiseAbs().maxCoeff() / bounding_box_diagonal(mesh.positions)},
            {"solves", refinement.solves},
            {"correction_steps", refinement.corrections},
            {"most_correction_steps", refinement.most_corrections},
            {"stalled", refinement.stalled},
            {"contraction", refinement.contraction},
            {"factor_values_mb", static_cast<double>(factor.factor_nonzeros()) * 2 * sizeof(float) / 1e6},
            {"double_factor_values_mb", static_cast<double>(factor.factor_nonzeros()) * 2 * sizeof(double) / 1e6}};
  }

  DeformerOptions options_for(SolverBackend backend, SolveSchedule schedule) const {
    DeformerOptions options = DeformerOptions::solver(backend, schedule);
    resolution_.apply(options);
    options.precision = parse_precision(precision_).value_or(FactorPrecision::Double);
    return options;
  }

  // What recording a trace costs a drag update: medians with the recorder off and on, in
  // alternating blocks (a recording of --trace's own goes on; otherwise a scratch one is made and
  // dropped).
  // On shared_mesh_.
  void bench_trace_overhead(const EditConstraints& constraints, const HandleTransform& transform, nlohmann::json& report,
                            const Progress& progress) const {
    progress("trace overhead");
    Deformer deformer(shared_mesh_, constraints, shared_operators_, options_for(default_backend(), default_schedule()));
    Eigen::MatrixXd positions;
    const bool recording = trace_.wanted();
    if (!recording) trace::start(std::size_t{1} << 16);
    std::vector<double> samples[2];
    std::size_t events_on = 0, updates_on = 0;
    // Many short blocks, so that the machine's drift over the run falls on both sides alike.
    for (int block = 0; block < 12; ++block) {
      const bool on = block % 2 == 1;
      if (on) trace::resume();
      else trace::stop();
      const std::size_t events_before = trace::recorded_events();
      for (int k = 0; k <= steps_; ++k) {
        const HandleTransform step = transform.at_fraction(std::max(k, 1) / static_cast<double>(steps_));
        const auto start = Clock::now();
        deformer.deform(std::span(&step, 1), positions);
        if (k > 0) samples[on ? 1 : 0].push_back(milliseconds_since(start));
      }
      if (on) {
        events_on += trace::recorded_events() - events_before;
        updates_on += static_cast<std::size_t>(steps_) + 1;
      }
    }
    if (recording) trace::resume();
    else trace::stop();
    const double off = summarize(samples[0]).median, on = summarize(samples[1]).median;
    report["trace_overhead"] = {{"update_ms_off", off},
                                {"update_ms_on", on},
                                {"ratio", on / off},
                                {"events_per_update", static_cast<double>(events_on) / static_cast<double>(updates_on)}};
  }

  // The as-rigid-as-possible refinement: one iteration and its stages; then how long the drag
  // (kRefineDragSteps updates with kRefineDragIterations iterations each, as `edit --steps 10
  // --refine 5`) and a cold start from the paper's result take to come within 1% of the converged
  // energy, accelerated and plain.
  // On shared_mesh_.
  void bench_refinement(const EditConstraints& constraints, const HandleTransform& transform, nlohmann::json& report,
                        const Progress& progress) const {
    constexpr int kRefineDragSteps = 10, kRefineDragIterations = 5, kPlainCap = 3000;
    progress("refinement iterations");
    DeformerOptions options = options_for(default_backend(), default_schedule());
    options.prepare_refinement = true;
    Deformer deformer(shared_mesh_, constraints, shared_operators_, options);
    Eigen::MatrixXd positions;
    std::map<std::string, std::vector<double>> stage_samples;
    std::vector<double> samples;
    deformer.deform(std::span(&transform, 1), positions);
    for (int k = 0; k <= steps_; ++k) {
      if (deformer.refine(positions, 1) == 0) break;  // converged already
      if (k == 0) continue;
      const auto& t = deformer.refinement_timings();
      samples.push_back(t.total_ms);
      for (const auto& [name, value] : {std::pair{"rhs", t.rhs_ms}, {"solve", t.solve_ms}, {"acceleration", t.acceleration_ms},
                                        {"rotations", t.rotations_ms}}) {
        stage_samples[name].push_back(value);
      }
    }
    report["refine_iteration_ms"] = to_json(summarize(samples));
    for (const auto& [name, values] : stage_samples) report["refine_stage_ms"][name] = std::round(summarize(values).median * 1000.0) / 1000.0;

    progress("refinement: the converged energy");
    RefinementOptions tight;
    tight.tolerance = 1e-10;
    tight.max_iterations = 5000;
    deformer.set_refinement_options(tight);
    deformer.deform(std::span(&transform, 1), positions);
    deformer.refine(positions, tight.max_iterations);
    const double converged = deformer.refinement_status().energy;
    nlohmann::json convergence = {{"converged_energy", converged}, {"unrefined_energy", deformer.refinement_status().unrefined_energy}};

    // Iterations and milliseconds until the energy is within 1% of the converged one.
    const auto until_within = [&](Deformer& d, int cap) {
      int iterations = 0;
      const auto start = Clock::now();
      while (d.refinement_status().energy > 1.01 * converged && iterations < cap && d.refine(positions, 1) == 1) ++iterations;
      return nlohmann::json{{"iterations", iterations}, {"ms", milliseconds_since(start)}, {"reached", d.refinement_status().energy <= 1.01 * converged}};
    };
    for (const bool accelerate : {true, false}) {
      progress(std::string("refinement: convergence, ") + (accelerate ? "accelerated" : "plain"));
      RefinementOptions refinement;
      refinement.accelerate = accelerate;
      refinement.tolerance = 1e-12;  // never stop early: within 1% is what is measured
      DeformerOptions fresh = options_for(default_backend(), default_schedule());
      fresh.refinement = refinement;
      fresh.prepare_refinement = true;
      const std::string name = accelerate ? "accelerated" : "plain";
      {
        Deformer cold(shared_mesh_, constraints, shared_operators_, fresh);
        cold.deform(std::span(&transform, 1), positions);
        cold.refine(positions, 0);
        convergence[name]["from_paper"] = until_within(cold, kPlainCap);
      }
      Deformer dragged(shared_mesh_, constraints, shared_operators_, fresh);
      for (int step = 1; step <= kRefineDragSteps; ++step) {
        const HandleTransform at = transform.at_fraction(static_cast<double>(step) / kRefineDragSteps);
        dragged.deform(std::span(&at, 1), positions, step == 1 ? RefinementStart::FromPapersResult : RefinementStart::FromLastEdit);
        dragged.refine(positions, kRefineDragIterations);
      }
      convergence[name]["after_drag"] = until_within(dragged, kPlainCap);
      convergence[name]["after_drag"]["drag_energy"] = dragged.refinement_status().energy;
    }
    report["refine_convergence"] = convergence;
  }

  void finish(nlohmann::json& report) const {
    report["peak_rss_mb"] = peak_rss_mb();
    if (trace_.wanted()) {
      trace_.finish();
      report["trace"] = trace_.path;
    }
    if (!out_path_.empty()) {
      const std::string text = report.dump(2) + "\n";
      write_file_atomically(out_path_, [&](std::ostream& out) { out << text; });
    }
    print_json_line(report);
  }

  MeshSource source_;
  TraceChoice trace_;
  ResolutionChoice resolution_;
  std::string precision_ = std::string(to_string(FactorPrecision::Double));
  std::shared_ptr<const Mesh> shared_mesh_;  // the mesh benchmarked
  std::shared_ptr<const MeshOperators> shared_operators_;  // multiresolution: the base, built once
  std::string fixed_path_;
  std::string handle_path_;
  std::string transform_path_;
  std::string out_path_;
  int steps_ = 30;
  int subdivide_ = 0;
  double relief_ = 0.0;
  int threads_ = 0;
  bool quiet_ = false;
#ifdef HDEFORM_WITH_ENGINE
  bool render_ = false;
  RenderBenchOptions render_options_;
#endif
};

}  // namespace

std::unique_ptr<BatchCommand> make_bench_command() { return std::make_unique<BenchCommand>(); }

}  // namespace hdeform::cli
