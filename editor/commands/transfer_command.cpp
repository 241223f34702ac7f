// hdeform transfer: the poses of a source mesh copied onto a target (paper §6 or §7).
#include <CLI/CLI.hpp>
#include <chrono>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "batch_commands.h"
#include "cli_support.h"
#include "hdeform/counted.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "transfer_support.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

class TransferCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("transfer", "Copy the poses of a source mesh onto a target mesh from marker pairs");
    arguments_.add_options(*command, true);
    command->add_option("--source-pose", pose_paths_, "Source poses (OBJ, PLY, OFF or STL; the source rest mesh's connectivity); one output each")->required();
    command->add_option("--out-dir", out_dir_, "Where DIR/<pose name>.obj are written (created if missing)")->required();
    command->add_option("--expected", expected_paths_,
                        "Meshes the results should match, one per pose (the target's connectivity): reports the RMS vertex error "
                        "after rigid alignment over the bounding-box diagonal");
    solver_.add_options(*command);
    trace_.add_options(*command);
    command->add_flag("--quiet", quiet_, "No progress or warnings on stderr");
    return command;
  }

  int run() override {
    const TransferOptions options = arguments_.options(solver_.parsed_backend(), solver_.parsed_precision());
    if (!expected_paths_.empty() && expected_paths_.size() != pose_paths_.size()) {
      throw UsageError("give one --expected per --source-pose (" + std::to_string(pose_paths_.size()) + " poses, " +
                       std::to_string(expected_paths_.size()) + " expected)");
    }
    // Outputs are named after the poses; two poses with one name would overwrite each other.
    std::vector<std::string> outputs;
    std::map<std::string, std::string> named;
    std::vector<std::string> inputs = arguments_.inputs();
    inputs.insert(inputs.end(), pose_paths_.begin(), pose_paths_.end());
    inputs.insert(inputs.end(), expected_paths_.begin(), expected_paths_.end());
    for (const auto& pose : pose_paths_) {
      const std::string name = std::filesystem::path(pose).stem().string();
      const auto [it, inserted] = named.try_emplace(name, pose);
      if (!inserted) throw UsageError("poses " + it->second + " and " + pose + " would both be written to " + name + ".obj");
      outputs.push_back((std::filesystem::path(out_dir_) / (name + ".obj")).string());
      refuse_overwriting_inputs(outputs.back(), inputs);
    }
    if (trace_.wanted()) refuse_overwriting_inputs(trace_.path, inputs);
    const auto threads = solver_.apply_threads();
    const Progress progress(quiet_);
    trace_.begin();

    // Every input is read and checked before anything is written.
    TransferInputs loaded = load_transfer_inputs(arguments_, progress);
    progress("reading " + counted(pose_paths_.size(), "pose", "poses"));
    std::vector<Eigen::MatrixXd> poses;
    for (const auto& path : pose_paths_) {
      Mesh pose = read_mesh(path);
      if (pose.vertex_count() != loaded.source_rest.vertex_count() || pose.triangles != loaded.source_rest.triangles) {
        throw InputError(path + ": a pose must have the source rest mesh's vertices and triangles (it has " + std::to_string(pose.vertex_count()) +
                         " vertices and " + std::to_string(pose.triangle_count()) + " triangles, the rest mesh " +
                         std::to_string(loaded.source_rest.vertex_count()) + " and " + std::to_string(loaded.source_rest.triangle_count()) +
                         (pose.vertex_count() == loaded.source_rest.vertex_count() && pose.triangle_count() == loaded.source_rest.triangle_count()
                              ? ", listed differently)"
                              : ")"));
      }
      poses.push_back(std::move(pose.positions));
    }
    std::vector<Eigen::MatrixXd> expected;
    for (const auto& path : expected_paths_) {
      Mesh mesh = read_mesh(path);
      if (mesh.vertex_count() != loaded.target.vertex_count()) {
        throw InputError(path + ": " + std::to_string(mesh.vertex_count()) + " vertices; the target has " + std::to_string(loaded.target.vertex_count()));
      }
      expected.push_back(std::move(mesh.positions));
    }
    std::error_code error;
    std::filesystem::create_directories(out_dir_, error);
    if (error || !std::filesystem::is_directory(out_dir_)) throw InputError(out_dir_ + ": cannot create the output folder (" + error.message() + ")");

    const auto start = std::chrono::steady_clock::now();
    DeformationTransfer transfer(std::move(loaded.source_rest), std::move(loaded.target), std::move(loaded.markers), options,
                                 [&](std::string_view stage) { progress(stage); });
    progress.warn(transfer.warnings());
    nlohmann::json report = describe_setup(transfer);
    nlohmann::json per_pose = nlohmann::json::array();
    std::vector<double> pose_ms;
    double error_sum = 0.0;
    Eigen::MatrixXd result;
    for (std::size_t p = 0; p < poses.size(); ++p) {
      if (poses.size() > 1) progress("pose " + std::to_string(p + 1) + "/" + std::to_string(poses.size()) + ": " + pose_paths_[p]);
      transfer.transfer(poses[p], result);
      pose_ms.push_back(transfer.last_pose().total_ms);
      write_obj(outputs[p], Mesh{result, transfer.target_rest().triangles});
      nlohmann::json entry = {{"pose", pose_paths_[p]}, {"output", outputs[p]}, {"ms", transfer.last_pose().total_ms}};
      if (!expected.empty()) {
        const double aligned_error = aligned_rms_error(result, expected[p]);
        entry["error"] = aligned_error;
        error_sum += aligned_error;
      }
      per_pose.push_back(entry);
    }
    const double total_ms = milliseconds_since(start);

    report["command"] = "transfer";
    report["poses"] = poses.size();
    report["pose_ms"] = to_json(summarize(pose_ms));
    report["total_ms"] = total_ms;  // set-up and every pose, writing the results included (reading not)
    report["factorizations"] = transfer.factorizations();
    if (!expected.empty()) report["mean_error"] = error_sum / static_cast<double>(expected.size());
    report["per_pose"] = per_pose;
    report["out_dir"] = out_dir_;
    report["peak_rss_mb"] = peak_rss_mb();
    if (trace_.wanted()) {
      trace_.finish();
      report["trace"] = trace_.path;
    }
    print_json_line(report);
    return 0;
  }

 private:
  TransferArguments arguments_;
  SolverChoice solver_;
  TraceChoice trace_;
  std::vector<std::string> pose_paths_;
  std::vector<std::string> expected_paths_;
  std::string out_dir_;
  bool quiet_ = false;
};

}  // namespace

std::unique_ptr<BatchCommand> make_transfer_command() { return std::make_unique<TransferCommand>(); }

}  // namespace hdeform::cli
