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
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/errors.h"
#include "hdeform/handle_transform.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "hdeform/subdivision.h"
#include "hdeform/transfer.h"
#include "arguments.h"
#include "commands/cli_support.h"
#ifdef HDEFORM_WITH_ENGINE
#include "commands/render_support.h"
#endif

namespace py = pybind11;

namespace hdeform::python {
namespace {

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

  bind_deformer(m);

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
