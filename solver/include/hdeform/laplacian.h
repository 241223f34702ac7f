#pragma once
/// @file
/// Cotangent Laplacian, positive semidefinite convention (design.md):
///   L_ij = −½(cot α_ij + cot β_ij) for an edge ij,   L_ii = −Σ_j L_ij,
/// equivalently L_ij = Σ_t A_t ∇φ_i·∇φ_j. Rows sum to zero; L is symmetric.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

#include "hdeform/mesh.h"

namespace hdeform {

/// How a triangle enters the operator.
enum class ElementKind : std::uint8_t {
  Regular,     ///< exact cotangent weights
  Degenerate,  ///< zero-area or needle: weights scaled down (see below); does not connect components
  Ignored,     ///< a repeated vertex index, all corners coincident, or a duplicate of an earlier triangle
};

/// Largest cotangent magnitude a triangle keeps (an angle of about 0.006°). A triangle whose
/// cotangents exceed it has all three scaled by one common factor: the element stays symmetric,
/// positive semidefinite, with zero row sums, and finite even at zero area (the scaled weights
/// are the limits dot_k / max|dot|). Clamping angles one by one would make needles indefinite.
inline constexpr double kMaxCotangent = 1e4;

/// The cotangent weight of every edge of every triangle, with the elements that had to be bounded
/// or left out counted.
struct CotangentWeights {
  /// half_cotangent(t, k) = ½ cot of the angle at corner k: the weight of the edge opposite k.
  Eigen::MatrixXd half_cotangent;
  std::vector<ElementKind> kind;

  /// How many triangles were of that kind.
  std::size_t count(ElementKind which) const;
};

/// The weights of a mesh (validate_mesh first; throws InputError for a bad mesh).
CotangentWeights cotangent_weights(const Mesh& mesh);

/// n×n sparse Laplacian assembled from per-triangle weights (Ignored triangles contribute nothing).
Eigen::SparseMatrix<double> cotangent_laplacian(const Mesh& mesh, const CotangentWeights& weights);
/// The cotangent Laplacian of a mesh, both triangles stored (positive semidefinite).
Eigen::SparseMatrix<double> cotangent_laplacian(const Mesh& mesh);

}  // namespace hdeform
