#pragma once
// The interactive editor (`hdeform gui`): a GLFW window drawn by the Vulkan engine, a Dear ImGui
// side panel, and tools to paint vertex classes and move handles. Solves never run on this
// thread: a drag posts the newest poses to the document's update pipeline, and each frame shows
// the newest finished result without waiting for one.
#include <filesystem>
#include <string>
#include <vector>

#include "gui/transfer_view.h"
#include "hdeform/deformer.h"

namespace hdeform::cli {

struct EditorOptions {
  std::string mesh;     // OBJ path or shape:NAME[:RES]; empty: the built-in cactus, ready for Figure 1
  std::string session;  // a session to open instead
  std::string fixed;    // with a mesh: vertex lists and transforms, as for `hdeform edit`
  std::vector<std::string> handles;
  std::vector<std::string> transforms;
  std::string roi;
  std::string output;   // where Ctrl+S writes the result (OBJ) and, beside it, the session
  std::string up;  // z or y for every mesh; none: z in edit mode, each mesh's guessed in transfer mode
  std::string size = "1280x800";
  int samples = 0;      // 0: 4 on a GPU, 1 on a CPU device
  std::string device;
  std::string pacing = "auto";  // latch, free, or auto: latch on a CPU device (see wait_for_device)
  std::string proxy = "auto";   // auto: a simplified mesh while a large one moves on a CPU device (motion_detail.h); off
  long long slice_triangles = -1;  // a picture of more triangles is drawn over several frames; 0: whole; < 0: by device (scene_slices.h)
  bool validation = false;
  bool refine = true;   // a new session refines (as-rigid-as-possible); a session file says for itself
  // Where a new session solves (a session file says for itself): Automatic decides by the mesh's
  // size (multiresolution from kMultiresolutionFrom vertices).
  Resolution resolution = Resolution::Automatic;
  Eigen::Index base_vertices = kDefaultBaseVertices;
  // How a new session stores its factors (a session file that says keeps its own).
  FactorPrecision precision = FactorPrecision::Double;
  std::filesystem::path recovery_file;  // empty: default_recovery_path()
  std::string restore = "ask";          // ask, yes or no, when a recovery file is found
  std::string screenshot_dir = ".";
  double benchmark_drag_seconds = 0.0;  // > 0: drag the first handle for this long, report, exit
  std::string benchmark_out;            // the benchmark's JSON report (also printed)
  std::string trace;                    // a timeline of the session, written at exit (trace.h)
  TransferPaths transfer;              // a source or target given: start in transfer mode
};

// Runs until the window closes; returns the exit code. Throws UsageError or InputError for bad
// options or files given on the command line, RenderError when no window or device is available.
int run_editor(const EditorOptions& options);

}  // namespace hdeform::cli
