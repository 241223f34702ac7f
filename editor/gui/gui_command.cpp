// hdeform gui: the interactive editor.
#include "commands/batch_commands.h"

#include <CLI/CLI.hpp>
#include "commands/cli_support.h"
#include "gui/editor_app.h"

namespace hdeform::cli {
namespace {

class GuiCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("gui", "The interactive editor (without a mesh: the built-in cactus, ready for Figure 1)");
    command->add_option("mesh", options_.mesh, "Mesh to open (OBJ, PLY, OFF or STL), or shape:NAME[:RESOLUTION]");
    command->add_option("--session", options_.session, "Open an editor session (JSON)");
    command->add_option("--fixed", options_.fixed, "Fixed vertices: 0-based indices");
    command->add_option("--handle", options_.handles, "Handle vertices: 0-based indices; repeat for several handles");
    command->add_option("--transform", options_.transforms, "Starting transform of the matching --handle (as for edit)");
    command->add_option("--roi", options_.roi, "Region of interest: 0-based indices");
    command->add_option("--output", options_.output, "Where Ctrl+S saves the result (OBJ or PLY; the session goes beside it)");
    command->add_option("--up", options_.up,
                        "Up axis of the meshes: z or y (default: z in edit mode; in transfer mode each mesh's own, guessed from the "
                        "axis it stands on)");
    command->add_option("--size", options_.size, "Window size WIDTHxHEIGHT")->capture_default_str();
    command->add_option("--samples", options_.samples, "Multisampling (default: 4 on a GPU, 1 on a CPU device)");
    command->add_option("--device", options_.device, "Vulkan device: gpu, cpu, an index or part of a name");
    command->add_option("--pacing", options_.pacing,
                        "Solves and frames: free (frames never wait), latch (a frame waits up to 20 ms for the newest solve), "
                        "auto (latch on a CPU device)")
        ->check(CLI::IsMember({"auto", "free", "latch"}))
        ->capture_default_str();
    command->add_option("--proxy", options_.proxy,
                        "Large meshes on a CPU device: auto (a simplified mesh over the same vertices while it moves, the whole mesh "
                        "once it rests), off (always the whole mesh)")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    slice_option_ = command->add_option("--slice-triangles", options_.slice_triangles,
                                        "A still picture of more triangles than this is drawn over several frames, the window answering "
                                        "between them and showing the last picture meanwhile (default: 1000000 on a CPU device, 0 on a "
                                        "GPU; 0: always whole; needs --samples 1)");
    command->add_flag("--validation", options_.validation, "Enable the Khronos validation layer");
    resolution_.add_options(*command);
    add_precision_option(*command, precision_);
    command->add_flag("!--no-refine", options_.refine,
                      "A new session starts with the as-rigid-as-possible refinement off (the paper's method alone; a panel toggle)");
    command->add_option("--recovery-file", options_.recovery_file, "Crash-recovery file (default: $HDEFORM_RECOVERY_FILE or ~/.local/state/hdeform)");
    command->add_option("--restore", options_.restore, "After a crash: ask, yes or no")->capture_default_str();
    command->add_option("--screenshot-dir", options_.screenshot_dir, "Where F12 writes screenshots")->capture_default_str();
    command->add_option("--transfer-source", options_.transfer.source_rest, "Transfer mode: the source mesh at rest (OBJ, PLY, OFF or STL)");
    command->add_option("--transfer-target", options_.transfer.target, "Transfer mode: the target mesh (OBJ, PLY, OFF or STL)");
    command->add_option("--source-pose", options_.transfer.poses, "Transfer mode: source poses (OBJ, PLY, OFF or STL; * and ? match files in a folder)");
    command->add_option("--markers", options_.transfer.markers, "Transfer mode: marker pairs, loaded if the file exists; where Ctrl+S saves them");
    command->add_option("--source-column", options_.transfer.source_column, "Transfer mode: which marker column is the source's, 1 or 2")
        ->capture_default_str();
    command->add_option("--benchmark-drag", options_.benchmark_drag_seconds, "Drag the first handle for this many seconds, report frame times and latency, quit");
    command->add_option("--benchmark-out", options_.benchmark_out, "Also write the benchmark report to this file");
    command->add_option("--trace", options_.trace,
                        "Write a timeline of the session at exit (Chrome trace-event JSON: inputs, frames, the device's time, updates)");
    return command;
  }

  int run() override {
    if (options_.restore != "ask" && options_.restore != "yes" && options_.restore != "no") throw UsageError("--restore must be ask, yes or no");
    if (!options_.session.empty() && !options_.mesh.empty()) throw UsageError("give a mesh or --session, not both");
    if (!options_.session.empty() && (resolution_.exact || resolution_.multiresolution)) {
      throw UsageError("--session says where it solves (its \"resolution\"); leave out --exact and --multiresolution, and change it in the "
                       "panel (Solver: Solve on)");
    }
    if (options_.transforms.size() > options_.handles.size()) throw UsageError("more --transform than --handle");
    if (!options_.up.empty() && options_.up != "z" && options_.up != "y") throw UsageError("--up must be z or y");
    if (slice_option_->count() > 0 && options_.slice_triangles < 0) throw UsageError("--slice-triangles must be 0 (always whole) or more");
    if (options_.mesh.empty() && options_.session.empty() && (!options_.fixed.empty() || !options_.handles.empty() || !options_.roi.empty())) {
      throw UsageError("--fixed, --handle and --roi number the vertices of a mesh: give the mesh too (the built-in cactus is shape:cactus)");
    }
    if (options_.transfer.source_column != 1 && options_.transfer.source_column != 2) throw UsageError("--source-column must be 1 or 2");
    if (options_.transfer.source_rest.empty() != options_.transfer.target.empty()) {
      throw UsageError("transfer mode needs both --transfer-source and --transfer-target");
    }
    DeformerOptions solver;
    resolution_.apply(solver);
    options_.resolution = solver.resolution;
    options_.base_vertices = solver.base_vertices;
    options_.precision = parse_precision(precision_).value_or(FactorPrecision::Double);
    return run_editor(options_);
  }

 private:
  EditorOptions options_;
  CLI::Option* slice_option_ = nullptr;
  ResolutionChoice resolution_;
  std::string precision_ = std::string(to_string(FactorPrecision::Double));
};

}  // namespace

std::unique_ptr<BatchCommand> make_gui_command() { return std::make_unique<GuiCommand>(); }

}  // namespace hdeform::cli
