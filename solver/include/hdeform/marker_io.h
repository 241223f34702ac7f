#pragma once
/// @file
/// Marker pairs for deformation transfer (paper §6, §7): one pair per line, two 0-based vertex
/// indices — a vertex of one mesh and the corresponding vertex of the other; '#' starts a comment.
/// Which column is the source is the caller's choice: the shared cat↔lion file lists the cat
/// first, while the paper transfers lion → cat.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

namespace hdeform {

/// Marker pairs: source[i] on one mesh corresponds to target[i] on the other.
struct MarkerPairs {
  std::vector<int> source;  ///< vertex on the source (reference) mesh, per marker
  std::vector<int> target;  ///< the corresponding vertex on the target mesh

  /// The number of pairs.
  std::size_t size() const { return source.size(); }
};

/// Fewer markers than this cannot define harmonic coordinates worth matching (and §6's top-n
/// needs 3 ≤ n ≤ k).
inline constexpr std::size_t kMinimumMarkers = 3;

/// Which column of a marker file holds the source's vertices.
enum class SourceColumn { First, Second };

/// Throws InputError naming the file and line for: a line without exactly two indices, a
/// non-integer, a negative or out-of-range index (against each mesh's vertex count), a vertex
/// used by two markers on either mesh, and fewer than kMinimumMarkers pairs.
MarkerPairs read_marker_pairs(const std::filesystem::path& path, SourceColumn source_column, Eigen::Index source_vertex_count,
                              Eigen::Index target_vertex_count);

/// Writes one pair per line, atomically, the source in `source_column` (so that a file read with
/// a column choice is written back the same way).
void write_marker_pairs(const std::filesystem::path& path, const MarkerPairs& markers, SourceColumn source_column = SourceColumn::First);

}  // namespace hdeform
