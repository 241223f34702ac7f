// hdeform render: a PNG of a mesh with its field, vertex classes and markers (offscreen).
#include "batch_commands.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "hdeform/constraint_io.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "render_support.h"

namespace hdeform::cli {
namespace {

class RenderCommand final : public BatchCommand {
 public:
  CLI::App* add_to(CLI::App& app) override {
    auto* command = app.add_subcommand("render", "Render a mesh to PNG: field as a colormap with isolines, fixed and handle vertices");
    source_.add_options(*command);
    command->add_option("--field", field_path_, "Per-vertex values (one per line), drawn as a colormap");
    command->add_option("--fixed", fixed_path_, "Fixed vertices to colour: 0-based indices");
    command->add_option("--handle", handle_paths_, "Handle vertices to colour: 0-based indices; repeat for several handles");
    command->add_option("--out", out_path_, "Output PNG")->required();
    picture_.add_options(*command);
    command->add_flag("--quiet", quiet_, "No progress on stderr");
    return command;
  }

  int run() override {
    source_.require();
    refuse_overwriting_inputs(out_path_, {source_.mesh_path, field_path_, fixed_path_});
    const Progress progress(quiet_);
    picture_.quiet = quiet_;
    progress("reading " + source_.describe());
    LoadedMesh loaded = load_mesh(source_);
    const Mesh& mesh = loaded.mesh;
    engine::Scene scene;
    scene.positions = mesh.positions;
    scene.triangles = mesh.triangles;
    scene.up = picture_.up_axis();

    EditConstraints constraints;
    if (!fixed_path_.empty()) constraints.fixed = read_vertex_list(fixed_path_, mesh.vertex_count(), "the fixed vertices to colour");
    for (const auto& path : handle_paths_) constraints.handles.push_back(read_vertex_list(path, mesh.vertex_count(), "a handle needs at least one vertex"));
    refuse_contradictions(constraints, fixed_path_, handle_paths_);
    if (!field_path_.empty()) scene.field = read_values(field_path_, mesh.vertex_count());
    const bool nothing_given = field_path_.empty() && fixed_path_.empty() && handle_paths_.empty();
    if (nothing_given && loaded.demo_constraints) {
      // A built-in shape on its own shows its demo: the harmonic field and its source and sink.
      constraints = *loaded.demo_constraints;
      const auto weights = cotangent_weights(mesh);
      const auto partition = partition_vertices(mesh, weights, constraints);
      const DirichletSystem system(cotangent_laplacian(mesh, weights), partition, default_backend());
      scene.field = harmonic_field(system, partition);
    }
    scene.classes.assign(static_cast<std::size_t>(mesh.vertex_count()), HD_CLASS_FREE);
    for (const int v : constraints.fixed) scene.classes[static_cast<std::size_t>(v)] = engine::fixed_class();
    for (std::size_t h = 0; h < constraints.handles.size(); ++h) {
      for (const int v : constraints.handles[h]) {
        auto& vertex_class = scene.classes[static_cast<std::size_t>(v)];
        if (vertex_class != HD_CLASS_FREE) throw InputError("vertex " + std::to_string(v) + " is in two vertex lists");
        vertex_class = engine::handle_class(h);
      }
    }

    progress("rendering " + out_path_);
    nlohmann::json report = render_png(picture_, scene, out_path_);
    report["command"] = "render";
    report["mesh"] = source_.describe();
    report["vertices"] = mesh.vertex_count();
    report["triangles"] = mesh.triangle_count();
    print_json_line(report);
    return 0;
  }

 private:
  MeshSource source_;
  PictureOptions picture_;
  std::string field_path_;
  std::string fixed_path_;
  std::vector<std::string> handle_paths_;
  std::string out_path_;
  bool quiet_ = false;
};

}  // namespace

std::unique_ptr<BatchCommand> make_render_command() { return std::make_unique<RenderCommand>(); }

}  // namespace hdeform::cli
