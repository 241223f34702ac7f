#include "hdeform/marker_io.h"

#include <string>
#include <unordered_map>

#include "hdeform/atomic_file.h"
#include "hdeform/counted.h"
#include "hdeform/errors.h"
#include "text_scan.h"

namespace hdeform {

using detail::fail_at;
using detail::quoted;

MarkerPairs read_marker_pairs(const std::filesystem::path& path, SourceColumn source_column, Eigen::Index source_vertex_count,
                              Eigen::Index target_vertex_count) {
  const std::string content = detail::read_text_file(path);
  detail::reject_binary(path, content);
  const bool source_first = source_column == SourceColumn::First;
  const char* column_names[2] = {source_first ? "source" : "target", source_first ? "target" : "source"};
  const Eigen::Index counts[2] = {source_first ? source_vertex_count : target_vertex_count,
                                  source_first ? target_vertex_count : source_vertex_count};
  MarkerPairs markers;
  std::unordered_map<int, std::size_t> first_line[2];
  std::vector<std::string_view> tokens;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    if (tokens.empty()) return;
    if (tokens.size() != 2) {
      fail_at(path, line, "expected two vertex indices (" + std::string(column_names[0]) + " " + column_names[1] + "), found " +
                              counted(tokens.size(), "value", "values"));
    }
    int pair[2] = {0, 0};
    for (int column = 0; column < 2; ++column) {
      const auto token = tokens[static_cast<std::size_t>(column)];
      const auto value = detail::parse_integer(token);
      const std::string which = std::string(column_names[column]) + " vertex";
      if (!value) fail_at(path, line, quoted(token) + " is not a vertex index");
      if (*value < 0) fail_at(path, line, "negative " + which + " " + std::to_string(*value));
      if (*value >= counts[column]) {
        fail_at(path, line, which + " " + std::to_string(*value) + " out of range (that mesh has " + std::to_string(counts[column]) + " vertices)");
      }
      pair[column] = static_cast<int>(*value);
      const auto [it, inserted] = first_line[column].try_emplace(pair[column], line);
      if (!inserted) {
        fail_at(path, line, "duplicate marker: " + which + " " + std::to_string(pair[column]) + " is already paired on line " + std::to_string(it->second));
      }
    }
    markers.source.push_back(pair[source_first ? 0 : 1]);
    markers.target.push_back(pair[source_first ? 1 : 0]);
  });
  if (markers.size() < kMinimumMarkers) {
    throw InputError(path.string() + ": " + std::to_string(markers.size()) + " marker pair(s); deformation transfer needs at least " +
                     std::to_string(kMinimumMarkers));
  }
  return markers;
}

void write_marker_pairs(const std::filesystem::path& path, const MarkerPairs& markers, SourceColumn source_column) {
  const bool source_first = source_column == SourceColumn::First;
  write_file_atomically(path, [&](std::ostream& out) {
    out << (source_first ? "# source target" : "# target source") << " (0-based vertex indices)\n";
    for (std::size_t k = 0; k < markers.size(); ++k) {
      out << (source_first ? markers.source[k] : markers.target[k]) << ' ' << (source_first ? markers.target[k] : markers.source[k]) << '\n';
    }
  });
}

}  // namespace hdeform
