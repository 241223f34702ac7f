#include "gui/transfer_view.h"
#include "gui/transfer_view_parts.h"

#include "gui/view_navigation.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <fnmatch.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands/cli_support.h"
#include "gui/widgets.h"
#include "hdeform/counted.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/engine/mesh_renderer.h"
#include "hdeform/errors.h"
#include "hdeform/mesh_io.h"
#include "model/mesh_picker.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;

constexpr float kMarkerPickPixels = 9.0f;  // a click this close to a marker takes the marker
constexpr float kMarkerDotPixels = 4.0f;   // ... or only this close, when it would complete a pair
const char* const kSideNames[2] = {"source", "target"};


}  // namespace

// Paths separated by white space; a name with * or ? expands to the matching files of its folder,
// sorted.
std::vector<std::string> expand_paths(const std::string& text) {
  std::vector<std::string> paths;
  std::istringstream stream(text);
  for (std::string item; stream >> item;) {
    const std::filesystem::path path(item);
    const std::string name = path.filename().string();
    if (name.find_first_of("*?[") == std::string::npos) {
      paths.push_back(item);
      continue;
    }
    const auto folder = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
    std::vector<std::string> matches;
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
      if (entry.is_regular_file() && fnmatch(name.c_str(), entry.path().filename().c_str(), 0) == 0) matches.push_back(entry.path().string());
    }
    if (error) throw InputError(folder.string() + ": cannot list the folder (" + error.message() + ")");
    if (matches.empty()) throw InputError(item + ": no file matches");
    std::sort(matches.begin(), matches.end());
    paths.insert(paths.end(), matches.begin(), matches.end());
  }
  return paths;
}

void copy_text(char* buffer, std::size_t size, const std::string& text) { std::snprintf(buffer, size, "%s", text.c_str()); }

TransferView::TransferView(const engine::VulkanContext& context, VkRenderPass render_pass, const engine::PassFormat& format,
                           uint32_t frames_in_flight, std::optional<engine::UpAxis> up)
    : context_(context), render_pass_(render_pass), format_(format), frames_in_flight_(frames_in_flight), up_(up) {}

TransferView::~TransferView() {
  load_.abandon();
  compute_.abandon();
  vkDeviceWaitIdle(context_.device());
}

bool TransferView::working() const { return load_.running() || compute_.running(); }

// ---- loading ------------------------------------------------------------------------------------

void TransferView::open(const TransferPaths& inputs) {
  if (working()) {
    error_ = "wait until the current work finishes";
    return;
  }
  copy_text(source_path_, sizeof source_path_, inputs.source_rest);
  copy_text(target_path_, sizeof target_path_, inputs.target);
  std::string poses;
  for (const auto& pose : inputs.poses) poses += (poses.empty() ? "" : " ") + pose;
  copy_text(poses_path_, sizeof poses_path_, poses);
  copy_text(markers_file_, sizeof markers_file_, inputs.markers);
  source_column_ = inputs.source_column;
  error_.clear();
  load_.start("Loading " + inputs.source_rest + " and " + inputs.target, [inputs] {
    auto loaded = std::make_unique<Loaded>();
    if (inputs.source_rest.empty() || inputs.target.empty()) throw InputError("give the source rest mesh and the target mesh");
    loaded->source_path = inputs.source_rest;
    loaded->target_path = inputs.target;
    loaded->source_rest = read_mesh(inputs.source_rest);
    loaded->target = read_mesh(inputs.target);
    std::vector<std::string> pose_paths;
    for (const auto& pose : inputs.poses) {
      const auto expanded = expand_paths(pose);
      pose_paths.insert(pose_paths.end(), expanded.begin(), expanded.end());
    }
    for (const auto& path : pose_paths) {
      Mesh pose = read_mesh(path);
      if (pose.vertex_count() != loaded->source_rest.vertex_count() || pose.triangles != loaded->source_rest.triangles) {
        throw InputError(path + ": a pose must have the source rest mesh's vertices and triangles");
      }
      loaded->poses.push_back(std::move(pose.positions));
      loaded->pose_names.push_back(std::filesystem::path(path).stem().string());
      loaded->pose_paths.push_back(path);
    }
    loaded->markers_path = inputs.markers;
    loaded->source_column = inputs.source_column;
    if (!inputs.markers.empty() && std::filesystem::exists(inputs.markers)) {
      loaded->markers = read_marker_pairs(inputs.markers, inputs.source_column == 2 ? SourceColumn::Second : SourceColumn::First,
                                          loaded->source_rest.vertex_count(), loaded->target.vertex_count());
    }
    return loaded;
  }, [] { glfwPostEmptyEvent(); });
}

void TransferView::drop(const std::vector<std::string>& paths, const ImVec2& cursor) {
  if (paths.empty()) return;
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  TransferPaths inputs{source_path_, target_path_, expand_paths(poses_path_), markers_file_, source_column_};
  if (side_under(ImVec2(cursor.x * scale.x, cursor.y * scale.y)) == 1) {
    inputs.target = paths.front();
  } else {
    inputs.source_rest = paths.front();
    inputs.poses.assign(paths.begin() + 1, paths.end());
  }
  if (!inputs.source_rest.empty() && !inputs.target.empty()) {
    open_or_ask(inputs);
  } else {
    copy_text(source_path_, sizeof source_path_, inputs.source_rest);
    copy_text(target_path_, sizeof target_path_, inputs.target);
    status_ = "Now drop the " + std::string(inputs.target.empty() ? "target" : "source") + " mesh on its side";
  }
}

void TransferView::install(std::unique_ptr<Loaded> loaded) {
  vkDeviceWaitIdle(context_.device());
  const Mesh* meshes[2] = {&loaded->source_rest, &loaded->target};
  const std::string* paths[2] = {&loaded->source_path, &loaded->target_path};
  for (int s = 0; s < 2; ++s) {
    auto side = std::make_unique<Side>();
    side->rest = *meshes[s];
    side->path = *paths[s];
    side->exchange = std::make_unique<engine::GeometryExchange>(static_cast<std::size_t>(side->rest.vertex_count()));
    side->publisher = std::make_unique<engine::GeometryPublisher>(*side->exchange, side->rest.triangles);
    side->renderer = std::make_unique<engine::MeshRenderer>(context_, render_pass_, format_, frames_in_flight_);
    side->up = up_.value_or(engine::guess_up_axis(side->rest.positions));
    side->renderer->set_mesh(side->rest.triangles, *side->exchange, engine::Bounds::of(side->rest.positions), side->up);
    side->settings.legend = false;
    sides_[s] = std::move(side);
  }
  poses_ = std::move(loaded->poses);
  pose_names_ = std::move(loaded->pose_names);
  pose_paths_ = std::move(loaded->pose_paths);
  markers_ = MarkerEditor{};
  if (loaded->markers) markers_.replace(std::move(*loaded->markers));
  saved_markers_version_ = markers_.version();
  ++settings_version_;
  markers_path_ = loaded->markers_path;
  source_column_ = loaded->source_column;
  // Last: a restored state's markers file and pairs (unsaved until saved) win over the load's.
  if (restoring_) apply_restored(*std::exchange(restoring_, std::nullopt));
  computed_.reset();
  pending_.reset();
  drag_.reset();
  selected_ = -1;
  playing_ = false;
  frame_ = -1;
  shown_frame_ = -2;
  show_frame(-1);
  status_ = "Click a vertex on one mesh, then its counterpart on the other, to add a marker pair.";
  print_json_line({{"event", "transfer opened"},
                   {"source", sides_[0]->path},
                   {"target", sides_[1]->path},
                   {"poses", poses_.size()},
                   {"markers", markers_.size()}});
}

std::optional<TransferState> TransferView::state() const {
  if (!sides_[0]) return std::nullopt;
  TransferState state;
  state.source_rest = sides_[0]->path;
  state.target = sides_[1]->path;
  state.poses = pose_paths_;
  state.markers_file = markers_path_;
  state.source_column = source_column_;
  state.markers = markers_.pairs();
  state.source_y_up = sides_[0]->up == engine::UpAxis::Y;
  state.target_y_up = sides_[1]->up == engine::UpAxis::Y;
  state.method = method_;
  state.top_n = top_n_;
  state.mismatch_threshold = mismatch_threshold_;
  return state;
}

void TransferView::restore(const TransferState& state) {
  // A load from the command line may still be running: the restored state supersedes it.
  load_.abandon();
  compute_.abandon();
  restoring_ = state;
  // The markers come from the state, not from the markers file (which may be older).
  open({state.source_rest, state.target, state.poses, "", state.source_column});
}

void TransferView::apply_restored(const TransferState& state) {
  for (const auto* list : {&state.markers.source, &state.markers.target}) {
    const Eigen::Index count = sides_[list == &state.markers.source ? 0 : 1]->rest.vertex_count();
    for (const int vertex : *list) {
      if (vertex >= count) {
        error_ = "the recovered markers do not fit the meshes (vertex " + std::to_string(vertex) + "); the markers were not restored";
        return;
      }
    }
  }
  markers_.replace(state.markers);
  markers_path_ = state.markers_file;
  copy_text(markers_file_, sizeof markers_file_, state.markers_file);
  const bool y_up[2] = {state.source_y_up, state.target_y_up};
  for (int s = 0; s < 2; ++s) set_up(s, y_up[s] ? engine::UpAxis::Y : engine::UpAxis::Z);
  method_ = state.method;
  top_n_ = state.top_n;
  mismatch_threshold_ = static_cast<float>(state.mismatch_threshold);
  publish_markers();
  status_ = "Restored " + counted(markers_.size(), "marker pair", "marker pairs");
  print_json_line({{"event", "transfer restored"}, {"markers", markers_.size()}});
}

void TransferView::set_up(int side, engine::UpAxis up) {
  Side& view = *sides_[side];
  if (view.up == up) return;
  view.up = up;
  view.renderer->set_mesh(view.rest.triangles, *view.exchange, engine::Bounds::of(view.rest.positions), view.up);
  view.camera_fitted = false;  // framed again, standing up
  ++settings_version_;
}

// ---- each frame ---------------------------------------------------------------------------------

void TransferView::poll() {
  const auto failed = [this](const std::string& failure) {
    error_ = failure;
    print_json_line({{"event", "error"}, {"message", failure}});
  };
  if (load_.done()) {
    auto outcome = load_.take();
    if (!outcome.error.empty()) {
      failed(outcome.error + (restoring_ ? " (the recovered transfer state was not restored)" : ""));
      restoring_.reset();
    } else {
      install(std::move(*outcome.result));
    }
  }
  if (compute_.done()) {
    auto outcome = compute_.take();
    if (!outcome.error.empty()) failed(outcome.error);
    std::unique_ptr<Computed> computed = outcome.result ? std::move(*outcome.result) : nullptr;
    if (computed) {
      computed_ = std::move(computed);
      computed_markers_version_ = computed_->markers_version;
      status_ = "Transferred " + counted(computed_->results.size(), "pose", "poses");
      nlohmann::json setup = {{"total", computed_->setup.total_ms},
                              {"correspondence", computed_->setup.source_coordinates_ms + computed_->setup.target_coordinates_ms + computed_->setup.matching_ms}};
      print_json_line({{"event", "transfer computed"},
                       {"method", to_string(computed_->method)},
                       {"poses", computed_->results.size()},
                       {"markers", markers_.size()},
                       {"factorizations", computed_->factorizations},
                       {"mismatched_triangles", computed_->mismatches},
                       {"setup_ms", setup},
                       {"pose_ms", to_json(computed_->pose_ms)}});
      frame_ = poses_.empty() ? -1 : 0;
      playing_ = poses_.size() > 1;
      last_advance_ = Clock::now();
      shown_frame_ = -2;
    }
  }
  if (!sides_[0]) return;
  if (playing_ && !poses_.empty() && seconds_since(last_advance_) >= 1.0 / std::max(frames_per_second_, 1.0f)) {
    frame_ = (frame_ + 1) % static_cast<int>(poses_.size());
    last_advance_ = Clock::now();
  }
  const bool results = computed_ && !stale();
  if (frame_ != shown_frame_ || results != shown_results_) show_frame(frame_);
}

bool TransferView::stale() const { return computed_ && computed_markers_version_ != markers_.version(); }

void TransferView::show_frame(int frame) {
  frame = std::clamp(frame, -1, static_cast<int>(poses_.size()) - 1);
  frame_ = frame;
  shown_frame_ = frame;
  shown_results_ = computed_ && !stale();
  const Eigen::MatrixXd& source = frame < 0 ? sides_[0]->rest.positions : poses_[static_cast<std::size_t>(frame)];
  const Eigen::MatrixXd& target =
      frame < 0 || !shown_results_ ? sides_[1]->rest.positions : computed_->results[static_cast<std::size_t>(frame)];
  sides_[0]->publisher->publish(source);
  sides_[0]->shown = &source;
  sides_[1]->publisher->publish(target);
  sides_[1]->shown = &target;
  publish_markers();
}

const Eigen::MatrixXd& TransferView::shown_positions(int side) const {
  return sides_[side]->shown != nullptr ? *sides_[side]->shown : sides_[side]->rest.positions;
}

void TransferView::publish_markers() {
  for (int s = 0; s < 2; ++s) {
    if (!sides_[s]) continue;
    const auto& vertices = s == 0 ? markers_.pairs().source : markers_.pairs().target;
    std::vector<engine::Marker> markers;
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const int vertex = drag_ && drag_->pair == k && drag_->side == s ? drag_->vertex : vertices[k];
      markers.push_back({shown_positions(s).row(vertex).transpose().cast<float>(), static_cast<uint32_t>(k % HD_HANDLE_COLORS)});
    }
    if (pending_ && pending_->side == s) markers.push_back({shown_positions(s).row(pending_->vertex).transpose().cast<float>(), static_cast<uint32_t>(markers.size() % HD_HANDLE_COLORS)});
    sides_[s]->renderer->set_markers(markers);
  }
}

void TransferView::fit_cameras() {
  for (auto& side : sides_) {
    if (!side || side->area.extent.width == 0) continue;
    side->camera = engine::Camera::three_quarter_front(engine::Bounds::of(side->rest.positions), side->up, side->aspect());
    side->camera_fitted = true;
  }
}

void TransferView::prepare(uint32_t slot, VkExtent2D framebuffer, float panel_pixels) {
  if (!sides_[0]) return;
  const auto left = static_cast<int32_t>(std::min(std::lround(panel_pixels), static_cast<long>(framebuffer.width)));
  const uint32_t width = framebuffer.width - static_cast<uint32_t>(left);
  sides_[0]->area = {{left, 0}, {width / 2, framebuffer.height}};
  sides_[1]->area = {{left + static_cast<int32_t>(width / 2), 0}, {width - width / 2, framebuffer.height}};
  for (auto& side : sides_) {
    if (!side->camera_fitted && side->area.extent.width > 0) {
      side->camera = engine::Camera::three_quarter_front(engine::Bounds::of(side->rest.positions), side->up, side->aspect());
      side->camera_fitted = true;
    }
    if (side->area.extent.width > 0 && side->area.extent.height > 0) side->renderer->prepare(slot, side->camera, side->settings, side->area);
  }
}

void TransferView::record(VkCommandBuffer commands, uint32_t slot) const {
  if (!sides_[0]) return;
  for (const auto& side : sides_) {
    if (side->area.extent.width > 0 && side->area.extent.height > 0) side->renderer->record(commands, slot, side->area);
  }
}

bool TransferView::busy() const { return working() || playing_ || drag_.has_value(); }

std::optional<std::pair<std::string, double>> TransferView::work() const {
  if (load_.running()) return std::pair{load_.what(), load_.seconds()};
  if (compute_.running()) return std::pair{compute_.what(), compute_.seconds()};
  return std::nullopt;
}

// ---- input -------------------------------------------------------------------------------------

int TransferView::side_under(const ImVec2& pixel) const {
  for (int s = 0; s < 2; ++s) {
    if (!sides_[s]) continue;
    const VkRect2D& area = sides_[s]->area;
    if (pixel.x >= static_cast<float>(area.offset.x) && pixel.x < static_cast<float>(area.offset.x) + static_cast<float>(area.extent.width) &&
        pixel.y >= static_cast<float>(area.offset.y) && pixel.y < static_cast<float>(area.offset.y) + static_cast<float>(area.extent.height)) {
      return s;
    }
  }
  return -1;
}

ImVec2 TransferView::project(int side, const Eigen::Vector3d& point) const {
  const Side& s = *sides_[side];
  const Eigen::Vector4f clip = s.camera.view_projection(s.aspect()) * Eigen::Vector4f(point.cast<float>().homogeneous());
  return ImVec2(static_cast<float>(s.area.offset.x) + (clip.x() / clip.w() * 0.5f + 0.5f) * static_cast<float>(s.area.extent.width),
                static_cast<float>(s.area.offset.y) + (clip.y() / clip.w() * 0.5f + 0.5f) * static_cast<float>(s.area.extent.height));
}

std::optional<int> TransferView::pick_vertex(int side, const ImVec2& pixel) {
  Side& s = *sides_[side];
  MeshPicker* picker = s.picker.follow(s.rest.triangles, s.exchange->acquire());
  if (picker == nullptr) return std::nullopt;
  const auto ray = s.camera.ray(pixel.x - static_cast<float>(s.area.offset.x), pixel.y - static_cast<float>(s.area.offset.y),
                                static_cast<float>(s.area.extent.width), static_cast<float>(s.area.extent.height));
  const auto hit = picker->pick(ray);
  if (!hit) return std::nullopt;
  return hit->vertex;
}

std::optional<std::size_t> TransferView::marker_near(int side, const ImVec2& pixel, float reach_pixels) const {
  const auto& vertices = side == 0 ? markers_.pairs().source : markers_.pairs().target;
  const float reach = reach_pixels * ImGui::GetIO().DisplayFramebufferScale.x;
  std::optional<std::size_t> nearest;
  float best = reach;
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const ImVec2 at = project(side, shown_positions(side).row(vertices[k]).transpose());
    const float distance = std::hypot(at.x - pixel.x, at.y - pixel.y);
    if (distance <= best) {
      best = distance;
      nearest = k;
    }
  }
  return nearest;
}

void TransferView::add_or_complete(int side, int vertex) {
  if (!pending_ || pending_->side == side) {
    if (const int taken = markers_.find(side == 0 ? MarkerSide::Source : MarkerSide::Target, vertex); taken >= 0) {
      selected_ = taken;
      status_ = std::string(kSideNames[side]) + " vertex " + std::to_string(vertex) + " already has marker " + std::to_string(taken + 1);
      return;
    }
    pending_ = Pending{side, vertex};
    status_ = "Now click the matching vertex on the " + std::string(kSideNames[1 - side]) + " (Esc cancels).";
    publish_markers();
    return;
  }
  const int source = side == 0 ? vertex : pending_->vertex;
  const int target = side == 1 ? vertex : pending_->vertex;
  if (const auto problem = markers_.add(source, target)) {
    status_ = *problem;
    return;
  }
  pending_.reset();
  selected_ = static_cast<int>(markers_.size()) - 1;
  status_ = "Marker " + std::to_string(markers_.size()) + ": source vertex " + std::to_string(source) + ", target vertex " + std::to_string(target);
  print_json_line({{"event", "marker added"}, {"pair", markers_.size() - 1}, {"source", source}, {"target", target}});
  publish_markers();
}

void TransferView::handle_mouse() {
  if (!sides_[0]) return;
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 scale = io.DisplayFramebufferScale;
  const ImVec2 pixel(io.MousePos.x * scale.x, io.MousePos.y * scale.y);
  const int side = side_under(pixel);

  // Each view's camera, as in edit mode, moved in the view where the drag began.
  const CameraGesture gesture = camera_gesture_now();
  if (gesture != CameraGesture::None) {
    if (camera_side_ < 0 && !io.WantCaptureMouse) camera_side_ = side;
  } else {
    camera_side_ = -1;
  }
  const Eigen::Vector2f delta(io.MouseDelta.x, io.MouseDelta.y);
  if (camera_side_ >= 0) {
    apply_camera_gesture(sides_[camera_side_]->camera, gesture, delta, static_cast<float>(sides_[camera_side_]->area.extent.height) / scale.y, 0.0f);
  }
  if (!io.WantCaptureMouse && side >= 0) apply_camera_gesture(sides_[side]->camera, CameraGesture::None, delta, 1.0f, io.MouseWheel);

  if (drag_) {
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      if (const auto vertex = pick_vertex(drag_->side, pixel); vertex && *vertex != drag_->vertex) {
        drag_->vertex = *vertex;
        publish_markers();
      }
      return;
    }
    const Drag finished = *drag_;
    drag_.reset();
    const auto& vertices = finished.side == 0 ? markers_.pairs().source : markers_.pairs().target;
    if (finished.vertex != vertices[finished.pair]) {
      if (const auto problem = markers_.move(finished.pair, finished.side == 0 ? MarkerSide::Source : MarkerSide::Target, finished.vertex)) {
        status_ = *problem;
      } else {
        status_ = "Moved marker " + std::to_string(finished.pair + 1);
      }
    }
    publish_markers();
    return;
  }
  if (io.WantCaptureMouse || side < 0 || io.KeyAlt || !ImGui::IsMouseClicked(ImGuiMouseButton_Left)) return;
  // With a pair waiting for this side, a click completes it unless it lands on a marker's dot.
  const bool completing = pending_ && pending_->side != side;
  if (const auto near = marker_near(side, pixel, completing ? kMarkerDotPixels : kMarkerPickPixels)) {
    selected_ = static_cast<int>(*near);
    const auto& vertices = side == 0 ? markers_.pairs().source : markers_.pairs().target;
    drag_ = Drag{*near, side, vertices[*near]};
    status_ = "Marker " + std::to_string(*near + 1) + " selected: drag to move it, Delete removes the pair";
    return;
  }
  if (const auto vertex = pick_vertex(side, pixel)) add_or_complete(side, *vertex);
}

void TransferView::handle_key(int key, int mods) {
  if (!sides_[0]) return;
  constexpr int kModifiers = GLFW_MOD_CONTROL | GLFW_MOD_SHIFT | GLFW_MOD_ALT;
  const int modifiers = mods & kModifiers;
  const auto after_history = [this](const char* what) {
    pending_.reset();
    selected_ = std::min(selected_, static_cast<int>(markers_.size()) - 1);
    status_ = what;
    publish_markers();
  };
  if (key == GLFW_KEY_Z && modifiers == GLFW_MOD_CONTROL && markers_.undo()) after_history("Undone");
  if (((key == GLFW_KEY_Z && modifiers == (GLFW_MOD_CONTROL | GLFW_MOD_SHIFT)) || (key == GLFW_KEY_Y && modifiers == GLFW_MOD_CONTROL)) &&
      markers_.redo()) {
    after_history("Redone");
  }
  if (key == GLFW_KEY_S && modifiers == GLFW_MOD_CONTROL) {
    if (markers_path_.empty()) save_as_open_ = true;
    else save_markers(markers_path_);
  }
  if (modifiers != 0) return;
  if ((key == GLFW_KEY_DELETE || key == GLFW_KEY_BACKSPACE) && selected_ >= 0 && selected_ < static_cast<int>(markers_.size())) {
    markers_.remove(static_cast<std::size_t>(selected_));
    status_ = "Removed marker " + std::to_string(selected_ + 1);
    selected_ = -1;
    publish_markers();
  }
  if (key == GLFW_KEY_ESCAPE) {
    pending_.reset();
    selected_ = -1;
    publish_markers();
  }
  if (key == GLFW_KEY_SPACE && !poses_.empty()) {
    playing_ = !playing_;
    if (playing_ && frame_ < 0) frame_ = 0;
    last_advance_ = Clock::now();
  }
  if (key == GLFW_KEY_RIGHT && !poses_.empty()) frame_ = std::min(frame_ + 1, static_cast<int>(poses_.size()) - 1);
  if (key == GLFW_KEY_LEFT && !poses_.empty()) frame_ = std::max(frame_ - 1, -1);
  if (key == GLFW_KEY_F5) start_compute();
  if (key == GLFW_KEY_F) fit_cameras();
}

// ---- compute, save, export ------------------------------------------------------------------------

void TransferView::start_compute() {
  if (!sides_[0] || working()) return;
  if (markers_.size() < kMinimumMarkers) {
    error_ = "Place at least " + std::to_string(kMinimumMarkers) + " marker pairs first";
    return;
  }
  error_.clear();
  playing_ = false;
  TransferOptions options;
  options.method = method_ == 0 ? TransferMethod::Correspondence : TransferMethod::Interpolation;
  options.top_n = method_ == 0 ? top_n_ : 0;
  options.mismatch_threshold = mismatch_threshold_;
  compute_.start("Transferring " + counted(poses_.size(), "pose", "poses") + " by " + std::string(to_string(options.method)),
                 [options, source = sides_[0]->rest, target = sides_[1]->rest, markers = markers_.pairs(), poses = poses_, version = markers_.version()] {
    DeformationTransfer transfer(source, target, markers, options);
    auto computed = std::make_unique<Computed>();
    std::vector<double> pose_ms;
    for (const auto& pose : poses) {
      computed->results.emplace_back();
      transfer.transfer(pose, computed->results.back());
      pose_ms.push_back(transfer.last_pose().total_ms);
    }
    computed->setup = transfer.setup_timings();
    computed->pose_ms = summarize(pose_ms);
    computed->factorizations = transfer.factorizations();
    computed->mismatches = transfer.mismatch_count();
    computed->markers_version = version;
    computed->method = options.method;
    computed->warnings = transfer.warnings();
    return computed;
  }, [] { glfwPostEmptyEvent(); });
}

void TransferView::save_markers(const std::string& path) {
  try {
    write_marker_pairs(path, markers_.pairs(), source_column_ == 2 ? SourceColumn::Second : SourceColumn::First);
    saved_markers_version_ = markers_.version();
    markers_path_ = path;
    copy_text(markers_file_, sizeof markers_file_, path);
    status_ = "Saved " + counted(markers_.size(), "marker pair", "marker pairs") + " to " + path;
    error_.clear();
    print_json_line({{"event", "markers saved"}, {"path", path}, {"count", markers_.size()}, {"source_column", source_column_}});
  } catch (const std::exception& error) {
    error_ = error.what();
  }
}

void TransferView::export_sequence(const std::string& folder) {
  if (!computed_ || stale()) return;
  try {
    std::error_code error;
    std::filesystem::create_directories(folder, error);
    if (error) throw InputError(folder + ": cannot create the folder (" + error.message() + ")");
    for (std::size_t p = 0; p < computed_->results.size(); ++p) {
      write_obj(std::filesystem::path(folder) / (pose_names_[p] + ".obj"), Mesh{computed_->results[p], sides_[1]->rest.triangles});
    }
    status_ = "Wrote " + counted(computed_->results.size(), "mesh", "meshes") + " to " + folder;
    print_json_line({{"event", "sequence exported"}, {"folder", folder}, {"count", computed_->results.size()}});
  } catch (const std::exception& error) {
    error_ = error.what();
  }
}

// ---- panel and overlays ---------------------------------------------------------------------------

}  // namespace hdeform::cli
