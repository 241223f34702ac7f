#pragma once
// The Python module's arguments: numpy arrays and Python objects checked and converted to the
// solver's types, with ValueError messages that name the argument, its expected shape and what
// came; and the solver's matrices handed back to numpy without a copy.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "hdeform/dirichlet_system.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"
#include "hdeform/refinement.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform::python {

namespace py = pybind11;

// "float64 of shape (2, 3)": what came, for messages.
std::string describe_array(const py::array& array);
// numpy.asarray(object), or a ValueError saying that `name` must be `expected`.
py::array as_array(const py::handle& object, const std::string& name, const std::string& expected);
// n×3 floating point (float64, or float32 widened).
Eigen::MatrixXd positions_argument(const py::handle& object, const std::string& name);
// Integers that fit an int, of shape (rows, columns) or, with columns = 0, 1-D.
Eigen::MatrixXi integer_argument(const py::handle& object, const std::string& name, py::ssize_t columns, const std::string& expected);
Eigen::MatrixXi triangles_argument(const py::handle& object, const std::string& name);
std::vector<int> indices_argument(const py::handle& object, const std::string& name);
// Positions and triangles, validated as a mesh (InputError naming `name`).
Mesh mesh_argument(const py::handle& positions, const py::handle& triangles, const std::string& name);
SolverBackend backend_argument(const std::string& name);
FactorPrecision precision_argument(const std::string& name);
// A 3×4 or 4×4 matrix (its last row 0 0 0 1), or a Transform.
HandleTransform transform_argument(const py::handle& object, const std::string& name);
// One transform, or a list of one per handle.
std::vector<HandleTransform> transforms_argument(const py::handle& object, std::size_t handles);
// "auto" (until converged), or a number of iterations (0: the paper's method alone).
int refine_argument(const py::object& refine, const RefinementOptions& options);

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

py::array index_array(const std::vector<int>& indices);

// The Deformer class, as hdeform.Deformer (deformer_binding.cpp).
void bind_deformer(py::module_& m);

}  // namespace hdeform::python
