#include "session.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands/cli_support.h"
#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "hdeform/shapes.h"
#include "json_locate.h"

namespace hdeform::cli {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "hdeform-session";
constexpr int kVersion = 1;

json vector_json(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json transform_json(const HandleTransform& transform) {
  if (transform.kind == HandleTransform::Kind::Pose) {
    return {{"pose",
             {{"pivot", vector_json(transform.pivot)},
              {"axis", vector_json(transform.axis)},
              {"angle", transform.angle},
              {"scale", transform.scale},
              {"shift", vector_json(transform.shift)}}}};
  }
  json matrix = json::array();
  const auto affine = transform.affine();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) matrix.push_back(affine(r, c));
  }
  return {{"matrix", matrix}};
}

json stage_json(const EditStage& stage) {
  json handles = json::array();
  for (const auto& handle : stage.handles) handles.push_back({{"vertices", handle.vertices}, {"transform", transform_json(handle.transform)}});
  json out = {{"region_of_interest", stage.region_of_interest}, {"fixed", stage.fixed}, {"handles", handles}, {"refine", stage.refine}};
  if (stage.refine_settle > 0.0) out["refine_settle"] = stage.refine_settle;
  return out;
}

// Reading with errors that name the line: every accessor takes the value's JSON pointer.
class Reader {
 public:
  explicit Reader(const SessionSource& source) : source_(source) {}

  [[noreturn]] void fail(const std::string& pointer, const std::string& problem) const {
    throw InputError(source_.where(pointer) + ": " + (pointer.empty() ? "" : pointer + ": ") + problem);
  }

  const json& member(const json& object, const std::string& pointer, const char* key, bool required = true) const {
    static const json kNull;
    if (!object.is_object()) fail(pointer, "expected an object");
    const auto it = object.find(key);
    if (it == object.end()) {
      if (required) fail(pointer, std::string("missing \"") + key + "\"");
      return kNull;
    }
    return *it;
  }

  double number(const json& value, const std::string& pointer) const {
    if (!value.is_number()) fail(pointer, "expected a number");
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail(pointer, "non-finite number");
    return number;
  }

  Eigen::Vector3d vector3(const json& value, const std::string& pointer) const {
    if (!value.is_array() || value.size() != 3) fail(pointer, "expected 3 numbers");
    return {number(value[0], pointer + "/0"), number(value[1], pointer + "/1"), number(value[2], pointer + "/2")};
  }

  std::vector<int> indices(const json& value, const std::string& pointer) const {
    if (value.is_null()) return {};
    if (!value.is_array()) fail(pointer, "expected a list of vertex indices");
    std::vector<int> out;
    out.reserve(value.size());
    for (std::size_t k = 0; k < value.size(); ++k) {
      const auto& item = value[k];
      const std::string at = pointer + "/" + std::to_string(k);
      if (!item.is_number_integer()) fail(at, "expected a vertex index (an integer)");
      const auto index = item.get<long long>();
      if (index < 0 || index > std::numeric_limits<int>::max()) fail(at, "vertex index " + std::to_string(index) + " out of range");
      out.push_back(static_cast<int>(index));
    }
    return out;
  }

  HandleTransform transform(const json& value, const std::string& pointer) const {
    try {
      if (value.is_object() && value.contains("pose")) {
        const auto& pose = value["pose"];
        const std::string at = pointer + "/pose";
        return HandleTransform::about_pivot(vector3(member(pose, at, "axis"), at + "/axis"), vector3(member(pose, at, "pivot"), at + "/pivot"),
                                            number(member(pose, at, "angle"), at + "/angle"), number(member(pose, at, "scale"), at + "/scale"),
                                            vector3(member(pose, at, "shift"), at + "/shift"));
      }
      if (value.is_object() && value.contains("matrix")) {
        const auto& matrix = value["matrix"];
        const std::string at = pointer + "/matrix";
        if (!matrix.is_array() || matrix.size() != 12) fail(at, "expected 12 numbers (the 3×4 matrix [A | t], row-major)");
        Eigen::Matrix<double, 3, 4> affine;
        for (int k = 0; k < 12; ++k) affine(k / 4, k % 4) = number(matrix[static_cast<std::size_t>(k)], at + "/" + std::to_string(k));
        return HandleTransform::from_affine(affine);
      }
    } catch (const InputError& error) {
      if (std::string(error.what()).find(source_.path.string()) == 0) throw;
      fail(pointer, error.what());
    }
    fail(pointer, "expected {\"pose\": {...}} or {\"matrix\": [12 numbers]}");
  }

  EditStage stage(const json& value, const std::string& pointer) const {
    EditStage stage;
    stage.region_of_interest = indices(member(value, pointer, "region_of_interest", false), pointer + "/region_of_interest");
    stage.fixed = indices(member(value, pointer, "fixed", false), pointer + "/fixed");
    const auto& handles = member(value, pointer, "handles", false);
    if (!handles.is_null() && !handles.is_array()) fail(pointer + "/handles", "expected a list of handles");
    for (std::size_t h = 0; !handles.is_null() && h < handles.size(); ++h) {
      const std::string at = pointer + "/handles/" + std::to_string(h);
      SessionHandle handle;
      handle.vertices = indices(member(handles[h], at, "vertices"), at + "/vertices");
      if (handle.vertices.empty()) fail(at + "/vertices", "a handle needs at least one vertex");
      handle.transform = transform(member(handles[h], at, "transform"), at + "/transform");
      stage.handles.push_back(std::move(handle));
    }
    const auto& refine = member(value, pointer, "refine", false);  // absent in sessions written before refinement
    if (!refine.is_null() && !refine.is_boolean()) fail(pointer + "/refine", "expected true or false");
    stage.refine = refine.is_boolean() && refine.get<bool>();
    const auto& settle = member(value, pointer, "refine_settle", false);  // absent: the energy test alone
    if (!settle.is_null() && (!settle.is_number() || !std::isfinite(settle.get<double>()) || settle.get<double>() < 0.0 || settle.get<double>() >= 1.0)) {
      fail(pointer + "/refine_settle", "expected a fraction of the bounding-box diagonal, 0 or more and below 1");
    }
    stage.refine_settle = settle.is_number() ? settle.get<double>() : 0.0;
    return stage;
  }

 private:
  const SessionSource& source_;
};

}  // namespace

EditConstraints EditStage::constraints() const {
  EditConstraints constraints;
  constraints.region_of_interest = region_of_interest;
  constraints.fixed = fixed;
  for (const auto& handle : handles) constraints.handles.push_back(handle.vertices);
  return constraints;
}

RefinementOptions EditStage::refinement_options() const {
  RefinementOptions options;
  options.settle = refine_settle;
  return options;
}

std::vector<HandleTransform> EditStage::transforms() const {
  std::vector<HandleTransform> out;
  for (const auto& handle : handles) out.push_back(handle.transform);
  return out;
}

bool EditStage::operator==(const EditStage& other) const {
  if (region_of_interest != other.region_of_interest || fixed != other.fixed || handles.size() != other.handles.size() ||
      refine != other.refine || refine_settle != other.refine_settle) {
    return false;
  }
  for (std::size_t h = 0; h < handles.size(); ++h) {
    if (handles[h].vertices != other.handles[h].vertices) return false;
    if (transform_json(handles[h].transform) != transform_json(other.handles[h].transform)) return false;
  }
  return true;
}

bool Session::operator==(const Session& other) const {
  return mesh == other.mesh && applied == other.applied && current == other.current && active_handle == other.active_handle &&
         resolution == other.resolution && (resolution != Resolution::Multiresolution || base_vertices == other.base_vertices) &&
         precision.value_or(FactorPrecision::Double) == other.precision.value_or(FactorPrecision::Double);
}

json to_json(const Session& session) {
  json applied = json::array();
  for (const auto& stage : session.applied) applied.push_back(stage_json(stage));
  json out = {{"format", kFormat},
              {"version", kVersion},
              {"mesh", session.mesh},
              {"applied", applied},
              {"current", stage_json(session.current)},
              {"active_handle", session.active_handle}};
  out["resolution"] = to_string(session.resolution);
  if (session.resolution == Resolution::Multiresolution) out["base_vertices"] = session.base_vertices;
  if (session.precision == FactorPrecision::Single) out["precision"] = to_string(*session.precision);
  return out;
}

namespace {

// FNV-1a, 64 bits: identifies a state among a few hundred, not a defence against forgery.
std::string fnv1a_digest(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 0x100000001b3ull;
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

}  // namespace

std::string session_digest(const Session& session) { return fnv1a_digest(to_json(session).dump()); }

std::string positions_digest(const Eigen::MatrixXd& positions) {
  return fnv1a_digest({reinterpret_cast<const char*>(positions.data()), static_cast<std::size_t>(positions.size()) * sizeof(double)});
}

std::string SessionSource::where(const std::string& pointer) const {
  const std::size_t line = json_line_of(text, pointer);
  return line > 0 ? path.string() + ":" + std::to_string(line) : path.string();
}

Session session_from_json(const json& value, const SessionSource& source) {
  const Reader reader(source);
  if (!value.is_object()) reader.fail("", "a session is a JSON object");
  const auto& format = reader.member(value, "", "format");
  if (format != kFormat) reader.fail("/format", "not an hdeform session (format is not \"hdeform-session\")");
  const auto& version = reader.member(value, "", "version");
  if (!version.is_number_integer() || version.get<int>() != kVersion) reader.fail("/version", "unsupported session version (this build reads 1)");
  Session session;
  const auto& mesh = reader.member(value, "", "mesh");
  if (!mesh.is_string() || mesh.get<std::string>().empty()) reader.fail("/mesh", "expected the mesh's path or shape:NAME");
  session.mesh = mesh.get<std::string>();
  const auto& applied = reader.member(value, "", "applied", false);
  if (!applied.is_null() && !applied.is_array()) reader.fail("/applied", "expected a list of stages");
  for (std::size_t k = 0; !applied.is_null() && k < applied.size(); ++k) {
    auto stage = reader.stage(applied[k], "/applied/" + std::to_string(k));
    if (stage.handles.empty()) reader.fail("/applied/" + std::to_string(k), "an applied stage needs a handle");
    session.applied.push_back(std::move(stage));
  }
  session.current = reader.stage(reader.member(value, "", "current"), "/current");
  const auto& active = reader.member(value, "", "active_handle", false);
  if (!active.is_null()) {
    if (!active.is_number_integer()) reader.fail("/active_handle", "expected an integer");
    session.active_handle = active.get<int>();
  }
  if (session.active_handle < 0 || (session.active_handle > 0 && session.active_handle >= static_cast<int>(session.current.handles.size()))) {
    reader.fail("/active_handle", "no handle " + std::to_string(session.active_handle));
  }
  const auto& resolution = reader.member(value, "", "resolution", false);
  session.resolution = Resolution::Exact;  // absent: a session from before multiresolution
  if (!resolution.is_null()) {
    const auto parsed = resolution.is_string() ? parse_resolution(resolution.get<std::string>()) : std::nullopt;
    if (!parsed) reader.fail("/resolution", "expected \"exact\", \"multiresolution\" or \"automatic\"");
    session.resolution = *parsed;
  }
  const auto& base_vertices = reader.member(value, "", "base_vertices", false);
  if (session.resolution == Resolution::Multiresolution) {
    if (!base_vertices.is_number_integer() || base_vertices.get<std::int64_t>() < 4) {
      reader.fail("/base_vertices", "multiresolution needs the base mesh's size: an integer, at least 4");
    }
    session.base_vertices = base_vertices.get<Eigen::Index>();
  }
  const auto& precision = reader.member(value, "", "precision", false);
  if (!precision.is_null()) {
    const auto parsed = precision.is_string() ? parse_precision(precision.get<std::string>()) : std::nullopt;
    if (!parsed) reader.fail("/precision", "expected \"double\" or \"single\"");
    session.precision = *parsed;
  }
  return session;
}

Session read_session(const std::filesystem::path& path, SessionSource* source_out) {
  SessionSource source{path, {}};
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path.string() + ": cannot open file (" + std::strerror(errno) + ")");
    std::ostringstream text;
    text << in.rdbuf();
    source.text = std::move(text).str();
  }
  if (source.text.find('\0') != std::string::npos) throw InputError(path.string() + ": binary data, not a JSON session");
  json value;
  try {
    value = json::parse(source.text);
  } catch (const json::parse_error& error) {
    const std::string what = error.what();
    const auto colon = what.rfind(": ");
    throw InputError(path.string() + ":" + std::to_string(line_of_offset(source.text, error.byte > 0 ? error.byte - 1 : 0)) +
                     ": not valid JSON (" + (colon == std::string::npos ? what : what.substr(colon + 2)) + ")");
  } catch (const json::exception& error) {
    // A number too large for a double ("number overflow parsing '1e999'"): point at its line.
    const std::string what = error.what();
    const auto quote = what.find('\'');
    const auto token = quote == std::string::npos ? std::string() : what.substr(quote + 1, what.find('\'', quote + 1) - quote - 1);
    const auto at = token.empty() ? std::string::npos : source.text.find(token);
    const std::string where = at == std::string::npos ? path.string() : path.string() + ":" + std::to_string(line_of_offset(source.text, at));
    throw InputError(where + ": not valid JSON (" + (token.empty() ? what : "the number " + token + " is out of range") + ")");
  }
  Session session = session_from_json(value, source);
  if (!names_builtin_shape(session.mesh)) {
    const std::filesystem::path mesh(session.mesh);
    if (mesh.is_relative()) session.mesh = (path.parent_path() / mesh).lexically_normal().string();
  }
  if (source_out != nullptr) *source_out = std::move(source);
  return session;
}

void write_session(const std::filesystem::path& path, const Session& session) {
  const std::string text = to_json(session).dump(1) + "\n";
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

void check_session_against_mesh(const Session& session, Eigen::Index vertex_count, const SessionSource& source) {
  // One byte per vertex, and an item's name written only for the error: at 1.6 million vertices a
  // name per vertex and per listed index took 0.36 s of opening a scan.
  constexpr std::uint8_t kUnlisted = 0, kListed = 1;
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(vertex_count));
  std::vector<int> owner(static_cast<std::size_t>(vertex_count));  // 0 none, 1 fixed, h + 2 handle h
  auto owner_name = [](int owner_code) { return owner_code == 1 ? std::string("fixed") : "in handle " + std::to_string(owner_code - 1); };
  auto check_stage = [&](const EditStage& stage, const std::string& pointer) {
    std::fill(owner.begin(), owner.end(), 0);
    auto check_list = [&](const std::vector<int>& list, const std::string& at, int owner_code) {
      auto item = [&](std::size_t k) { return at + "/" + std::to_string(k); };
      std::fill(seen.begin(), seen.end(), kUnlisted);
      for (std::size_t k = 0; k < list.size(); ++k) {
        const int v = list[k];
        if (v < 0 || v >= vertex_count) {
          throw InputError(source.where(item(k)) + ": " + item(k) + ": vertex " + std::to_string(v) + " out of range (the mesh has " +
                           std::to_string(vertex_count) + " vertices)");
        }
        auto& listed = seen[static_cast<std::size_t>(v)];
        if (listed == kListed) throw InputError(source.where(item(k)) + ": " + item(k) + ": vertex " + std::to_string(v) + " listed twice");
        listed = kListed;
        if (owner_code == 0) continue;
        int& taken = owner[static_cast<std::size_t>(v)];
        if (taken != 0) {
          throw InputError(source.where(item(k)) + ": " + item(k) + ": vertex " + std::to_string(v) + " is both " + owner_name(taken) + " and " +
                           owner_name(owner_code));
        }
        taken = owner_code;
      }
    };
    check_list(stage.region_of_interest, pointer + "/region_of_interest", 0);
    check_list(stage.fixed, pointer + "/fixed", 1);
    for (std::size_t h = 0; h < stage.handles.size(); ++h) {
      check_list(stage.handles[h].vertices, pointer + "/handles/" + std::to_string(h) + "/vertices", static_cast<int>(h) + 2);
    }
  };
  for (std::size_t k = 0; k < session.applied.size(); ++k) check_stage(session.applied[k], "/applied/" + std::to_string(k));
  check_stage(session.current, "/current");
}

Mesh load_session_mesh(const Session& session, const SessionSource* session_source) {
  if (session_source != nullptr) {
    Mesh mesh;
    try {
      mesh = load_session_mesh(session);
    } catch (const InputError& error) {
      throw InputError(session_source->where("/mesh") + ": the session's mesh: " + error.what());
    }
    check_session_against_mesh(session, mesh.vertex_count(), *session_source);
    return mesh;
  }
  if (names_builtin_shape(session.mesh)) {
    try {
      return load_mesh(MeshSource::from_name(session.mesh)).mesh;
    } catch (const InputError& error) {
      throw InputError(std::string("session mesh ") + error.what());
    }
  }
  return read_mesh(session.mesh);
}

Eigen::MatrixXd stage_result(Deformer& deformer, const EditStage& stage) {
  Eigen::MatrixXd positions;
  const auto transforms = stage.transforms();
  deformer.deform(transforms, positions);
  if (stage.refine) {
    const RefinementOptions options = stage.refinement_options();
    deformer.set_refinement_options(options);
    deformer.refine(positions, options.max_iterations);
  }
  return positions;
}

Eigen::MatrixXd replay_session(const Session& session, const Mesh& base, const DeformerOptions& options, const ProgressCallback& progress) {
  validate_mesh(base, session.mesh.empty() ? "session mesh" : session.mesh);
  Mesh rest = base;
  auto run_stage = [&](const EditStage& stage) {
    DeformerOptions stage_options = options;
    stage_options.prepare_refinement = stage.refine;
    stage_options.resolution = session.resolution;
    if (session.resolution == Resolution::Multiresolution) stage_options.base_vertices = session.base_vertices;
    if (session.precision) stage_options.precision = *session.precision;
    Deformer deformer(rest, stage.constraints(), stage_options, progress);
    if (stage.refine && progress) progress("refining until converged");
    return stage_result(deformer, stage);
  };
  for (const auto& stage : session.applied) rest.positions = run_stage(stage);
  if (session.current.handles.empty()) return rest.positions;
  return run_stage(session.current);
}

}  // namespace hdeform::cli
