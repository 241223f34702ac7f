// hdeform field: the harmonic guidance field (paper §5) for given sources and sinks.
#include "batch_commands.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "hdeform/constraint_io.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_check.h"
#include "hdeform/stopwatch.h"
#ifdef HDEFORM_WITH_ENGINE
#include "render_support.h"
#endif

namespace hdeform::cli {
namespace {

class FieldCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("field", "Harmonic field: 1 at the sources, 0 at the sinks; one value per vertex");
    source_.add_options(*command);
    command->add_option("--sources", sources_path_, "Source vertices (value 1): 0-based indices");
    command->add_option("--sinks", sinks_path_, "Sink vertices (value 0): 0-based indices");
    command->add_option("--out", out_path_, "Output: one value per vertex per line")->required();
    solver_.add_options(*command);
    command->add_flag("--quiet", quiet_, "No progress or warnings on stderr");
#ifdef HDEFORM_WITH_ENGINE
    command->add_option("--png", png_path_, "Also render the field to this PNG (the paper's Figure 1, left)");
    picture_.add_options(*command);
#endif
    return command;
  }

  int run() override {
    source_.require();
    refuse_overwriting_inputs(out_path_, {source_.mesh_path, sources_path_, sinks_path_});
    if (!png_path_.empty()) refuse_overwriting_inputs(png_path_, {source_.mesh_path, sources_path_, sinks_path_});
    const auto threads = solver_.apply_threads();
    const Progress progress(quiet_);
    progress("reading " + source_.describe());
    LoadedMesh loaded = load_mesh(source_);
    const Mesh& mesh = loaded.mesh;

    EditConstraints constraints;
    if (!sources_path_.empty()) {
      constraints.handles = {read_vertex_list(sources_path_, mesh.vertex_count(), "the field needs a source")};
      if (!sinks_path_.empty()) constraints.fixed = read_vertex_list(sinks_path_, mesh.vertex_count(), "the sinks are where the field is 0");
      refuse_contradictions(constraints, sinks_path_, {sources_path_});
    } else if (loaded.demo_constraints) {
      if (!sinks_path_.empty()) throw UsageError("--sinks without --sources");
      constraints = *loaded.demo_constraints;
    } else {
      throw UsageError("give --sources FILE (and usually --sinks FILE)");
    }

    const auto weights = cotangent_weights(mesh);
    const auto partition = partition_vertices(mesh, weights, constraints);
    auto warnings = inspect_mesh(mesh, weights).warnings();
    warnings.insert(warnings.end(), partition.warnings.begin(), partition.warnings.end());
    if (constraints.fixed.empty()) warnings.emplace_back("no sinks: the field is 1 on every part that holds a source");
    progress.warn(warnings);
    progress("factoring " + std::to_string(partition.free_vertices.size()) + " unknowns");
    const DirichletSystem system(cotangent_laplacian(mesh, weights), partition, solver_.parsed_backend(), {}, nullptr,
                                 solver_.parsed_precision());
    if (const auto& note = system.factor().precision_note(); !note.empty()) {
      warnings.push_back(note);
      progress.warn({note});
    }
    progress("solving the harmonic field");
    const auto start = std::chrono::steady_clock::now();
    const Eigen::VectorXd field = harmonic_field(system, partition);
    const double field_ms = milliseconds_since(start);
    write_values(out_path_, field);
    nlohmann::json picture;
#ifdef HDEFORM_WITH_ENGINE
    if (!png_path_.empty()) {
      progress("rendering " + png_path_);
      engine::Scene scene{mesh.positions, mesh.triangles, field, vertex_classes(partition), {}, {}, picture_.up_axis(), {}};
      picture_.quiet = quiet_;
      picture = render_png(picture_, scene, png_path_);
    }
#endif

    nlohmann::json report({
        {"command", "field"},
        {"mesh", source_.describe()},
        {"vertices", mesh.vertex_count()},
        {"triangles", mesh.triangle_count()},
        {"sources", partition.count(VertexRole::Handle)},
        {"sinks", partition.count(VertexRole::Fixed)},
        {"backend", solver_.backend},
        {"precision", to_string(system.factor().precision())},
        {"factor_ms", system.factor_ms()},
        {"field_ms", field_ms},
        {"min", field.minCoeff()},
        {"max", field.maxCoeff()},
        {"warnings", warnings},
        {"output", out_path_},
    });
    if (!picture.is_null()) report["picture"] = picture;
    print_json_line(report);
    return 0;
  }

 private:
  MeshSource source_;
  SolverChoice solver_;
  std::string sources_path_;
  std::string sinks_path_;
  std::string out_path_;
  bool quiet_ = false;
  std::string png_path_;
#ifdef HDEFORM_WITH_ENGINE
  PictureOptions picture_;
#endif
};

}  // namespace

std::unique_ptr<BatchCommand> make_field_command() { return std::make_unique<FieldCommand>(); }

}  // namespace hdeform::cli
