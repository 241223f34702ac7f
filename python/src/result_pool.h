#pragma once
// ResultPool: the memory of position arrays handed to Python, taken back when Python frees them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <memory>
#include <mutex>

namespace hdeform::python {

namespace py = pybind11;

// The position arrays deform() and refine() hand to Python come from here, and come back once Python
// lets go of them. Memory new to the process costs a page fault per page at its first write, and
// a dear one on a virtual machine: the 3.3M Buddha's 39 MB of positions took about 100 ms to fill
// anew on this project's machines, where filling a reused array takes under 10. A caller that
// drops each result before asking for the next (the Blender add-on writes it to a shape key) gets
// the same memory back each time; one that keeps them gets new arrays, never one it still holds.
class ResultPool {
 public:
  std::unique_ptr<Eigen::MatrixXd> take(Eigen::Index rows, Eigen::Index cols) {
    std::lock_guard lock(mutex_);
    if (spare_ && spare_->rows() == rows && spare_->cols() == cols) return std::move(spare_);
    return std::make_unique<Eigen::MatrixXd>(rows, cols);
  }
  // A Fortran-ordered float64 array over `matrix`; when Python frees it, the matrix comes back to
  // `pool` (kept as the spare) if the pool is still there.
  static py::array hand_over(std::unique_ptr<Eigen::MatrixXd> matrix, const std::shared_ptr<ResultPool>& pool) {
    struct Lent {
      std::unique_ptr<Eigen::MatrixXd> matrix;
      std::weak_ptr<ResultPool> pool;
    };
    auto* lent = new Lent{std::move(matrix), pool};
    const py::capsule release(lent, [](void* pointer) {
      std::unique_ptr<Lent> back(static_cast<Lent*>(pointer));
      if (const auto owner = back->pool.lock()) {
        std::lock_guard lock(owner->mutex_);
        owner->spare_ = std::move(back->matrix);
      }
    });
    const Eigen::MatrixXd& data = *lent->matrix;
    const auto rows = static_cast<py::ssize_t>(data.rows()), cols = static_cast<py::ssize_t>(data.cols());
    return py::array_t<double>({rows, cols}, {static_cast<py::ssize_t>(sizeof(double)), static_cast<py::ssize_t>(sizeof(double)) * rows}, data.data(),
                               release);
  }

 private:
  std::mutex mutex_;
  std::unique_ptr<Eigen::MatrixXd> spare_;
};

}  // namespace hdeform::python
