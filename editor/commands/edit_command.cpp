// hdeform edit: the paper's editing pipeline in batch, optionally as a simulated drag.
#include <CLI/CLI.hpp>
#include <chrono>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <unordered_map>

#include "batch_commands.h"
#include "cli_support.h"
#include "hdeform/constraint_io.h"
#include "hdeform/counted.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shape_metrics.h"
#include "model/session.h"
#include "hdeform/stopwatch.h"
#ifdef HDEFORM_WITH_ENGINE
#include "render_support.h"
#endif

namespace hdeform::cli {
namespace {

class EditCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("edit", "Deform a mesh: fixed vertices stay, handles follow their transforms");
    source_.add_options(*command);
    command->add_option("--session", session_path_, "Replay an editor session (JSON) instead of --mesh/--fixed/--handle/--transform");
    command->add_option("--fixed", fixed_path_, "Fixed vertices (sinks): 0-based indices");
    command->add_option("--handle", handle_paths_, "Handle vertices (sources): 0-based indices; repeat for several handles");
    command->add_option("--transform", transform_paths_,
                        "Transform of the matching --handle: 12 numbers [A|t] row-major, or 'twist AX AY AZ PX PY PZ DEG [S]'");
    command->add_option("--roi", roi_path_, "Region of interest: 0-based indices (default: the whole mesh)");
    command->add_option("--sel", sel_path_,
                        "Botsch-Sorkine labels instead of --fixed/--handle: one per vertex, 0 fixed, 1 deformable, 2 handle (NAME.sel)");
    command->add_option("--def", def_path_, "With --sel: the handle's transform (NAME.def, a 4x4 matrix; anything --transform takes)");
    command->add_option("--out", out_path_, "Output mesh (.obj or .ply)")->required();
    command->add_option("--steps", steps_, "Simulate a drag: go from the identity to the transform in this many updates")
        ->capture_default_str();
    solver_.add_options(*command);
    resolution_.add_options(*command);
    refine_.add_options(*command);
    trace_.add_options(*command);
    command->add_flag("--quiet", quiet_, "No progress or warnings on stderr");
#ifdef HDEFORM_WITH_ENGINE
    command->add_option("--png", png_path_, "Also render the result to this PNG (fixed and handle vertices coloured)");
    picture_.add_options(*command);
#endif
    return command;
  }

  int run() override {
    if (!session_path_.empty()) {
      if (!source_.mesh_path.empty() || !source_.shape_name.empty() || !fixed_path_.empty() || !roi_path_.empty() || !handle_paths_.empty() ||
          !transform_paths_.empty()) {
        throw UsageError("--session replaces --mesh, --shape, --fixed, --roi, --handle and --transform");
      }
      if (refine_.iterations != "0") throw UsageError("--session carries its own refinement setting (each stage's \"refine\"); leave out --refine");
      if (resolution_.exact || resolution_.multiresolution) {
        throw UsageError("--session says where it solves (its \"resolution\"); leave out --exact and --multiresolution");
      }
    } else {
      source_.require();
    }
    if (!sel_path_.empty() || !def_path_.empty()) {
      if (sel_path_.empty() || def_path_.empty()) throw UsageError("--sel and --def go together: the labels and the handle's transform");
      if (!fixed_path_.empty() || !handle_paths_.empty() || !transform_paths_.empty() || !session_path_.empty()) {
        throw UsageError("--sel and --def replace --fixed, --handle, --transform and --session");
      }
    }
    if (handle_paths_.size() != transform_paths_.size()) {
      throw UsageError("give one --transform per --handle (" + std::to_string(handle_paths_.size()) + " handles, " +
                       std::to_string(transform_paths_.size()) + " transforms)");
    }
    if (steps_ < 1) throw UsageError("--steps must be at least 1");
    std::vector<std::string> inputs{source_.mesh_path, fixed_path_, roi_path_, session_path_, sel_path_, def_path_};
    inputs.insert(inputs.end(), handle_paths_.begin(), handle_paths_.end());
    inputs.insert(inputs.end(), transform_paths_.begin(), transform_paths_.end());
    refuse_overwriting_inputs(out_path_, inputs);
    refuse_unwritable_mesh_output("--out", out_path_);
    if (!png_path_.empty()) refuse_overwriting_inputs(png_path_, inputs);
    if (trace_.wanted()) refuse_overwriting_inputs(trace_.path, inputs);
    trace_.begin();
    const auto threads = solver_.apply_threads();
    const Progress progress(quiet_);
    DeformerOptions options = DeformerOptions::solver(solver_.parsed_backend(), solver_.parsed_schedule());
    options.precision = solver_.parsed_precision();
    resolution_.apply(options);
    int refine_iterations = refine_.parsed_iterations();
    options.refinement = refine_.options();
    options.prepare_refinement = refine_iterations > 0;
    std::optional<EditStage> session_stage;  // refined as the editor saves it, when it refines

    LoadedMesh loaded;
    EditConstraints constraints;
    std::vector<HandleTransform> transforms;
    std::string mesh_name = source_.describe();
    if (!session_path_.empty()) {
      progress("reading " + session_path_);
      SessionSource session_source;
      Session session = read_session(session_path_, &session_source);
      mesh_name = session.mesh;
      progress("reading " + session.mesh);
      loaded.mesh = load_session_mesh(session, &session_source);  // and the lists checked against it
      options.resolution = session.resolution;
      if (session.resolution == Resolution::Multiresolution) options.base_vertices = session.base_vertices;
      if (session.precision) {
        if (solver_.precision_given() && *session.precision != options.precision) {
          throw UsageError("--session says how its factors are stored (its \"precision\": " + std::string(to_string(*session.precision)) +
                           "); leave out --precision");
        }
        options.precision = *session.precision;
      }
      if (!session.applied.empty()) {
        progress("replaying " + counted(session.applied.size(), "applied stage", "applied stages"));
        Session applied_only = session;
        applied_only.current = {};
        loaded.mesh.positions = replay_session(applied_only, loaded.mesh, options, progress);
      }
      constraints = session.current.constraints();
      transforms = session.current.transforms();
      if (session.current.refine) session_stage = session.current;
      options.prepare_refinement = session.current.refine;
      if (transforms.empty()) {
        // Nothing is being edited: the result is the rest shape after the applied stages.
        write_mesh(out_path_, loaded.mesh);
        trace_.finish();
        print_json_line({{"command", "edit"}, {"mesh", mesh_name}, {"session", session_path_}, {"vertices", loaded.mesh.vertex_count()},
                         {"triangles", loaded.mesh.triangle_count()}, {"handles", 0}, {"output", out_path_}});
        return 0;
      }
    } else {
      progress("reading " + source_.describe());
      loaded = load_mesh(source_);
    }
    const auto vertex_count = loaded.mesh.vertex_count();
    if (!session_path_.empty()) {
      // constraints and transforms came from the session
    } else if (!sel_path_.empty()) {
      auto labels = read_vertex_labels(sel_path_, vertex_count);
      constraints.fixed = std::move(labels.fixed);
      constraints.handles = {std::move(labels.handle)};
      transforms = {read_handle_transform(def_path_)};
    } else if (!handle_paths_.empty()) {
      for (std::size_t h = 0; h < handle_paths_.size(); ++h) {
        constraints.handles.push_back(read_vertex_list(handle_paths_[h], vertex_count, "a handle needs at least one vertex"));
        transforms.push_back(read_handle_transform(transform_paths_[h]));
      }
      if (!fixed_path_.empty()) constraints.fixed = read_vertex_list(fixed_path_, vertex_count, "the fixed vertices are the sinks");
      refuse_contradictions(constraints, fixed_path_, handle_paths_);
    } else if (loaded.demo_constraints) {
      if (!fixed_path_.empty()) throw UsageError("--fixed without --handle: give the handles too, or neither for the demo edit");
      constraints = *loaded.demo_constraints;
      transforms = {*loaded.demo_transform};
    } else {
      throw UsageError("give at least one --handle FILE --transform FILE");
    }
    if (!roi_path_.empty()) constraints.region_of_interest = read_vertex_list(roi_path_, vertex_count, "an empty region of interest leaves nothing to deform");
    const std::string mesh_description = mesh_name;

    Deformer deformer(std::move(loaded.mesh), std::move(constraints), options, progress);
    auto warnings = deformer.warnings();
    if (transforms.size() > 1) {
      for (std::size_t h = 0; h < transforms.size(); ++h) {
        if (std::abs(transforms[h].angle) > std::numbers::pi) {
          warnings.push_back("handle " + std::to_string(h + 1) +
                             ": with several handles rotations are interpolated as quaternions, so a twist beyond half a turn "
                             "counts modulo a full turn");
        }
      }
    }
    progress.warn(warnings);

    progress("deforming in " + counted(static_cast<std::size_t>(steps_), "step", "steps") +
             (refine_iterations == 0 ? std::string()
              : refine_.until_converged() ? ", refined until converged"
                                          : ", " + counted(static_cast<std::size_t>(refine_iterations), "refinement iteration",
                                                           "refinement iterations") + " each"));
    Eigen::MatrixXd positions = deformer.rest().positions;
    std::vector<HandleTransform> step_transforms(transforms.size());
    std::vector<double> step_ms;
    int refined_iterations = 0;
    for (int step = 1; step <= steps_; ++step) {
      const double fraction = static_cast<double>(step) / steps_;
      for (std::size_t h = 0; h < transforms.size(); ++h) step_transforms[h] = transforms[h].at_fraction(fraction);
      const auto start = std::chrono::steady_clock::now();
      // After the first step, each step's refinement goes on from the last one's, as in a drag shown live.
      deformer.deform(step_transforms, positions, step == 1 ? RefinementStart::FromPapersResult : RefinementStart::FromLastEdit);
      if (refine_iterations > 0) refined_iterations += deformer.refine(positions, refine_iterations);
      step_ms.push_back(milliseconds_since(start));
    }
    if (session_stage) {
      progress("refining until converged, as the editor saves it");
      const auto start = std::chrono::steady_clock::now();
      positions = stage_result(deformer, *session_stage);
      step_ms.back() += milliseconds_since(start);
      refine_iterations = deformer.refinement_status().iterations;
      refined_iterations = refine_iterations;
    }
    if (!positions.allFinite()) throw SolveError("the deformation produced non-finite positions");
    if (refine_.until_converged() && !deformer.refinement_status().converged) {
      progress.warn({"the refinement did not converge in " + std::to_string(refine_iterations) + " iterations (energy " +
                     std::to_string(deformer.refinement_status().energy) + ")"});
    }

    progress("writing " + out_path_);
    write_mesh(out_path_, Mesh{positions, deformer.rest().triangles});
    nlohmann::json picture;
#ifdef HDEFORM_WITH_ENGINE
    if (!png_path_.empty()) {
      progress("rendering " + png_path_);
      engine::Scene scene{positions, deformer.rest().triangles, {}, vertex_classes(deformer.partition()), {},
                          engine::Bounds::of(deformer.rest().positions), picture_.up_axis(), {}};
      picture_.quiet = quiet_;
      picture = render_png(picture_, scene, png_path_);
    }
#endif

    const auto& partition = deformer.partition();
    const auto& timings = deformer.timings();
    nlohmann::json report = {
        {"command", "edit"},
        {"mesh", mesh_description},
        {"vertices", deformer.rest().vertex_count()},
        {"triangles", deformer.rest().triangle_count()},
        {"free", partition.count(VertexRole::Free)},
        {"fixed", partition.count(VertexRole::Fixed)},
        {"handle_vertices", partition.count(VertexRole::Handle)},
        {"handles", deformer.handle_count()},
        {"backend", to_string(options.backend)},
        {"schedule", to_string(options.schedule)},
        {"precision", to_string(deformer.system().factor().precision())},
        {"correction_steps", deformer.system().factor().refinement().corrections},
        {"threads", solver_.effective_threads()},
        {"resolution", to_string(deformer.resolution())},
        {"solved_vertices", deformer.solved_mesh().vertex_count()},
        {"laplacian_ms", timings.laplacian_ms},
        {"factor_ms", timings.factor_ms},
        {"base_ms", timings.base_ms},
        {"field_ms", timings.field_ms},
        {"steps", steps_},
        {"step_ms", to_json(summarize(step_ms))},
        {"mean_edge_strain", mean_edge_strain(deformer.rest(), positions)},
        {"peak_rss_mb", peak_rss_mb()},
        {"warnings", warnings},
        {"output", out_path_},
    };
    if (refine_iterations > 0) {
      const auto& status = deformer.refinement_status();
      report["refine"] = {{"iterations", refined_iterations},
                          {"last_step_iterations", status.iterations},
                          {"energy", status.energy},
                          {"unrefined_energy", status.unrefined_energy},
                          {"converged", status.converged},
                          {"settled", status.settled},
                          {"largest_step", status.largest_step},
                          {"accelerated", status.accelerated},
                          {"rejected", status.rejected}};
    }
    if (!picture.is_null()) report["picture"] = picture;
    if (trace_.wanted()) {
      trace_.finish();
      report["trace"] = trace_.path;
    }
    print_json_line(report);
    return 0;
  }

 private:
  MeshSource source_;
  SolverChoice solver_;
  ResolutionChoice resolution_;
  RefineChoice refine_;
  TraceChoice trace_;
  std::string session_path_;
  std::string fixed_path_;
  std::string roi_path_;
  std::string out_path_;
  std::string sel_path_;
  std::string def_path_;
  std::vector<std::string> handle_paths_;
  std::vector<std::string> transform_paths_;
  int steps_ = 1;
  bool quiet_ = false;
  std::string png_path_;
#ifdef HDEFORM_WITH_ENGINE
  PictureOptions picture_;
#endif
};

}  // namespace

std::unique_ptr<BatchCommand> make_edit_command() { return std::make_unique<EditCommand>(); }

}  // namespace hdeform::cli
