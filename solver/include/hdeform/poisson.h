#pragma once
/// @file
/// Poisson reconstruction (paper §5, design.md). Each triangle is deformed by its own map T_t;
/// the divergence of the deformed gradients at vertex i is
///   b_i = Σ_{t∋i} A_t (T_t J_t) ∇φ_i = Σ_{t∋i} T_t g_{t,i},   g_{t,i} = Σ_{j∈t} w_ij (p_i − p_j),
/// with w_ij the triangle's cotangent weight of edge ij. The g are fixed by the rest shape, so an
/// update costs one 3×3 product per triangle corner. With every T_t = I, b = L p exactly, so
/// nothing moved reproduces the input. The solve is L_ff x_f = b_f − L_fc x_c.
#include <Eigen/Core>
#include <span>
#include <vector>

#include "hdeform/deformation_field.h"
#include "hdeform/dirichlet_system.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform {

/// Builds the Poisson right-hand side of per-triangle maps for one partition, in parallel, in a
/// fixed order per row (the same bits on any number of threads). Made once per selection.
class PoissonAssembler {
 public:
  // Keeps a reference to `system`, which must outlive the assembler.
  /// Precomputes the rest gradients and the rows' gather lists for `system`'s free vertices.
  PoissonAssembler(const Mesh& rest, const CotangentWeights& weights, const DirichletSystem& system);

  /// Writes b_f − L_fc x_c into columns first_column .. first_column+2 of `rhs` (factor order).
  /// `maps` has one entry per triangle; the constrained rows of `positions` (n×3) hold their
  /// targets. Parallel over rows, each row summed in a fixed order: the same bits for any
  /// number of threads. Allocation-free.
  void assemble(std::span<const Eigen::Matrix3d> maps, const Eigen::MatrixXd& positions, ColumnBlocks& rhs,
                int first_column = 0) const;
  /// The same for maps about one axis (one handle): Σ T_t g = Σα g + a × Σβ g + a (a · Σγ g).
  void assemble(const AxialMaps& maps, const Eigen::MatrixXd& positions, ColumnBlocks& rhs, int first_column = 0) const;

 private:
  template <class CornerSum>
  void assemble_rows(const Eigen::MatrixXd& positions, ColumnBlocks& rhs, int first_column, CornerSum corner_sum) const;

  /// A corner's triangle. User-provided constructor: resizing leaves the corners to the threads
  /// that fill them (a zero fill would fault their pages in on one thread first).
  struct CornerTriangle {
    CornerTriangle() {}  ///< NOLINT(modernize-use-equals-default)
    int index;
  };
  const DirichletSystem& system_;
  std::vector<std::size_t> corner_start_;  ///< per factor-order row
  /// Each row's corners: their triangles, and their rest gradients g_{t,i} (Eigen leaves those
  /// uninitialised too). Two arrays rather than one of pairs: 28 bytes a corner instead of 32, the
  /// right-hand side streaming them.
  std::vector<CornerTriangle> corner_triangle_;
  std::vector<Eigen::Vector3d> corner_gradient_;
};

/// One-off reconstruction (allocates): the constrained rows of `positions` hold their targets, the
/// free rows receive the solution.
void poisson_reconstruct(const PoissonAssembler& assembler, const DirichletSystem& system,
                         std::span<const Eigen::Matrix3d> maps, Eigen::MatrixXd& positions);

}  // namespace hdeform
