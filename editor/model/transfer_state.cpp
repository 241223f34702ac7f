#include "transfer_state.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

#include "hdeform/atomic_file.h"
#include "hdeform/counted.h"
#include "hdeform/errors.h"

namespace hdeform::cli {
namespace {

constexpr int kFormat = 1;

template <class T>
T field(const nlohmann::json& json, const char* name, const std::filesystem::path& path) {
  if (!json.contains(name)) throw InputError(path.string() + ": \"" + std::string(name) + "\" is missing");
  try {
    return json.at(name).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(path.string() + ": \"" + std::string(name) + "\" has the wrong type");
  }
}

}  // namespace

bool TransferState::operator==(const TransferState& other) const {
  return source_rest == other.source_rest && target == other.target && poses == other.poses && markers_file == other.markers_file &&
         source_column == other.source_column && markers.source == other.markers.source && markers.target == other.markers.target &&
         source_y_up == other.source_y_up && target_y_up == other.target_y_up && method == other.method && top_n == other.top_n &&
         mismatch_threshold == other.mismatch_threshold;
}

void write_transfer_state(const std::filesystem::path& path, const TransferState& state) {
  const nlohmann::json json{{"hdeform_transfer_state", kFormat},
                            {"source_rest", state.source_rest},
                            {"target", state.target},
                            {"poses", state.poses},
                            {"markers_file", state.markers_file},
                            {"source_column", state.source_column},
                            {"marker_source", state.markers.source},
                            {"marker_target", state.markers.target},
                            {"source_y_up", state.source_y_up},
                            {"target_y_up", state.target_y_up},
                            {"method", state.method == 1 ? "interpolation" : "correspondence"},
                            {"top_n", state.top_n},
                            {"mismatch_threshold", state.mismatch_threshold}};
  const std::string text = json.dump(1) + "\n";
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

TransferState read_transfer_state(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open file");
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::parse_error& error) {
    throw InputError(path.string() + ": not JSON (" + error.what() + ")");
  }
  if (!json.is_object() || field<int>(json, "hdeform_transfer_state", path) != kFormat) {
    throw InputError(path.string() + ": not an hdeform transfer state (format " + std::to_string(kFormat) + ")");
  }
  TransferState state;
  state.source_rest = field<std::string>(json, "source_rest", path);
  state.target = field<std::string>(json, "target", path);
  state.poses = field<std::vector<std::string>>(json, "poses", path);
  state.markers_file = field<std::string>(json, "markers_file", path);
  state.source_column = field<int>(json, "source_column", path);
  if (state.source_column != 1 && state.source_column != 2) throw InputError(path.string() + ": \"source_column\" must be 1 or 2");
  state.markers.source = field<std::vector<int>>(json, "marker_source", path);
  state.markers.target = field<std::vector<int>>(json, "marker_target", path);
  if (state.markers.source.size() != state.markers.target.size()) {
    throw InputError(path.string() + ": \"marker_source\" and \"marker_target\" differ in length");
  }
  for (const auto* list : {&state.markers.source, &state.markers.target}) {
    for (const int vertex : *list) {
      if (vertex < 0) throw InputError(path.string() + ": negative marker vertex " + std::to_string(vertex));
    }
  }
  state.source_y_up = field<bool>(json, "source_y_up", path);
  state.target_y_up = field<bool>(json, "target_y_up", path);
  const auto method = field<std::string>(json, "method", path);
  if (method != "correspondence" && method != "interpolation") throw InputError(path.string() + ": unknown \"method\" '" + method + "'");
  state.method = method == "interpolation" ? 1 : 0;
  state.top_n = field<int>(json, "top_n", path);
  state.mismatch_threshold = field<double>(json, "mismatch_threshold", path);
  if (state.top_n < 0 || !(state.mismatch_threshold > 0.0)) throw InputError(path.string() + ": \"top_n\" or \"mismatch_threshold\" out of range");
  return state;
}

std::string describe_transfer_state(const TransferState& state) {
  const auto name = [](const std::string& path) { return std::filesystem::path(path).filename().string(); };
  std::string text = name(state.source_rest) + " -> " + name(state.target);  // ASCII: the editor's font has no arrow
  if (!state.poses.empty()) {
    text += ", " + counted(state.poses.size(), "pose", "poses");
  }
  text += ", " + counted(state.markers.size(), "marker pair", "marker pairs");
  return text;
}

}  // namespace hdeform::cli
