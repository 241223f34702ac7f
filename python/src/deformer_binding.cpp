// hdeform.Deformer: the solver's Deformer with its refinement setting and the arrays it hands to
// numpy; the GIL released while it sets up and solves.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arguments.h"
#include "hdeform/deformer.h"
#include "hdeform/multiresolution.h"
#include "result_pool.h"

namespace hdeform::python {
namespace {

// A Deformer with its refinement setting and the buffer it writes.
class PyDeformer {
 public:
  PyDeformer(const py::object& positions, const py::object& triangles, const py::object& fixed, const py::object& handles,
             const py::object& roi, const std::string& backend, const py::object& refine, double refine_tolerance, double refine_settle,
             bool acceleration, const py::object& progress, const std::string& resolution, Eigen::Index base_vertices,
             const std::string& precision) {
    Mesh mesh = mesh_argument(positions, triangles, "mesh");
    EditConstraints constraints;
    constraints.fixed = indices_argument(fixed, "fixed");
    if (!py::isinstance<py::sequence>(handles) || py::isinstance<py::str>(handles)) {
      throw py::value_error("handles must be a list of vertex index lists, one per handle");
    }
    std::size_t h = 0;
    for (const auto handle : handles.cast<py::sequence>()) constraints.handles.push_back(indices_argument(handle, "handles[" + std::to_string(h++) + "]"));
    if (!roi.is_none()) constraints.region_of_interest = indices_argument(roi, "roi");
    DeformerOptions options = DeformerOptions::solver(backend_argument(backend));
    options.precision = precision_argument(precision);
    const auto parsed_resolution = resolution == "auto" ? std::optional(Resolution::Automatic) : parse_resolution(resolution);
    if (!parsed_resolution || resolution == "automatic") {
      throw py::value_error("resolution must be 'auto', 'exact' or 'multiresolution', not '" + resolution + "'");
    }
    if (base_vertices < 4) throw py::value_error("base_vertices must be at least 4");
    options.resolution = *parsed_resolution;
    options.base_vertices = base_vertices;
    if (!(refine_tolerance > 0.0 && refine_tolerance < 1.0)) throw py::value_error("refine_tolerance must lie between 0 and 1");
    if (!(refine_settle >= 0.0 && refine_settle < 1.0)) throw py::value_error("refine_settle must be 0 (off) or a fraction below 1");
    options.refinement.tolerance = refine_tolerance;
    options.refinement.settle = refine_settle;
    options.refinement.accelerate = acceleration;
    refine_iterations_ = refine_argument(refine, options.refinement);
    options.prepare_refinement = refine_iterations_ > 0;
    if (!progress.is_none() && !PyCallable_Check(progress.ptr())) throw py::value_error("progress must be a callable taking a str, or None");
    // Called from this (the constructing) thread with the GIL released: taken back for the call.
    ProgressCallback report;
    if (!progress.is_none()) {
      report = [&progress](std::string_view stage) {
        const py::gil_scoped_acquire locked;
        progress(std::string(stage));
      };
    }
    const py::gil_scoped_release unlocked;
    deformer_ = std::make_unique<Deformer>(std::move(mesh), std::move(constraints), options, report);
  }

  py::array deform(const py::object& transforms_object, const py::object& refine) {
    const auto transforms = transforms_argument(transforms_object, deformer_->handle_count());
    const int iterations = refine.is_none() ? refine_iterations_ : refine_argument(refine, deformer_->refinement_options());
    auto positions = results_->take(deformer_->rest().vertex_count(), 3);
    {
      const py::gil_scoped_release unlocked;
      deformer_->deform(transforms, *positions);
      if (iterations > 0) deformer_->refine(*positions, iterations);
      last_ = *positions;
    }
    refined_ = iterations > 0;
    return ResultPool::hand_over(std::move(positions), results_);
  }

  py::array refine_more(int iterations) {
    if (last_.rows() == 0) throw py::value_error("refine: deform() first (it gives the edit to refine)");
    if (iterations < 0) throw py::value_error("refine: iterations must be 0 or more");
    auto positions = results_->take(last_.rows(), last_.cols());
    {
      const py::gil_scoped_release unlocked;
      deformer_->refine(last_, iterations);
      *positions = last_;
    }
    refined_ = true;
    return ResultPool::hand_over(std::move(positions), results_);
  }

  py::array field() const { return owning_array(Eigen::VectorXd(deformer_->field())); }
  std::vector<std::string> warnings() const { return deformer_->warnings(); }
  py::dict inspection() const {
    const MeshInspection& found = deformer_->inspection();
    py::dict result;
    result["degenerate_triangles"] = found.degenerate_triangles;
    result["ignored_triangles"] = found.ignored_triangles;
    result["nonmanifold_edges"] = found.nonmanifold_edges;
    result["nonmanifold_vertices"] = found.nonmanifold_vertices;
    result["duplicated_vertices"] = found.duplicated_vertices;
    result["boundary_edges"] = found.boundary_edges;
    result["components"] = found.components;
    result["unreferenced_vertices"] = found.unreferenced_vertices;
    return result;
  }
  double refine_tolerance() const { return deformer_->refinement_options().tolerance; }
  void set_refine_tolerance(double tolerance) {
    if (!(tolerance > 0.0 && tolerance < 1.0)) throw py::value_error("refine_tolerance must lie between 0 and 1");
    RefinementOptions options = deformer_->refinement_options();
    options.tolerance = tolerance;
    deformer_->set_refinement_options(options);
  }
  py::dict refinement() const {
    py::dict result;
    if (!refined_) {
      // The last deform() was the paper's update alone: nothing refined, no energy computed.
      result["iterations"] = 0;
      result["energy"] = py::none();
      result["unrefined_energy"] = py::none();
      result["converged"] = false;
      result["settled"] = false;
      result["largest_step"] = py::none();
      return result;
    }
    const auto& status = deformer_->refinement_status();
    result["iterations"] = status.iterations;
    result["energy"] = status.energy;
    result["unrefined_energy"] = status.unrefined_energy;
    result["converged"] = status.converged;
    result["settled"] = status.settled;
    result["largest_step"] = status.largest_step;
    return result;
  }
  py::dict timings() const {
    py::dict result;
    result["laplacian_ms"] = deformer_->timings().laplacian_ms;
    result["factor_ms"] = deformer_->timings().factor_ms;
    result["field_ms"] = deformer_->timings().field_ms;
    result["base_ms"] = deformer_->timings().base_ms;
    result["last_update_ms"] = deformer_->last_update().total_ms;
    result["last_detail_ms"] = deformer_->last_update().detail_ms;
    return result;
  }
  Eigen::Index vertex_count() const { return deformer_->rest().vertex_count(); }
  std::string resolution() const { return std::string(to_string(deformer_->resolution())); }
  std::string precision() const { return std::string(to_string(deformer_->system().factor().precision())); }
  Eigen::Index solved_vertex_count() const { return deformer_->solved_mesh().vertex_count(); }
  std::size_t handle_count() const { return deformer_->handle_count(); }

 private:
  std::unique_ptr<Deformer> deformer_;
  int refine_iterations_ = 0;
  Eigen::MatrixXd last_;  // the last edit's positions, which refine() goes on from
  std::shared_ptr<ResultPool> results_ = std::make_shared<ResultPool>();
  bool refined_ = false;  // the last edit has been refined (else its refinement_status is an older edit's)
};

}  // namespace

void bind_deformer(py::module_& m) {
  static const std::string deformer_doc =
      R"doc(Sets up the solve once: Laplacian, factorization, harmonic field.

V: (n, 3) positions, any float dtype (float32 is widened) or nested lists.
F: (m, 3) triangles, 0-based vertex indices, any integer dtype or nested lists.
fixed: 1-D integer array or list of the vertices that stay at rest (the sinks).
handles: a list of 1-D integer arrays or lists, one per handle (the sources).
roi: 1-D integer array or list, the region of interest (None: the whole mesh); vertices
    outside it stay where they are.
backend: 'tree' (the default), 'eigen' or 'cholmod'.
refine: as-rigid-as-possible iterations after each deform(): 0 (the paper's method alone), a
    number, or 'auto' (until an iteration gains less than refine_tolerance, or moves no vertex
    by more than refine_settle of the bounding-box diagonal when that is > 0).
acceleration: Anderson acceleration of the refinement.
progress: None or a callable taking one str, called before each set-up stage.
resolution: 'exact' (every vertex an unknown), 'multiresolution' (the solves on a base mesh of
    about base_vertices vertices, the detail carried; fixed and handle vertices exact) or 'auto'
    (multiresolution from )doc" + std::to_string(kMultiresolutionFrom) + R"doc( vertices on).
precision: 'double', or 'single': the factor stored in single precision (half its memory), every
    solve refined against the double matrix to the same accuracy, one or two steps more per solve.
    A matrix too ill-conditioned for it keeps double, and warnings says so. (Also for
    harmonic_field, transfer and correspondence.)

Raises ValueError for a wrong shape or dtype, hdeform.InputError for bad data (a handle without
a fixed vertex in its part of the mesh, an index out of range) and hdeform.SolveError when the
factorization fails.)doc";
  py::class_<PyDeformer>(m, "Deformer", R"doc(The editing engine: set up once per mesh and vertex classes, then deform() per edit.

    deformer = hdeform.Deformer(V, F, fixed, [handle], refine="auto")
    bent = deformer.deform([hdeform.Transform(matrix_3x4)])    # (n, 3) float64)doc")
      .def(py::init<const py::object&, const py::object&, const py::object&, const py::object&, const py::object&, const std::string&,
                    const py::object&, double, double, bool, const py::object&, const std::string&, Eigen::Index, const std::string&>(),
           py::arg("V"), py::arg("F"), py::arg("fixed"), py::arg("handles"), py::arg("roi") = py::none(),
           py::arg("backend") = std::string(to_string(default_backend())), py::arg("refine") = 0,
           py::arg("refine_tolerance") = RefinementOptions{}.tolerance, py::arg("refine_settle") = RefinementOptions{}.settle,
           py::arg("acceleration") = true, py::arg("progress") = py::none(), py::arg("resolution") = "auto",
           py::arg("base_vertices") = kDefaultBaseVertices, py::arg("precision") = "double",
           deformer_doc.c_str())
      .def("deform", &PyDeformer::deform, py::arg("transforms"), py::arg("refine") = py::none(),
           R"doc(The deformed positions for one transform per handle.

transforms: a list with one Transform, or (3, 4) / (4, 4) float array, per handle.
refine: None (the constructor's refine), or a number or 'auto' for this call.
Returns an (n, 3) float64 array. Refinement starts from the paper's result for this pose, so the
same pose gives the same positions whatever was deformed before.)doc")
      .def("refine", &PyDeformer::refine_more, py::arg("iterations") = 1,
           R"doc(Up to `iterations` (int) more refinement iterations of the last deform(), fewer once converged.

Returns the (n, 3) float64 positions. deform(T, refine=0) then refine() until
refinement['converged'] gives the same bits as deform(T, refine='auto').)doc")
      .def_property_readonly("field", &PyDeformer::field, "The harmonic field h, an (n,) float64 array: 1 on the handles, 0 on the fixed vertices")
      .def_property_readonly("warnings", &PyDeformer::warnings, "Findings about the mesh and the handles (list of str), as `hdeform edit` reports them")
      .def_property_readonly("inspection", &PyDeformer::inspection,
                             "What the mesh's inspection counted, a dict of int: degenerate_triangles (zero-area or needle), "
                             "ignored_triangles (duplicated, or with a repeated vertex), nonmanifold_edges, nonmanifold_vertices, "
                             "duplicated_vertices, boundary_edges, components, unreferenced_vertices (the warnings' lines say the same in words)")
      .def_property_readonly("refinement", &PyDeformer::refinement,
                             "The last edit's refinement, a dict: iterations (int), energy and unrefined_energy (float, None "
                             "before any iteration), converged, settled (bool), largest_step (float, a fraction of the diagonal)")
      .def_property("refine_tolerance", &PyDeformer::refine_tolerance, &PyDeformer::set_refine_tolerance,
                    "Where a refinement until converged stops: the energy falls by less than this fraction in an iteration")
      .def_property_readonly("timings", &PyDeformer::timings, "Set-up stages and the last update's stages, a dict of float milliseconds")
      .def_property_readonly("vertex_count", &PyDeformer::vertex_count, "n, the mesh's vertices")
      .def_property_readonly("resolution", &PyDeformer::resolution, "Where the solves run: 'exact' or 'multiresolution'")
      .def_property_readonly("precision", &PyDeformer::precision, "How the factor is stored: 'double' or 'single'")
      .def_property_readonly("solved_vertex_count", &PyDeformer::solved_vertex_count,
                             "The vertices the solves run on: the base mesh's with multiresolution, else vertex_count")
      .def_property_readonly("handle_count", &PyDeformer::handle_count, "The number of handles: deform() takes one transform each");
}

}  // namespace hdeform::python
