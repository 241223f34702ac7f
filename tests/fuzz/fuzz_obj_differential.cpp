// The OBJ reader against an independent reference on the same bytes: either both refuse, or
// both build the same vertex and triangle arrays, bit for bit. The reference below is written
// for clarity, not speed, and shares no code with the reader: it normalises line ends first,
// splits with a string stream, checks number syntax with a hand-written grammar and converts with
// strtod/strtoll. Its rules are the ones README.md states for OBJ files. The reader's parallel
// path (the text cut into pieces, parsed apart and joined) must agree with its one-pass path too:
// the same arrays, or a refusal with the same message.
#include <bit>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz_input.h"
#include "hdeform/mesh_io.h"
#include "io/obj_pieces.h"

namespace {

struct ReferenceMesh {
  std::vector<double> coordinates;  // x y z per vertex
  std::vector<int> triangles;       // 3 per triangle
};

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size()) text.replace(at, from.size(), to);
  return text;
}

bool all_digits(const std::string& text, std::size_t begin, std::size_t end) {
  if (begin >= end) return false;
  for (std::size_t i = begin; i < end; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return false;
  }
  return true;
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// [+-] then digits[.digits] | .digits, optional exponent; or inf, infinity, nan, nan(...).
std::optional<double> number(const std::string& token) {
  std::size_t i = 0;
  if (i < token.size() && (token[i] == '+' || token[i] == '-')) ++i;
  const std::string rest = lower(token.substr(i));
  bool special = rest == "inf" || rest == "infinity" || rest == "nan";
  if (!special && rest.size() >= 5 && rest.compare(0, 4, "nan(") == 0 && rest.back() == ')') {
    special = true;
    for (std::size_t k = 4; k + 1 < rest.size(); ++k) {
      if (!std::isalnum(static_cast<unsigned char>(rest[k])) && rest[k] != '_') special = false;
    }
  }
  if (!special) {
    std::size_t digits_end = i;
    while (digits_end < token.size() && std::isdigit(static_cast<unsigned char>(token[digits_end]))) ++digits_end;
    bool any_digits = digits_end > i;
    std::size_t at = digits_end;
    if (at < token.size() && token[at] == '.') {
      ++at;
      const std::size_t fraction = at;
      while (at < token.size() && std::isdigit(static_cast<unsigned char>(token[at]))) ++at;
      any_digits = any_digits || at > fraction;
    }
    if (!any_digits) return std::nullopt;
    if (at < token.size() && (token[at] == 'e' || token[at] == 'E')) {
      ++at;
      if (at < token.size() && (token[at] == '+' || token[at] == '-')) ++at;
      if (!all_digits(token, at, token.size())) return std::nullopt;
      at = token.size();
    }
    if (at != token.size()) return std::nullopt;
  }
  return std::strtod(token.c_str(), nullptr);
}

std::optional<long long> integer(const std::string& token) {
  const std::size_t sign = !token.empty() && (token[0] == '+' || token[0] == '-') ? 1 : 0;
  if (!all_digits(token, sign, token.size())) return std::nullopt;
  errno = 0;
  const long long value = std::strtoll(token.c_str(), nullptr, 10);
  if (errno == ERANGE) return std::nullopt;
  return value;
}

std::optional<ReferenceMesh> reference_read(std::string text) {
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 && c != '\t' && c != '\n' && c != '\v' && c != '\f' && c != '\r') return std::nullopt;
  }
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  text = replace_all(replace_all(text, "\r\n", "\n"), "\r", "\n");

  // Logical lines: comments cut, trailing blanks cut, backslash continuations joined.
  std::vector<std::string> lines;
  std::string pending;
  bool continuing = false;
  std::istringstream physical(text);
  for (std::string line; std::getline(physical, line);) {
    line = line.substr(0, line.find('#'));
    while (!line.empty() && std::string(" \t\v\f").find(line.back()) != std::string::npos) line.pop_back();
    const bool continues = !line.empty() && line.back() == '\\';
    if (continues) line.pop_back();
    pending += line + " ";
    continuing = continues;
    if (!continues) {
      lines.push_back(pending);
      pending.clear();
    }
  }
  if (continuing) lines.push_back(pending);

  ReferenceMesh mesh;
  long long vertices = 0;
  std::vector<std::vector<long long>> faces;  // 0-based
  for (const auto& line : lines) {
    std::istringstream words(line);
    std::vector<std::string> tokens;
    for (std::string token; words >> token;) tokens.push_back(token);
    if (tokens.empty()) continue;
    if (tokens[0] == "v") {
      if (tokens.size() < 4 || tokens.size() > 8) return std::nullopt;
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const auto value = number(tokens[k]);
        if (!value) return std::nullopt;
        if (k <= 3) {
          if (*value != *value || *value - *value != 0.0) return std::nullopt;  // NaN or infinite
          mesh.coordinates.push_back(*value);
        }
      }
      ++vertices;
    } else if (tokens[0] == "f") {
      if (tokens.size() < 4) return std::nullopt;
      std::vector<long long> face;
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        std::vector<std::string> parts;
        std::istringstream slashes(tokens[k] + "/");
        for (std::string part; std::getline(slashes, part, '/');) parts.push_back(part);
        if (parts.size() > 3) return std::nullopt;
        const auto index = integer(parts[0]);
        if (!index || *index == 0 || *index < -vertices || *index > INT_MAX) return std::nullopt;
        for (std::size_t p = 1; p < parts.size(); ++p) {
          if (!parts[p].empty() && !integer(parts[p])) return std::nullopt;
        }
        face.push_back(*index > 0 ? *index - 1 : vertices + *index);
      }
      faces.push_back(face);
    }
  }
  if (faces.empty()) return std::nullopt;
  for (const auto& face : faces) {
    for (const long long index : face) {
      if (index >= vertices) return std::nullopt;
    }
  }
  const auto squared_distance = [&](long long a, long long b) {
    double sum = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double d = mesh.coordinates[static_cast<std::size_t>(3 * b + c)] - mesh.coordinates[static_cast<std::size_t>(3 * a + c)];
      sum += d * d;
    }
    return sum;
  };
  for (const auto& f : faces) {
    const auto add = [&](long long a, long long b, long long c) {
      for (const long long v : {a, b, c}) mesh.triangles.push_back(static_cast<int>(v));
    };
    if (f.size() == 4) {
      if (squared_distance(f[0], f[2]) < squared_distance(f[1], f[3])) {
        add(f[0], f[1], f[2]);
        add(f[0], f[2], f[3]);
      } else {
        add(f[0], f[1], f[3]);
        add(f[1], f[2], f[3]);
      }
    } else {
      for (std::size_t k = 1; k + 1 < f.size(); ++k) add(f[0], f[k], f[k + 1]);
    }
  }
  return mesh;
}

[[noreturn]] void disagree(const char* what) {
  std::fprintf(stderr, "the OBJ reader and the reference disagree: %s\n", what);
  std::abort();
}

bool same_arrays(const hdeform::Mesh& a, const hdeform::Mesh& b) {
  if (a.positions.rows() != b.positions.rows() || a.triangles.rows() != b.triangles.rows()) return false;
  for (Eigen::Index i = 0; i < a.positions.size(); ++i) {
    if (std::bit_cast<std::uint64_t>(a.positions.data()[i]) != std::bit_cast<std::uint64_t>(b.positions.data()[i])) return false;
  }
  return a.triangles == b.triangles;
}

// Pieces of 1 to 64 bytes, chosen by the input's length: every cut the input's lines allow.
void compare_pieces(const std::string& text, const std::optional<hdeform::Mesh>& whole) {
  std::string whole_error, pieces_error;
  if (!whole) {
    try {
      (void)hdeform::parse_obj("input.obj", text);
    } catch (const hdeform::InputError& error) {
      whole_error = error.what();
    }
  }
  std::optional<hdeform::Mesh> pieces;
  try {
    pieces = hdeform::detail::try_parse_obj_in_pieces("input.obj", text, 1 + text.size() % 64);
  } catch (const hdeform::InputError& error) {
    pieces_error = error.what();
  }
  if (pieces && (!whole || !same_arrays(*pieces, *whole))) disagree("the pieces build other arrays than the one pass");
  if (!pieces_error.empty() && pieces_error != whole_error) disagree("the pieces refuse with another message than the one pass");
  if (whole && !pieces) {
    // Only a problem in a piece (nothing in a valid file) sends a valid file to the one pass.
    disagree("the pieces refuse a file the one pass reads");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hdeform::fuzz::run_on_one_thread();
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<hdeform::Mesh> mesh;
  hdeform::fuzz::expect_clean_refusal([&] { mesh = hdeform::parse_obj("input.obj", text); });
  const auto reference = reference_read(text);
  if (mesh.has_value() != reference.has_value()) disagree(mesh ? "the reader accepts, the reference refuses" : "the reader refuses, the reference accepts");
  compare_pieces(text, mesh);
  if (!mesh) return 0;
  if (static_cast<std::size_t>(mesh->positions.size()) != reference->coordinates.size()) disagree("vertex count");
  if (static_cast<std::size_t>(mesh->triangles.size()) != reference->triangles.size()) disagree("triangle count");
  for (Eigen::Index v = 0; v < mesh->vertex_count(); ++v) {
    for (int c = 0; c < 3; ++c) {
      const double expected = reference->coordinates[static_cast<std::size_t>(3 * v + c)];
      if (std::bit_cast<std::uint64_t>(mesh->positions(v, c)) != std::bit_cast<std::uint64_t>(expected)) disagree("a coordinate");
    }
  }
  for (Eigen::Index t = 0; t < mesh->triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) {
      if (mesh->triangles(t, c) != reference->triangles[static_cast<std::size_t>(3 * t + c)]) disagree("a triangle");
    }
  }
  return 0;
}
