#pragma once
/// @file
/// The Laplacian with Dirichlet constraints (design.md): the vertices of a partition that are not
/// free have known values and the free ones solve
///   L_ff X_f = S_f − L_fc X_c.
/// L_ff is factored once per mesh and partition; every right-hand side after that (harmonic
/// fields, quaternion components, coordinates) costs back-substitution only.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <span>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform {

/// L_ff X_f = S_f − L_fc X_c for one partition: L_ff factored once, its solves and the coupling
/// to the constrained vertices, for every right-hand side of an edit.
class DirichletSystem {
 public:
  /// One L_fc entry: the constrained vertex a free row couples to, and the weight.
  struct Coupling {
    int vertex;     ///< a constrained vertex
    double weight;  ///< L_fc entry
  };

  /// Throws SolveError when the factorization fails. `vertex_rank` is an elimination order of the
  /// whole Laplacian (elimination_ranks; computed here when not given); the free vertices are
  /// eliminated in the order it induces. `reuse`: an earlier system's factor().analysis(), taken when L_ff has the
  /// pattern it was made for (see SparseCholesky::factor). `precision`: how L is stored for the
  /// solves (SparseCholesky::factor).
  DirichletSystem(const Eigen::SparseMatrix<double>& laplacian, const VertexPartition& partition, SolverBackend backend,
                  std::span<const int> vertex_rank = {}, const std::shared_ptr<const SparseCholesky::Analysis>& reuse = nullptr,
                  FactorPrecision precision = FactorPrecision::Double);

  /// The factorization of L_ff.
  const SparseCholesky& factor() const { return factor_; }
  /// Time spent analysing and factoring L_ff, milliseconds.
  double factor_ms() const { return factor_ms_; }
  /// The number of free vertices (rows of L_ff).
  Eigen::Index free_count() const { return static_cast<Eigen::Index>(vertex_of_row_.size()); }
  /// The number of vertices of the mesh.
  Eigen::Index vertex_count() const { return static_cast<Eigen::Index>(row_of_vertex_.size()); }

  /// Factor-order row of a free vertex, −1 for a constrained one; and the inverse map.
  const std::vector<int>& row_of_vertex() const { return row_of_vertex_; }
  /// The free vertex of each factor-order row.
  const std::vector<int>& vertex_of_row() const { return vertex_of_row_; }

  /// The L_fc entries of one factor-order row.
  std::span<const Coupling> coupling(int row) const {
    const auto begin = coupling_start_[static_cast<std::size_t>(row)];
    const auto end = coupling_start_[static_cast<std::size_t>(row) + 1];
    return {coupling_.data() + begin, coupling_.data() + end};
  }

  /// Convenience (allocates): `values` is n×k; its constrained rows hold the Dirichlet data and
  /// its free rows receive the solution. `source`, if given, is n×k and supplies S_f.
  void solve(Eigen::MatrixXd& values, const Eigen::MatrixXd* source = nullptr) const;

 private:
  SparseCholesky factor_;
  double factor_ms_ = 0.0;
  std::vector<int> row_of_vertex_;
  std::vector<int> vertex_of_row_;
  std::vector<std::size_t> coupling_start_;
  std::vector<Coupling> coupling_;
};

}  // namespace hdeform
