#pragma once
// What the refinement's stages (arap_refinement.cpp, arap_local_step.cpp) share, private to them:
// how work is cut into chunks, the rows' layout, and the rotation fits' settings.
#include <tbb/parallel_for.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <vector>

#include "hdeform/sparse_cholesky.h"

namespace hdeform::detail {

// Work is cut into chunks of this many items, the same for any number of threads; a sum is the
// sum of its chunks' partial sums in chunk order.
constexpr std::size_t kChunk = 2048;
inline std::size_t chunk_count(std::size_t items) { return (items + kChunk - 1) / kChunk; }

template <class Body>
void for_each_chunk(std::size_t items, Body body) {
  tbb::parallel_for(std::size_t{0}, chunk_count(items), [&](std::size_t chunk) {
    body(chunk, chunk * kChunk, std::min(items, (chunk + 1) * kChunk));
  });
}

// Rotation fits: Newton steps from the last fit, which moves little. For the paper's result, whose
// energy is reported and decides where an edit starts: up to eight from the field's rotations.
// Within an iteration one: each step raises the fit, so the energy still falls, and the rotations
// converge with the positions (one step or two per iteration take as many iterations to converge:
// buddha-206k, cylinder).
constexpr double kRotationTolerance = 1e-7;
constexpr int kPaperFitSteps = 8;
constexpr int kIterationSteps = 1;

// The per-vertex arrays (positions, right-hand sides, the acceleration's differences) keep x, y, z
// and a zero pad per row: the layout in which the solve sums a row's three values as one vector.
constexpr std::size_t kStride = SparseCholesky::fast_solve_stride(3);

inline Eigen::Vector3d row3(const std::vector<double>& values, std::size_t row) {
  return {values[kStride * row], values[kStride * row + 1], values[kStride * row + 2]};
}

static_assert(kStride == 4, "the gathers load a row of positions as four lanes");

// The two gathers (the covariances', the right-hand sides') read, for each pair, its neighbour's
// row (a position, a rotation), scattered over the mesh, and waited for it: they ask for it this
// many pairs early (the right-hand side's stage 1.14-1.16 -> 0.85-0.90 ms at 48 on the Buddha;
// 0.90-0.97 at 32, 0.81-0.99 at 64). The pair list carries this many padding entries so the
// look-ahead stays inside it.
constexpr std::size_t kPairsAhead = 48;

}  // namespace hdeform::detail
