// hdeform._core: the solver (and, when built, the renderer) for Python. numpy arrays in and out:
// positions n×3 float64, triangles m×3 int32 (any integer type accepted), index lists 1-D. Results
// are handed to numpy without a copy (column-major arrays that own the solver's matrices). The
// GIL is released while anything is solved. InputError and SolveError keep the command line's
// messages, as hdeform.InputError (a ValueError) and hdeform.SolveError (a RuntimeError).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/counted.h"
#include "hdeform/deformer.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/handle_transform.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"
#include "hdeform/transfer.h"
#include "result_pool.h"
#include "commands/cli_support.h"
#ifdef HDEFORM_WITH_ENGINE
#include "commands/render_support.h"
#endif

namespace py = pybind11;

namespace hdeform::python {
namespace {

std::string type_name(const py::handle& object) { return py::str(py::type::of(object).attr("__name__")).cast<std::string>(); }

std::string describe_array(const py::array& array) {
  std::string shape = "(";
  for (py::ssize_t d = 0; d < array.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(array.shape(d));
  if (array.ndim() == 1) shape += ",";
  return py::str(array.dtype()).cast<std::string>() + " of shape " + shape + ")";
}

py::array as_array(const py::handle& object, const std::string& name, const std::string& expected) {
  try {
    return py::module_::import("numpy").attr("asarray")(object).cast<py::array>();
  } catch (const py::error_already_set&) {
    throw py::value_error(name + " must be " + expected + "; got a " + type_name(object));
  }
}

// n×3 floating point (float64, or float32 widened).
Eigen::MatrixXd positions_argument(const py::handle& object, const std::string& name) {
  const std::string expected = "a float64 array of shape (n, 3)";
  const py::array array = as_array(object, name, expected);
  if (array.dtype().kind() != 'f' || array.ndim() != 2 || array.shape(1) != 3) {
    throw py::value_error(name + " must be " + expected + "; got " + describe_array(array));
  }
  const auto values = array.cast<py::array_t<double, py::array::forcecast>>();
  const auto view = values.unchecked<2>();
  Eigen::MatrixXd positions(view.shape(0), 3);
  for (py::ssize_t i = 0; i < view.shape(0); ++i) {
    for (py::ssize_t c = 0; c < 3; ++c) positions(i, c) = view(i, c);
  }
  return positions;
}

// Integers that fit an int, of shape (rows, columns) or, with columns = 0, 1-D.
Eigen::MatrixXi integer_argument(const py::handle& object, const std::string& name, py::ssize_t columns, const std::string& expected) {
  const py::array array = as_array(object, name, expected);
  const bool shape_ok = columns == 0 ? array.ndim() == 1 : (array.ndim() == 2 && array.shape(1) == columns);
  const bool empty_list = columns == 0 && array.ndim() == 1 && array.shape(0) == 0;
  if ((!empty_list && array.dtype().kind() != 'i' && array.dtype().kind() != 'u') || !shape_ok) {
    throw py::value_error(name + " must be " + expected + "; got " + describe_array(array));
  }
  const auto values = array.cast<py::array_t<long long, py::array::c_style | py::array::forcecast>>();  // row-major: read below in order
  const py::ssize_t rows = values.shape(0);
  const py::ssize_t width = columns == 0 ? 1 : columns;
  Eigen::MatrixXi result(rows, width);
  const long long* data = values.data();
  for (py::ssize_t i = 0; i < rows * width; ++i) {
    if (data[i] < std::numeric_limits<int>::min() || data[i] > std::numeric_limits<int>::max()) {
      throw py::value_error(name + ": index " + std::to_string(data[i]) + " does not fit a 32-bit int");
    }
  }
  for (py::ssize_t i = 0; i < rows; ++i) {
    for (py::ssize_t c = 0; c < width; ++c) result(i, c) = static_cast<int>(data[i * width + c]);
  }
  return result;
}

Eigen::MatrixXi triangles_argument(const py::handle& object, const std::string& name) {
  return integer_argument(object, name, 3, "an integer array of shape (m, 3)");
}

std::vector<int> indices_argument(const py::handle& object, const std::string& name) {
  const Eigen::MatrixXi column = integer_argument(object, name, 0, "a 1-D array (or list) of vertex indices");
  return {column.data(), column.data() + column.size()};
}

Mesh mesh_argument(const py::handle& positions, const py::handle& triangles, const std::string& name) {
  Mesh mesh{positions_argument(positions, name + " positions"), triangles_argument(triangles, name + " triangles")};
  validate_mesh(mesh, name);
  return mesh;
}

// numpy views owning the matrices: no copy.
template <class Matrix>
py::array owning_array(Matrix&& matrix) {
  using Scalar = typename std::decay_t<Matrix>::Scalar;
  auto* owned = new std::decay_t<Matrix>(std::forward<Matrix>(matrix));
  const py::capsule release(owned, [](void* pointer) { delete static_cast<std::decay_t<Matrix>*>(pointer); });
  const auto rows = static_cast<py::ssize_t>(owned->rows());
  if constexpr (std::decay_t<Matrix>::ColsAtCompileTime == 1) {
    return py::array_t<Scalar>({rows}, {static_cast<py::ssize_t>(sizeof(Scalar))}, owned->data(), release);
  } else {
    const auto cols = static_cast<py::ssize_t>(owned->cols());
    return py::array_t<Scalar>({rows, cols}, {static_cast<py::ssize_t>(sizeof(Scalar)), static_cast<py::ssize_t>(sizeof(Scalar)) * rows},
                               owned->data(), release);
  }
}

py::array index_array(const std::vector<int>& indices) {
  Eigen::VectorXi column = Eigen::Map<const Eigen::VectorXi>(indices.data(), static_cast<Eigen::Index>(indices.size()));
  return owning_array(std::move(column));
}

SolverBackend backend_argument(const std::string& name) {
  const auto backend = parse_backend(name);
  if (!backend) throw py::value_error("backend must be 'tree', 'eigen' or 'cholmod'; got '" + name + "'");
  if (!backend_available(*backend)) throw py::value_error("this build has no " + name + " backend");
  return *backend;
}

FactorPrecision precision_argument(const std::string& name) {
  const auto precision = parse_precision(name);
  if (!precision) throw py::value_error("precision must be 'double' or 'single'; got '" + name + "'");
  return *precision;
}

// A 3×4 or 4×4 matrix (its last row 0 0 0 1), or a Transform.
HandleTransform transform_argument(const py::handle& object, const std::string& name) {
  if (py::isinstance<HandleTransform>(object)) return object.cast<HandleTransform>();
  const std::string expected = "a Transform or a float array of shape (3, 4) or (4, 4)";
  const py::array array = as_array(object, name, expected);
  if ((array.dtype().kind() != 'f' && array.dtype().kind() != 'i') || array.ndim() != 2 || array.shape(1) != 4 ||
      (array.shape(0) != 3 && array.shape(0) != 4)) {
    throw py::value_error(name + " must be " + expected + "; got " + describe_array(array));
  }
  const auto values = array.cast<py::array_t<double, py::array::forcecast>>().unchecked<2>();
  if (values.shape(0) == 4 && (values(3, 0) != 0.0 || values(3, 1) != 0.0 || values(3, 2) != 0.0 || values(3, 3) != 1.0)) {
    throw InputError(name + ": a 4×4 transform must end with the row 0 0 0 1 (it is not affine)");
  }
  Eigen::Matrix<double, 3, 4> affine;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) affine(r, c) = values(r, c);
  }
  try {
    return HandleTransform::from_affine(affine);
  } catch (const InputError& error) {
    throw InputError(name + ": " + error.what());
  }
}

std::vector<HandleTransform> transforms_argument(const py::handle& object, std::size_t handles) {
  std::vector<HandleTransform> transforms;
  const bool one = py::isinstance<HandleTransform>(object) ||
                   (py::isinstance<py::array>(object) && py::reinterpret_borrow<py::array>(object).ndim() == 2);
  if (one) {
    transforms.push_back(transform_argument(object, "transform"));
  } else {
    if (!py::isinstance<py::sequence>(object)) throw py::value_error("transforms must be a list with one transform per handle");
    std::size_t k = 0;
    for (const auto item : object.cast<py::sequence>()) transforms.push_back(transform_argument(item, "transforms[" + std::to_string(k++) + "]"));
  }
  if (transforms.size() != handles) {
    throw py::value_error(counted(transforms.size(), "transform", "transforms") + " for " + counted(handles, "handle", "handles"));
  }
  return transforms;
}

// "auto" (until converged), or a number of iterations (0: the paper's method alone).
int refine_argument(const py::object& refine, const RefinementOptions& options) {
  if (py::isinstance<py::str>(refine)) {
    if (refine.cast<std::string>() != "auto") throw py::value_error("refine must be a number of iterations or 'auto'");
    return options.max_iterations;
  }
  if (!py::isinstance<py::int_>(refine) || refine.cast<long long>() < 0 || refine.cast<long long>() > 100000) {
    throw py::value_error("refine must be a number of iterations (0 to 100000) or 'auto'");
  }
  return refine.cast<int>();
}

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

py::tuple read_mesh_binding(const std::filesystem::path& path) {
  Mesh mesh;
  {
    const py::gil_scoped_release unlocked;
    mesh = read_mesh(path);
  }
  return py::make_tuple(owning_array(std::move(mesh.positions)), owning_array(std::move(mesh.triangles)));
}

void write_mesh_binding(const std::filesystem::path& path, const py::object& positions, const py::object& triangles) {
  const Mesh mesh = mesh_argument(positions, triangles, path.string());
  const py::gil_scoped_release unlocked;
  write_mesh(path, mesh);
}

py::dict shape_binding(const std::string& name, int resolution) {
  const auto kind = parse_shape(name);
  if (!kind) throw py::value_error("unknown shape '" + name + "' (cactus, bar, cylinder, sphere)");
  if (resolution < 8) throw py::value_error("resolution must be at least 8");
  Shape shape = make_shape(*kind, resolution);
  py::dict result;
  result["V"] = owning_array(std::move(shape.mesh.positions));
  result["F"] = owning_array(std::move(shape.mesh.triangles));
  result["fixed"] = index_array(shape.demo_constraints.fixed);
  py::list handles;
  for (const auto& handle : shape.demo_constraints.handles) handles.append(index_array(handle));
  result["handles"] = handles;
  result["transform"] = shape.demo_transform;
  return result;
}

py::tuple laplacian_binding(const py::object& positions, const py::object& triangles) {
  const Mesh mesh = mesh_argument(positions, triangles, "mesh");
  Eigen::SparseMatrix<double> laplacian;
  {
    const py::gil_scoped_release unlocked;
    laplacian = cotangent_laplacian(mesh);
    laplacian.makeCompressed();
  }
  const auto nonzeros = laplacian.nonZeros();
  Eigen::VectorXd data = Eigen::Map<const Eigen::VectorXd>(laplacian.valuePtr(), nonzeros);
  Eigen::VectorXi indices = Eigen::Map<const Eigen::VectorXi>(laplacian.innerIndexPtr(), nonzeros);
  Eigen::VectorXi starts = Eigen::Map<const Eigen::VectorXi>(laplacian.outerIndexPtr(), laplacian.cols() + 1);
  return py::make_tuple(owning_array(std::move(data)), owning_array(std::move(indices)), owning_array(std::move(starts)), laplacian.rows());
}

py::array harmonic_field_binding(const py::object& positions, const py::object& triangles, const py::object& sources,
                                 const py::object& sinks, const std::string& backend, const std::string& precision) {
  const Mesh mesh = mesh_argument(positions, triangles, "mesh");
  EditConstraints constraints;
  constraints.handles = {indices_argument(sources, "sources")};
  constraints.fixed = indices_argument(sinks, "sinks");
  if (constraints.handles.front().empty()) throw InputError("sources: the field needs at least one source vertex");
  const SolverBackend chosen = backend_argument(backend);
  const FactorPrecision stored = precision_argument(precision);
  Eigen::VectorXd field;
  {
    const py::gil_scoped_release unlocked;
    const auto weights = cotangent_weights(mesh);
    const auto partition = partition_vertices(mesh, weights, constraints);
    const DirichletSystem system(cotangent_laplacian(mesh, weights), partition, chosen, {}, nullptr, stored);
    field = harmonic_field(system, partition);
  }
  return owning_array(std::move(field));
}

// Midpoint subdivision, `levels` times, with vertex sets carried over (subdivision.h).
py::tuple subdivide_binding(const py::object& positions, const py::object& triangles, int levels, const py::object& sets) {
  if (levels < 0 || levels > 4) throw py::value_error("levels must be between 0 and 4 (each multiplies the triangles by four)");
  Mesh mesh = mesh_argument(positions, triangles, "mesh");
  std::vector<std::vector<int>> carried;
  for (const py::handle set : sets) {
    const std::string name = "sets[" + std::to_string(carried.size()) + "]";
    carried.push_back(indices_argument(set, name));
    for (const int v : carried.back()) {
      if (v < 0 || v >= mesh.vertex_count()) {
        throw InputError(name + ": vertex " + std::to_string(v) + " out of range (the mesh has " + std::to_string(mesh.vertex_count()) + " vertices)");
      }
    }
  }
  {
    const py::gil_scoped_release unlocked;
    for (int level = 0; level < levels; ++level) {
      Subdivision subdivision = subdivide(mesh);
      for (auto& set : carried) set = subdivided_set(set, subdivision);
      mesh = std::move(subdivision.mesh);
    }
  }
  py::list out_sets;
  for (const auto& set : carried) out_sets.append(index_array(set));
  return py::make_tuple(owning_array(std::move(mesh.positions)), owning_array(std::move(mesh.triangles)), out_sets);
}

py::array add_relief_binding(const py::object& positions, const py::object& triangles, double amplitude) {
  Mesh mesh = mesh_argument(positions, triangles, "mesh");
  {
    const py::gil_scoped_release unlocked;
    add_relief(mesh, amplitude);
  }
  return owning_array(std::move(mesh.positions));
}

struct TransferArguments {
  Mesh source;
  Mesh target;
  MarkerPairs markers;
  TransferOptions options;
};

TransferArguments transfer_arguments(const py::tuple& source_rest, const py::tuple& target, const py::object& markers,
                                     const std::string& method, int top_n, double mismatch_threshold, const std::string& backend,
                                     const std::string& precision) {
  if (source_rest.size() != 2 || target.size() != 2) throw py::value_error("source_rest and target must each be a (V, F) pair");
  TransferArguments arguments{mesh_argument(source_rest[0], source_rest[1], "source mesh"), mesh_argument(target[0], target[1], "target mesh"),
                              {}, {}};
  const Eigen::MatrixXi pairs = integer_argument(markers, "markers", 2, "an integer array of shape (k, 2): source vertex, target vertex");
  for (Eigen::Index k = 0; k < pairs.rows(); ++k) {
    arguments.markers.source.push_back(pairs(k, 0));
    arguments.markers.target.push_back(pairs(k, 1));
  }
  const auto parsed = parse_transfer_method(method);
  if (!parsed) throw py::value_error("method must be 'correspondence' or 'interpolation'; got '" + method + "'");
  arguments.options.method = *parsed;
  arguments.options.top_n = top_n;
  arguments.options.mismatch_threshold = mismatch_threshold;
  arguments.options.backend = backend_argument(backend);
  arguments.options.precision = precision_argument(precision);
  return arguments;
}

py::list transfer_binding(const py::tuple& source_rest, const py::object& source_poses, const py::tuple& target, const py::object& markers,
                          const std::string& method, int top_n, double mismatch_threshold, const std::string& backend,
                          const std::string& precision) {
  auto arguments = transfer_arguments(source_rest, target, markers, method, top_n, mismatch_threshold, backend, precision);
  if (!py::isinstance<py::sequence>(source_poses)) throw py::value_error("source_poses must be a list of (n, 3) position arrays");
  std::vector<Eigen::MatrixXd> poses;
  for (const auto pose : source_poses.cast<py::sequence>()) {
    const std::string name = "source_poses[" + std::to_string(poses.size()) + "]";
    poses.push_back(positions_argument(pose, name));
    if (poses.back().rows() != arguments.source.vertex_count()) {
      throw py::value_error(name + " has " + std::to_string(poses.back().rows()) + " vertices; the source rest mesh has " +
                            std::to_string(arguments.source.vertex_count()));
    }
  }
  std::vector<Eigen::MatrixXd> results(poses.size());
  {
    const py::gil_scoped_release unlocked;
    DeformationTransfer transfer(std::move(arguments.source), std::move(arguments.target), std::move(arguments.markers), arguments.options);
    for (std::size_t p = 0; p < poses.size(); ++p) transfer.transfer(poses[p], results[p]);
  }
  py::list out;
  for (auto& result : results) out.append(owning_array(std::move(result)));
  return out;
}

py::tuple correspondence_binding(const py::tuple& source_rest, const py::tuple& target, const py::object& markers, int top_n,
                                 double mismatch_threshold, const std::string& backend, const std::string& precision) {
  auto arguments = transfer_arguments(source_rest, target, markers, "correspondence", top_n, mismatch_threshold, backend, precision);
  Eigen::VectorXi source_triangle;
  Eigen::VectorXd distance;
  std::vector<bool> mismatched;
  {
    const py::gil_scoped_release unlocked;
    const DeformationTransfer transfer(std::move(arguments.source), std::move(arguments.target), std::move(arguments.markers), arguments.options);
    const auto& match = transfer.match();
    source_triangle = Eigen::Map<const Eigen::VectorXi>(match.source.data(), static_cast<Eigen::Index>(match.source.size()));
    distance = Eigen::Map<const Eigen::VectorXd>(match.distance.data(), static_cast<Eigen::Index>(match.distance.size()));
    mismatched = transfer.mismatched();
  }
  py::array_t<bool> mismatch(static_cast<py::ssize_t>(mismatched.size()));
  for (std::size_t t = 0; t < mismatched.size(); ++t) mismatch.mutable_at(static_cast<py::ssize_t>(t)) = mismatched[t];
  return py::make_tuple(owning_array(std::move(source_triangle)), owning_array(std::move(distance)), mismatch);
}

py::dict render_binding(const py::object& positions, const py::object& triangles, const std::filesystem::path& path, const py::object& field,
                        const py::object& fixed, const py::object& handles, const std::string& size, const std::string& camera,
                        const std::string& up, bool wireframe, const std::string& device) {
#ifdef HDEFORM_WITH_ENGINE
  const Mesh mesh = mesh_argument(positions, triangles, "mesh");
  engine::Scene scene;
  scene.positions = mesh.positions;
  scene.triangles = mesh.triangles;
  if (!field.is_none()) {
    const py::array values = as_array(field, "field", "a float array of shape (n,)");
    if (values.ndim() != 1 || values.shape(0) != mesh.vertex_count() || values.dtype().kind() != 'f') {
      throw py::value_error("field must be a float array of shape (" + std::to_string(mesh.vertex_count()) + ",); got " + describe_array(values));
    }
    const auto view = values.cast<py::array_t<double, py::array::forcecast>>().unchecked<1>();
    scene.field.resize(mesh.vertex_count());
    for (Eigen::Index v = 0; v < mesh.vertex_count(); ++v) scene.field(v) = view(v);
  }
  if (!fixed.is_none() || !handles.is_none()) {
    EditConstraints constraints;
    if (!fixed.is_none()) constraints.fixed = indices_argument(fixed, "fixed");
    if (!handles.is_none()) {
      std::size_t h = 0;
      for (const auto handle : handles.cast<py::sequence>()) constraints.handles.push_back(indices_argument(handle, "handles[" + std::to_string(h++) + "]"));
    }
    const auto weights = cotangent_weights(mesh);
    scene.classes = cli::vertex_classes(partition_vertices(mesh, weights, constraints));
  }
  cli::PictureOptions options;
  options.size = size;
  options.camera = camera;
  options.up = up;
  options.wireframe = wireframe;
  options.device = device;
  scene.up = options.up_axis();
  nlohmann::json report;
  {
    const py::gil_scoped_release unlocked;
    report = cli::render_png(options, scene, path.string());
  }
  py::dict result;
  result["path"] = path.string();
  result["device"] = report.value("device", std::string());
  return result;
#else
  (void)positions, (void)triangles, (void)path, (void)field, (void)fixed, (void)handles, (void)size, (void)camera, (void)up, (void)wireframe,
      (void)device;
  throw std::runtime_error("render: this hdeform was built without the engine (HDEFORM_SOLVER_ONLY)");
#endif
}

}  // namespace
}  // namespace hdeform::python

PYBIND11_MODULE(_core, m) {
  using namespace hdeform;
  using namespace hdeform::python;
  m.doc() = "hdeform: detail-preserving deformation guided by harmonic fields (Zayer et al. 2005)";
  m.attr("has_render") = py::bool_(
#ifdef HDEFORM_WITH_ENGINE
      true
#else
      false
#endif
  );
  // Named as users import them: hdeform.InputError, hdeform.SolveError.
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError).attr("__module__") = "hdeform";
  py::register_exception<SolveError>(m, "SolveError", PyExc_RuntimeError).attr("__module__") = "hdeform";
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const cli::UsageError& usage) {
      PyErr_SetString(PyExc_ValueError, usage.what());
    }
  });

  py::class_<HandleTransform>(m, "Transform", "A handle's edit: an affine map, or a turn of any size about a line (a twist)")
      .def(py::init([](const py::object& matrix) { return transform_argument(matrix, "matrix"); }), py::arg("matrix"),
           R"doc(A handle's edit from a matrix.

matrix: a (3, 4) array [A | t] or a (4, 4) homogeneous one ending in 0 0 0 1, any float or
    integer dtype; A must be finite and non-singular, without a reflection (else InputError).
    The handle's vertices go to A p + t; the field spreads A's rotation and scale.)doc")
      .def_static("twist",
                  [](const std::array<double, 3>& axis, const std::array<double, 3>& point, double degrees, double scale,
                     const std::array<double, 3>& shift) {
                    return HandleTransform::about_pivot(Eigen::Vector3d(axis[0], axis[1], axis[2]), Eigen::Vector3d(point[0], point[1], point[2]),
                                                        degrees * M_PI / 180.0, scale, Eigen::Vector3d(shift[0], shift[1], shift[2]));
                  },
                  py::arg("axis"), py::arg("point"), py::arg("degrees"), py::arg("scale") = 1.0, py::arg("shift") = std::array<double, 3>{0, 0, 0},
                  R"doc(A turn of any size about a line, blended along the field (720 gives two full turns).

axis: 3 floats, the line's direction (not zero).  point: 3 floats, a point on the line.
degrees: the turn, any value.  scale: a uniform scale about point (> 0).  shift: 3 floats,
a translation applied after: p -> point + shift + scale R(axis, degrees) (p - point).)doc")
      .def_property_readonly("matrix", [](const HandleTransform& t) { return owning_array(Eigen::MatrixXd(t.affine())); })
      .def_property_readonly("degrees", [](const HandleTransform& t) { return t.angle * 180.0 / M_PI; })
      .def_property_readonly("scale", [](const HandleTransform& t) { return t.scale; })
      .def("__repr__", [](const HandleTransform& t) {
        return "<hdeform.Transform " + std::string(t.kind == HandleTransform::Kind::Pose ? "twist" : "affine") + ", " +
               std::to_string(t.angle * 180.0 / M_PI) + " degrees, scale " + std::to_string(t.scale) + ">";
      });

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

  m.def("read_mesh", &read_mesh_binding, py::arg("path"), "(V, F) from an OBJ, PLY, OFF or STL file (path: str or os.PathLike): V an (n, 3) float64 array, F an (m, 3) "
        "int32 array of 0-based indices. Raises hdeform.InputError naming the file and line");
  m.def(
      "triangulate",
      [](const py::object& positions, const py::object& sizes, const py::object& corners) {
        const Eigen::MatrixXd points = positions_argument(positions, "V");
        const Eigen::VectorXi polygon_sizes = integer_argument(sizes, "sizes", 0, "a 1-D integer array of corner counts");
        const Eigen::VectorXi polygon_corners = integer_argument(corners, "corners", 0, "a 1-D integer array of vertex indices");
        return owning_array(triangulate_polygons(points, polygon_sizes, polygon_corners));
      },
      py::arg("V"), py::arg("sizes"), py::arg("corners"),
      "Polygons (sizes[p] corners each, their vertex indices one after another in corners) as an (m, 3) int32 array of "
      "triangles, by the readers' rule: a quad along its shorter diagonal, a larger polygon as a fan from its first corner");
  m.def("write_mesh", &write_mesh_binding, py::arg("path"), py::arg("V"), py::arg("F"), "Writes V ((n, 3) floats) and F ((m, 3) integers) to path, .obj or .ply by its extension, atomically "
        "(a temporary file renamed when complete)");
  m.def("shape", &shape_binding, py::arg("name"), py::arg("resolution") = kDefaultShapeResolution,
        "A built-in shape ('cactus', 'bar', 'cylinder', 'sphere'; resolution: segments around, at least 8) and its "
        "demo edit, a dict: 'V' (n, 3) float64, 'F' (m, 3) int32, 'fixed' (k,) int32, 'handles' a list of int32 arrays, "
        "'transform' a Transform");
  m.def("subdivide", &subdivide_binding, py::arg("V"), py::arg("F"), py::arg("levels") = 1, py::arg("sets") = py::list(),
        "Every triangle split into four at its edges' midpoints, levels times (0 to 4): (V, F, sets). The original "
        "vertices keep their positions and indices, the new ones follow; triangle t becomes 4t .. 4t+3. sets: a list of "
        "1-D integer arrays (fixed vertices, handles) carried over, a new vertex belonging to a set where both ends of "
        "its edge do; returned as int32 arrays. What hdeform bench --subdivide does");
  m.def("add_relief", &add_relief_binding, py::arg("V"), py::arg("F"), py::arg("amplitude"),
        "V with every vertex moved along its normal by amplitude times the bounding box's diagonal times a fixed pattern "
        "of three frequencies (at most 1.75 in size): detail for measuring at scale, as hdeform bench --relief. An "
        "(n, 3) float64 array; amplitude 0 returns V unchanged; a negative or non-finite amplitude raises hdeform.InputError");
  m.def("_cotangent_laplacian_csc", &laplacian_binding, py::arg("V"), py::arg("F"));
  m.def("harmonic_field", &harmonic_field_binding, py::arg("V"), py::arg("F"), py::arg("sources"), py::arg("sinks"),
        py::arg("backend") = std::string(to_string(default_backend())), py::arg("precision") = "double",
        "The harmonic field, an (n,) float64 array: 1 at the sources, 0 at the sinks (1-D integer arrays or lists), "
        "harmonic elsewhere (V (n, 3) floats, F (m, 3) integers)");
  m.def("transfer", &transfer_binding, py::arg("source_rest"), py::arg("source_poses"), py::arg("target"), py::arg("markers"),
        py::arg("method") = "correspondence", py::arg("top_n") = 0, py::arg("mismatch_threshold") = kDefaultMismatchThreshold,
        py::arg("backend") = std::string(to_string(default_backend())), py::arg("precision") = "double",
        "The source's poses on the target (paper sections 6 and 7). source_rest and target: (V, F) tuples; "
        "source_poses: a list of (n_s, 3) float arrays (the source's vertices in each pose); markers: (k, 2) integer "
        "array or list of (source vertex, target vertex) pairs, k >= 3; method: 'correspondence' or 'interpolation'. "
        "Returns a list of (n_t, 3) float64 arrays, one per pose");
  m.def("correspondence", &correspondence_binding, py::arg("source_rest"), py::arg("target"), py::arg("markers"), py::arg("top_n") = 0,
        py::arg("mismatch_threshold") = kDefaultMismatchThreshold, py::arg("backend") = std::string(to_string(default_backend())),
        py::arg("precision") = "double", "The triangle correspondence of paper section 6: a tuple of three arrays over the target's triangles: the "
        "matched source triangle (int32), the distance in harmonic coordinates (float64) and whether it is a mismatch "
        "(bool). Arguments as for transfer()");
  m.def("render", &render_binding, py::arg("V"), py::arg("F"), py::arg("path"), py::arg("field") = py::none(), py::arg("fixed") = py::none(),
        py::arg("handles") = py::none(), py::arg("size") = "1024x768", py::arg("camera") = "", py::arg("up") = "z",
        py::arg("wireframe") = false, py::arg("device") = "", "Writes a PNG of the mesh to path: V (n, 3) floats, F (m, 3) integers; field: None or (n,) floats drawn as "
        "colours; fixed: None or 1-D integers; handles: None or a list of 1-D integer arrays; size 'WxH'; camera "
        "'YAW,PITCH[,ZOOM]' in degrees; up 'z' or 'y'. Only when hdeform.has_render");
}
