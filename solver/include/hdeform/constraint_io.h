#pragma once
/// @file
/// The small text files of an edit. Errors name the file, the line and the problem.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "hdeform/handle_transform.h"

namespace hdeform {

/// 0-based vertex indices separated by white space; '#' starts a comment. Rejects non-integers,
/// negative or out-of-range indices and repeated vertices. An empty list is returned as such.
std::vector<int> read_vertex_indices(const std::filesystem::path& path, Eigen::Index vertex_count);

/// A Botsch–Sorkine selection file (NAME.sel, as CGAL's deformation demo reads it): one label per
/// vertex in mesh order, 0 fixed, 1 deformable, 2 handle; '#' starts a comment. Rejects other
/// labels and a count that is not the mesh's vertex count, and a file without fixed or handle
/// vertices. Its companion NAME.def is a 4×4 transform: read_handle_transform reads it.
struct VertexLabels {
  std::vector<int> fixed;       ///< label 0
  std::vector<int> deformable;  ///< label 1
  std::vector<int> handle;      ///< label 2
};
/// Per-vertex Botsch–Sorkine labels (0 fixed, 1 deformable, 2 handle) from a .sel file of `vertex_count` lines.
VertexLabels read_vertex_labels(const std::filesystem::path& path, Eigen::Index vertex_count);

/// A handle transform, one of
///   12 numbers: the 3×4 matrix [A | t], row-major (a 4×4 homogeneous matrix with last row
///               0 0 0 1 is accepted too);
///   twist AX AY AZ PX PY PZ DEGREES [SCALE]: a turn of any size (720 for two turns) about the
///               line through P along A, blended by angle rather than by slerp.
/// Rejects other counts, non-numbers, non-finite values, singular maps and reflections.
HandleTransform read_handle_transform(const std::filesystem::path& path);

/// One value per line, shortest round-trip decimal form, written atomically.
void write_values(const std::filesystem::path& path, const Eigen::VectorXd& values);

/// The inverse: one finite number per vertex (white space separated, '#' comments).
Eigen::VectorXd read_values(const std::filesystem::path& path, Eigen::Index vertex_count);

}  // namespace hdeform
