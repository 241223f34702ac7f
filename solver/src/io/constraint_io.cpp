#include "hdeform/constraint_io.h"

#include <array>
#include <charconv>
#include <numbers>
#include <string>
#include <unordered_map>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "text_scan.h"

namespace hdeform {

using detail::fail_at;
using detail::quoted;

std::vector<int> read_vertex_indices(const std::filesystem::path& path, Eigen::Index vertex_count) {
  const std::string content = detail::read_text_file(path);
  detail::reject_binary(path, content);
  std::vector<int> indices;
  std::unordered_map<int, std::size_t> first_line;
  std::vector<std::string_view> tokens;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    for (const auto token : tokens) {
      const auto value = detail::parse_integer(token);
      if (!value) fail_at(path, line, quoted(token) + " is not a vertex index");
      if (*value < 0) fail_at(path, line, "negative vertex index " + std::to_string(*value));
      if (*value >= vertex_count) {
        fail_at(path, line, "vertex " + std::to_string(*value) + " out of range (the mesh has " + std::to_string(vertex_count) + " vertices)");
      }
      const int vertex = static_cast<int>(*value);
      const auto [it, inserted] = first_line.try_emplace(vertex, line);
      if (!inserted) fail_at(path, line, "vertex " + std::to_string(vertex) + " listed twice (first on line " + std::to_string(it->second) + ")");
      indices.push_back(vertex);
    }
  });
  return indices;
}

VertexLabels read_vertex_labels(const std::filesystem::path& path, Eigen::Index vertex_count) {
  const std::string content = detail::read_text_file(path);
  detail::reject_binary(path, content);
  VertexLabels labels;
  std::size_t count = 0;
  std::size_t last_line = 0;
  std::vector<std::string_view> tokens;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    for (const auto token : tokens) {
      if (static_cast<Eigen::Index>(count) == vertex_count) {
        fail_at(path, line, "more labels than the mesh's " + std::to_string(vertex_count) + " vertices");
      }
      const auto value = detail::parse_integer(token);
      if (!value || *value < 0 || *value > 2) fail_at(path, line, "label " + quoted(token) + " (0 fixed, 1 deformable, 2 handle)");
      const int vertex = static_cast<int>(count++);
      (*value == 0 ? labels.fixed : *value == 1 ? labels.deformable : labels.handle).push_back(vertex);
      last_line = line;
    }
  });
  if (count == 0) throw InputError(path.string() + ": no labels (one per vertex: 0 fixed, 1 deformable, 2 handle)");
  if (static_cast<Eigen::Index>(count) < vertex_count) {
    fail_at(path, last_line, "the labels end after " + std::to_string(count) + " of the mesh's " + std::to_string(vertex_count) + " vertices");
  }
  if (labels.handle.empty()) throw InputError(path.string() + ": no vertex is labelled 2 (the handle)");
  if (labels.fixed.empty()) throw InputError(path.string() + ": no vertex is labelled 0 (fixed): the handle's field needs sinks");
  return labels;
}

HandleTransform read_handle_transform(const std::filesystem::path& path) {
  const std::string content = detail::read_text_file(path);
  detail::reject_binary(path, content);
  std::vector<double> numbers;
  std::vector<std::size_t> number_lines;
  bool twist = false;
  std::vector<std::string_view> tokens;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    for (const auto token : tokens) {
      if (token == "twist" && numbers.empty() && !twist) {
        twist = true;
        continue;
      }
      const auto value = detail::parse_double(token);
      if (!value) fail_at(path, line, quoted(token) + " is not a number");
      if (!std::isfinite(*value)) fail_at(path, line, "non-finite value " + quoted(token));
      numbers.push_back(*value);
      number_lines.push_back(line);
    }
  });
  // A count problem is reported where the numbers run out or where the first extra one stands.
  const auto count_problem = [&](std::size_t expected, const std::string& what) {
    if (numbers.empty()) throw InputError(path.string() + ": no numbers; expected " + what);
    if (numbers.size() < expected) fail_at(path, number_lines.back(), "the numbers end after " + std::to_string(numbers.size()) + "; expected " + what);
    fail_at(path, number_lines[expected], "more than " + std::to_string(expected) + " numbers; expected " + what);
  };
  try {
    if (twist) {
      if (numbers.size() != 7 && numbers.size() != 8) count_problem(numbers.size() < 7 ? 7 : 8, "AX AY AZ PX PY PZ DEGREES [SCALE] after 'twist'");
      const Eigen::Vector3d axis(numbers[0], numbers[1], numbers[2]);
      const Eigen::Vector3d point(numbers[3], numbers[4], numbers[5]);
      return HandleTransform::about_pivot(axis, point, numbers[6] * std::numbers::pi / 180.0, numbers.size() == 8 ? numbers[7] : 1.0);
    }
    if (numbers.size() == 16) {
      if (numbers[12] != 0.0 || numbers[13] != 0.0 || numbers[14] != 0.0 || numbers[15] != 1.0) {
        fail_at(path, number_lines[12], "a 4×4 transform must end with the row 0 0 0 1 (it is not affine)");
      }
      numbers.resize(12);
    }
    if (numbers.size() != 12) count_problem(12, "12 (the 3×4 matrix [A | t], row-major)");
    Eigen::Matrix<double, 3, 4> affine;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) affine(r, c) = numbers[static_cast<std::size_t>(4 * r + c)];
    }
    return HandleTransform::from_affine(affine);
  } catch (const InputError& error) {
    if (std::string(error.what()).starts_with(path.string())) throw;
    // A property of the whole matrix: name the lines that hold it.
    const std::string lines = number_lines.front() == number_lines.back() ? std::to_string(number_lines.front())
                                                                          : std::to_string(number_lines.front()) + "-" + std::to_string(number_lines.back());
    throw InputError(path.string() + ":" + lines + ": " + error.what());
  }
}

Eigen::VectorXd read_values(const std::filesystem::path& path, Eigen::Index vertex_count) {
  const std::string content = detail::read_text_file(path);
  detail::reject_binary(path, content);
  std::vector<double> values;
  std::vector<std::string_view> tokens;
  std::size_t last_line = 0;
  detail::for_each_line(content, [&](std::size_t line, std::string_view text) {
    detail::split_tokens(text, tokens);
    for (const auto token : tokens) {
      const auto value = detail::parse_double(token);
      if (!value) fail_at(path, line, quoted(token) + " is not a number");
      if (!std::isfinite(*value)) fail_at(path, line, "non-finite value " + quoted(token));
      if (static_cast<Eigen::Index>(values.size()) == vertex_count) {
        fail_at(path, line, "more values than the mesh's " + std::to_string(vertex_count) + " vertices");
      }
      values.push_back(*value);
      last_line = line;
    }
  });
  if (values.empty()) throw InputError(path.string() + ": no values (one per vertex: " + std::to_string(vertex_count) + ")");
  if (static_cast<Eigen::Index>(values.size()) != vertex_count) {
    fail_at(path, last_line, "the values end after " + std::to_string(values.size()) + "; the mesh has " + std::to_string(vertex_count) + " vertices");
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), vertex_count);
}

void write_values(const std::filesystem::path& path, const Eigen::VectorXd& values) {
  std::string text;
  text.reserve(static_cast<std::size_t>(values.size()) * 24);
  std::array<char, 32> buffer;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), values(i));
    text.append(buffer.data(), result.ptr);
    text += '\n';
  }
  write_file_atomically(path, [&](std::ostream& out) { out.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

}  // namespace hdeform
