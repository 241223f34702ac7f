// hdeform correspondence: the §6 triangle correspondence on its own, as a map file and as the
// paper's Figure 4 (the target coloured by position, the source in the colours of the target
// triangles matched to it).
#include <CLI/CLI.hpp>
#include <fstream>
#include <nlohmann/json.hpp>

#include "batch_commands.h"
#include "cli_support.h"
#include "hdeform/atomic_file.h"
#include "transfer_support.h"
#ifdef HDEFORM_WITH_ENGINE
#include "hdeform/engine/mesh_renderer.h"
#include "render_support.h"
#endif

namespace hdeform::cli {
namespace {

#ifdef HDEFORM_WITH_ENGINE
// One vertex per triangle corner, so that each triangle carries its own colour.
engine::Scene per_triangle_scene(const Mesh& mesh, const std::vector<Eigen::Vector3f>& colors, engine::UpAxis up) {
  engine::Scene scene;
  const auto m = mesh.triangle_count();
  scene.positions.resize(3 * m, 3);
  scene.triangles.resize(m, 3);
  scene.classes.resize(static_cast<std::size_t>(3 * m));
  for (Eigen::Index t = 0; t < m; ++t) {
    for (int c = 0; c < 3; ++c) {
      scene.positions.row(3 * t + c) = mesh.positions.row(mesh.triangles(t, c));
      scene.triangles(t, c) = static_cast<int>(3 * t + c);
      scene.classes[static_cast<std::size_t>(3 * t + c)] = engine::color_class(colors[static_cast<std::size_t>(t)]);
    }
  }
  scene.rest_bounds = engine::Bounds::of(mesh.positions);
  scene.up = up;
  return scene;
}
#endif

class CorrespondenceCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("correspondence", "Match target triangles to source triangles by harmonic coordinates (paper §6)");
    arguments_.add_options(*command, false);
    command->add_option("--out", out_path_, "Write the map: per target triangle, its source triangle and the coordinate distance");
    solver_.add_options(*command);
    command->add_flag("--quiet", quiet_, "No progress or warnings on stderr");
#ifdef HDEFORM_WITH_ENGINE
    command->add_option("--png", png_path_, "Render the paper's Figure 4: the target coloured by position, the source in its matches' colours");
    picture_.add_options(*command);
#endif
    return command;
  }

  int run() override {
    const TransferOptions options = arguments_.options(solver_.parsed_backend(), solver_.parsed_precision());
    if (!out_path_.empty()) refuse_overwriting_inputs(out_path_, arguments_.inputs());
    if (!png_path_.empty()) refuse_overwriting_inputs(png_path_, arguments_.inputs());
    const auto threads = solver_.apply_threads();
    const Progress progress(quiet_);
    TransferInputs loaded = load_transfer_inputs(arguments_, progress);
    const DeformationTransfer transfer(std::move(loaded.source_rest), std::move(loaded.target), std::move(loaded.markers), options,
                                       [&](std::string_view stage) { progress(stage); });
    progress.warn(transfer.warnings());
    const auto& match = transfer.match();
    if (!out_path_.empty()) {
      write_file_atomically(out_path_, [&](std::ostream& out) {
        out << "# target triangle -> source triangle, harmonic-coordinate distance (mismatches marked)\n";
        for (std::size_t t = 0; t < match.source.size(); ++t) {
          out << t << ' ' << match.source[t] << ' ' << match.distance[t] << (transfer.mismatched()[t] ? " mismatch" : "") << '\n';
        }
      });
    }
    nlohmann::json report = describe_setup(transfer);
    report["command"] = "correspondence";
    std::vector<double> distances = match.distance;
    report["distance"] = to_json(summarize(distances));
    std::vector<bool> covered(static_cast<std::size_t>(transfer.source_rest().triangle_count()), false);
    for (std::size_t t = 0; t < match.source.size(); ++t) {
      if (!transfer.mismatched()[t]) covered[static_cast<std::size_t>(match.source[t])] = true;
    }
    report["source_triangles_matched"] = std::count(covered.begin(), covered.end(), true);
    if (!out_path_.empty()) report["output"] = out_path_;
#ifdef HDEFORM_WITH_ENGINE
    if (!png_path_.empty()) {
      progress("rendering " + png_path_);
      report["picture"] = render_figure(transfer);
    }
#endif
    print_json_line(report);
    return 0;
  }

 private:
#ifdef HDEFORM_WITH_ENGINE
  nlohmann::json render_figure(const DeformationTransfer& transfer) const {
    const Mesh& target = transfer.target_rest();
    const Mesh& source = transfer.source_rest();
    const auto& match = transfer.match();
    // Target: each triangle's barycenter within the bounding box as red, green, blue;
    // mismatches dark. Source: the mean colour of the target triangles matched to it; grey where
    // none is.
    const Eigen::RowVector3d low = target.positions.colwise().minCoeff();
    const Eigen::RowVector3d extent = (target.positions.colwise().maxCoeff() - low).cwiseMax(1e-300);
    std::vector<Eigen::Vector3f> target_colors(static_cast<std::size_t>(target.triangle_count()));
    std::vector<Eigen::Vector3d> sums(static_cast<std::size_t>(source.triangle_count()), Eigen::Vector3d::Zero());
    std::vector<int> counts(sums.size(), 0);
    for (Eigen::Index t = 0; t < target.triangle_count(); ++t) {
      const Eigen::RowVector3d centre = (target.positions.row(target.triangles(t, 0)) + target.positions.row(target.triangles(t, 1)) +
                                         target.positions.row(target.triangles(t, 2))) / 3.0;
      const Eigen::Vector3d color = ((centre - low).cwiseQuotient(extent)).transpose();
      const auto triangle = static_cast<std::size_t>(t);
      if (transfer.mismatched()[triangle]) {
        target_colors[triangle] = Eigen::Vector3f::Constant(0.15f);
        continue;
      }
      target_colors[triangle] = color.cast<float>();
      sums[static_cast<std::size_t>(match.source[triangle])] += color;
      ++counts[static_cast<std::size_t>(match.source[triangle])];
    }
    std::vector<Eigen::Vector3f> source_colors(sums.size());
    for (std::size_t s = 0; s < sums.size(); ++s) {
      source_colors[s] = counts[s] > 0 ? Eigen::Vector3f((sums[s] / counts[s]).cast<float>()) : Eigen::Vector3f::Constant(0.6f);
    }
    const std::vector<engine::Scene> panels{per_triangle_scene(target, target_colors, picture_.up_axis()),
                                            per_triangle_scene(source, source_colors, picture_.up_axis())};
    PictureOptions picture = picture_;
    picture.quiet = quiet_;
    return render_png(picture, panels, png_path_);
  }
#endif

  TransferArguments arguments_;
  SolverChoice solver_;
  std::string out_path_;
  bool quiet_ = false;
  std::string png_path_;
#ifdef HDEFORM_WITH_ENGINE
  PictureOptions picture_;
#endif
};

}  // namespace

std::unique_ptr<BatchCommand> make_correspondence_command() { return std::make_unique<CorrespondenceCommand>(); }

}  // namespace hdeform::cli
