#include "arguments.h"

#include <limits>

#include "hdeform/counted.h"
#include "hdeform/errors.h"
#include "commands/cli_support.h"

namespace hdeform::python {
namespace {

std::string type_name(const py::handle& object) { return py::str(py::type::of(object).attr("__name__")).cast<std::string>(); }

}  // namespace

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

}  // namespace hdeform::python
