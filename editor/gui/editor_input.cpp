// The editor window: keys, the mouse, painting, handle drags and the overlays drawn over the view.
#include "gui/editor_app_parts.h"

namespace hdeform::cli::gui {

void EditorApp::handle_keys() {
  // Screenshots work over dialogs too (a picture of what went wrong).
  if (pressed(GLFW_KEY_F12) || pressed(GLFW_KEY_F12, GLFW_MOD_SHIFT)) {
    screenshot_requested_ = true;
    screenshot_with_panel_ = pressed(GLFW_KEY_F12, GLFW_MOD_SHIFT);
  }
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantCaptureKeyboard) return;
  constexpr int kCtrl = GLFW_MOD_CONTROL;
  if (pressed(GLFW_KEY_T, kCtrl)) set_mode(mode_ == Mode::Transfer ? Mode::Edit : Mode::Transfer);
  if (pressed(GLFW_KEY_Q, kCtrl)) request_quit();
  if (pressed(GLFW_KEY_F1)) show_help_ = !show_help_;
  if (mode_ == Mode::Transfer) {
    for (const auto& press : frame_keys_) transfer_->handle_key(press.key, press.mods);
    return;
  }
  if (pressed(GLFW_KEY_Z, kCtrl)) undo();
  if (pressed(GLFW_KEY_Z, kCtrl | GLFW_MOD_SHIFT) || pressed(GLFW_KEY_Y, kCtrl)) redo();
  if (pressed(GLFW_KEY_S, kCtrl)) save(output_path_);
  if (pressed(GLFW_KEY_S, kCtrl | GLFW_MOD_SHIFT)) request_save_as();
  if (pressed(GLFW_KEY_O, kCtrl)) request_open();
  if (pressed(GLFW_KEY_DELETE, kCtrl) && document_ && document_->handle_count() > 0) {
    finish_action("remove handle " + std::to_string(document_->active_handle() + 1), [this] { document_->remove_handle(document_->active_handle()); });
  }
  if (!document_) return;
  if (pressed(GLFW_KEY_F)) adjust_camera(false);
  for (const auto& press : frame_keys_) tools_.press(press.key, press.mods);
  if (pressed(GLFW_KEY_I)) layer_action("invert", [this](Layer layer) { document_->invert(layer); });
  if (pressed(GLFW_KEY_EQUAL)) layer_action("grow", [this](Layer layer) { document_->grow(layer); });
  if (pressed(GLFW_KEY_MINUS)) layer_action("shrink", [this](Layer layer) { document_->shrink(layer); });
  if (pressed(GLFW_KEY_LEFT_BRACKET)) brush_radius_ /= 1.25f;
  if (pressed(GLFW_KEY_RIGHT_BRACKET)) brush_radius_ *= 1.25f;
  if (pressed(GLFW_KEY_N)) {
    document_->add_handle();
    tools_.tool = Tool::PaintHandle;
  }
  if (pressed(GLFW_KEY_TAB) && document_->handle_count() > 0) {
    document_->set_active_handle((document_->active_handle() + 1) % static_cast<int>(document_->handle_count()));
  }
  if (pressed(GLFW_KEY_0)) finish_action("reset the handles", [this] { document_->reset_poses(); });
  if (pressed(GLFW_KEY_A)) apply();
  if (pressed(GLFW_KEY_W)) settings_.wireframe = !settings_.wireframe;
  if (pressed(GLFW_KEY_H)) {
    settings_.show_field = !settings_.show_field;
    view_dirty_ = true;
  }
  if (pressed(GLFW_KEY_K)) settings_.show_classes = !settings_.show_classes;
  if (pressed(GLFW_KEY_P)) show_profiler_ = !show_profiler_;
}

bool EditorApp::pressed(int key, int mods) const {
  constexpr int kModifiers = GLFW_MOD_CONTROL | GLFW_MOD_SHIFT | GLFW_MOD_ALT;
  return std::any_of(frame_keys_.begin(), frame_keys_.end(), [&](const KeyPress& press) {
    return press.key == key && (press.mods & kModifiers) == mods;
  });
}

Eigen::ParametrizedLine<float, 3> EditorApp::cursor_ray(const ImVec2& cursor) const {
  const auto extent = target_->extent();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  return camera_.ray(cursor.x * scale.x, cursor.y * scale.y, static_cast<float>(extent.width), static_cast<float>(extent.height));
}

const engine::GeometrySnapshot* EditorApp::shown_snapshot() {
  const engine::GeometrySnapshot* shown = exchange_ ? exchange_->acquire() : nullptr;
  // A drag's answer holding the proxy's vertices alone is not the whole shape: nothing is, until
  // the whole one follows (the pipeline publishes it once the input rests). A settling shape with
  // the proxy's normals alone has every position: it is.
  return shown != nullptr && shown->only_vertices && !shown->every_position ? nullptr : shown;
}

const engine::GeometrySnapshot* EditorApp::shown_geometry(ViewPicker::Need need) {
  const engine::GeometrySnapshot* shown = shown_snapshot();
  if (shown != nullptr) picker_.follow(document_->rest().triangles, shown, need);
  return shown;
}

void EditorApp::handle_mouse() {
  if (!document_) return;
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 mouse = io.MousePos;
  const ImVec2 delta = io.MouseDelta;
  const bool over_view = !io.WantCaptureMouse;

  // A camera drag that began over the view goes on over the panel.
  const CameraGesture gesture = camera_gesture_now();
  if (over_view || camera_drag_) {
    apply_camera_gesture(camera_, gesture, {delta.x, delta.y}, io.DisplaySize.y, over_view ? io.MouseWheel : 0.0f);
    camera_drag_ = gesture != CameraGesture::None;
  }
  if (io.KeyAlt) return;

  if (ImGui::IsMouseClicked(ImGuiMouseButton_Left) && over_view) {
    dragging_ = true;
    stroke_.clear();
    drag_cursor_ = mouse;
    lay_out_gizmo();
    gizmo_drag_ = gizmo_.hit({mouse.x, mouse.y});
    if (tools_.connected_armed) {
      tools_.connected_armed = false;
      dragging_ = false;
      paint_connected(mouse);
      return;
    }
  }
  if (!dragging_) return;
  // A stroke follows every position the pointer reported, however many came in one frame (a
  // frame of a large mesh on a CPU device takes half a second); the first frame of a drag paints
  // where the button went down.
  const bool pressed_now = ImGui::IsMouseClicked(ImGuiMouseButton_Left);
  const std::span<const ImVec2> path = pressed_now ? std::span<const ImVec2>(&mouse, 1) : std::span<const ImVec2>(frame_pointer_path_);
  if (is_paint_tool(tools_.tool)) {
    if (tools_.lasso) extend_lasso(path);
    else if (pressed_now) paint_brush(mouse);
    else paint_brush_along(path);
  }
  if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) || !ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
    dragging_ = false;
    gizmo_drag_ = GizmoPart::None;
    if (is_paint_tool(tools_.tool) && tools_.lasso) paint_lasso();
    commit_action(is_paint_tool(tools_.tool) ? std::string(tools_.erase ? "erase " : "paint ") + layer_name()
                                       : lowercase_first(tool_name(tools_.tool)) + " " + std::to_string(document_->active_handle() + 1));
    return;
  }
  if (!is_paint_tool(tools_.tool)) continue_handle_drag(mouse, last_input_);
}

void EditorApp::extend_lasso(std::span<const ImVec2> path) {
  for (const ImVec2& point : path) {
    if (stroke_.empty() || std::hypot(stroke_.back().x - point.x, stroke_.back().y - point.y) > 3.0f) stroke_.push_back(point);
  }
}

void EditorApp::continue_handle_drag(const ImVec2& cursor, Clock::time_point event_time) {
  const ImVec2 delta(cursor.x - drag_cursor_.x, cursor.y - drag_cursor_.y);
  if (delta.x == 0.0f && delta.y == 0.0f) return;
  drag_handle(cursor, delta, event_time);
  drag_cursor_ = cursor;
}

std::optional<std::pair<ImVec2, float>> EditorApp::brush_on_screen(const ImVec2& mouse, ViewPicker::Need need) {
  if (shown_geometry(need) == nullptr) return std::nullopt;
  const auto ray = cursor_ray(mouse);
  const auto hit = picker_.current()->pick(ray);
  if (!hit && !tools_.paint_through) return std::nullopt;
  const Eigen::Vector3f point = hit ? hit->point : Eigen::Vector3f(ray.pointAt((camera_.target - camera_.position()).norm()));
  const Eigen::Vector3f right = (camera_.target - camera_.position()).cross(camera_.up_vector()).normalized();
  const ImVec2 centre = project(point);
  const ImVec2 edge = project(point + brush_radius_ * right);
  return std::pair{centre, std::hypot(edge.x - centre.x, edge.y - centre.y)};
}

void EditorApp::paint_brush(const ImVec2& mouse) {
  last_stamp_ = mouse;
  paint_stamps(std::span(&mouse, 1));
}

void EditorApp::paint_brush_along(std::span<const ImVec2> path) {
  if (path.empty()) return;
  // A stamp every half brush radius on screen (measured where the stroke last painted).
  const auto brush = brush_on_screen(last_stamp_);
  const float spacing = std::max(1.0f, 0.5f * (brush ? brush->second : 0.0f));
  std::vector<Eigen::Vector2f> points;
  for (const ImVec2& point : path) points.emplace_back(point.x, point.y);
  std::vector<ImVec2> stamps;
  for (const Eigen::Vector2f& stamp : stamps_along(Eigen::Vector2f(last_stamp_.x, last_stamp_.y), points, spacing)) stamps.emplace_back(stamp.x(), stamp.y());
  if (stamps.empty()) return;
  last_stamp_ = stamps.back();
  paint_stamps(stamps);
}

void EditorApp::paint_stamps(std::span<const ImVec2> stamps) {
  const auto* shown = shown_geometry();
  if (shown == nullptr) return;
  std::vector<int> vertices;
  if (tools_.paint_through) {
    // Everything under the brush's circles, front and back.
    const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
    std::vector<Eigen::Vector2f> centres;
    float radius = 0.0f;
    for (const ImVec2& stamp : stamps) {
      const auto brush = brush_on_screen(stamp);
      if (!brush) continue;
      centres.emplace_back(brush->first.x * scale.x, brush->first.y * scale.y);
      radius = brush->second * scale.x;
    }
    if (centres.empty()) return;
    const auto extent = target_->extent();
    vertices = vertices_in_screen_discs(shown->position_normal, centres, radius,
                                        camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)),
                                        static_cast<float>(extent.width), static_cast<float>(extent.height));
  } else {
    std::vector<Eigen::Vector3f> centres;
    for (const ImVec2& stamp : stamps) {
      if (const auto hit = picker_.current()->pick(cursor_ray(stamp))) centres.push_back(hit->point);
    }
    if (centres.empty()) return;
    vertices = vertices_in_balls(shown->position_normal, centres, brush_radius_);
  }
  document_->paint(vertices, layer_of(tools_.tool), tools_.erase);
  view_dirty_ = true;
  recovery_dirty_ = true;
}

void EditorApp::paint_lasso() {
  const auto* shown = shown_geometry();
  if (shown == nullptr || stroke_.size() < 3) return;
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  std::vector<Eigen::Vector2f> polygon;
  for (const auto& point : stroke_) polygon.emplace_back(point.x * scale.x, point.y * scale.y);
  const auto extent = target_->extent();
  const std::optional<Eigen::Vector3f> towards_viewer =
      tools_.paint_through ? std::nullopt : std::optional<Eigen::Vector3f>((camera_.position() - camera_.target).normalized());
  const auto vertices = vertices_in_lasso(shown->position_normal, polygon,
                                          camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)),
                                          static_cast<float>(extent.width), static_cast<float>(extent.height), towards_viewer);
  document_->paint(vertices, layer_of(tools_.tool), tools_.erase);
  stroke_.clear();
  view_dirty_ = true;
}

void EditorApp::paint_connected(const ImVec2& mouse) {
  if (!is_paint_tool(tools_.tool) || shown_geometry() == nullptr) return;
  const auto hit = picker_.current()->pick(cursor_ray(mouse));
  if (!hit) return;
  const auto vertices = connected_vertices(hit->vertex, document_->adjacency());
  finish_action(std::string(tools_.erase ? "erase " : "paint ") + "the connected part as " + layer_name(),
                [&] { document_->paint(vertices, layer_of(tools_.tool), tools_.erase); });
}

void EditorApp::drag_handle(const ImVec2& mouse, const ImVec2& delta, Clock::time_point event_time) {
  const int h = document_->active_handle();
  if (document_->handle_count() == 0 || document_->handle_size(h) == 0 || is_paint_tool(tools_.tool)) return;
  const HandleTransform& pose = document_->pose(h);
  DragStep step;
  step.from = cursor_ray(ImVec2(mouse.x - delta.x, mouse.y - delta.y));
  step.to = cursor_ray(mouse);
  step.cursor = Eigen::Vector2f(mouse.x, mouse.y);
  step.delta = Eigen::Vector2f(delta.x, delta.y);
  const Eigen::Vector3f eye = camera_.position();
  step.forward = (camera_.target - eye).normalized();
  step.right = step.forward.cross(camera_.up_vector()).normalized();
  step.up = step.right.cross(step.forward);
  const float depth = std::max((pose.pivot + pose.shift).cast<float>().dot(step.forward) - eye.dot(step.forward), 1e-6f);
  const float height = static_cast<float>(std::max(target_->extent().height, 1u)) / ImGui::GetIO().DisplayFramebufferScale.y;
  step.world_per_pixel = 2.0f * depth * std::tan(0.5f * camera_.fov_y) / height;
  step.project = [this](const Eigen::Vector3f& point) { return project_to_window(point); };
  step.ring_radius = 0.8f * gizmo_.length();
  const HandleTransform moved = drag_pose(pose, tools_, gizmo_drag_, step);
  document_->set_pose(h, moved.axis, moved.angle, moved.scale, moved.shift);
  note_pose_input(event_time);
  recovery_dirty_ = true;
}

std::optional<Eigen::Vector2f> EditorApp::project_to_window(const Eigen::Vector3f& point) const {
  const auto extent = target_->extent();
  const Eigen::Vector4f clip =
      camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)) * Eigen::Vector4f(point.x(), point.y(), point.z(), 1.0f);
  if (clip.w() <= 1e-6f) return std::nullopt;
  const ImVec2 p = project(point);
  return Eigen::Vector2f(p.x, p.y);
}

ImVec2 EditorApp::project(const Eigen::Vector3f& point) const {
  const auto extent = target_->extent();
  const Eigen::Vector4f clip =
      camera_.view_projection(static_cast<float>(extent.width) / static_cast<float>(extent.height)) * Eigen::Vector4f(point.x(), point.y(), point.z(), 1.0f);
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  return ImVec2((clip.x() / clip.w() * 0.5f + 0.5f) * static_cast<float>(extent.width) / scale.x,
                (clip.y() / clip.w() * 0.5f + 0.5f) * static_cast<float>(extent.height) / scale.y);
}

void EditorApp::draw_overlays() {
  if (!document_ || view_only_screenshot()) return;
  ImDrawList* draw = ImGui::GetBackgroundDrawList();  // under the panel and the dialogs
  const ImVec2 mouse = ImGui::GetIO().MousePos;
  if (is_paint_tool(tools_.tool)) {
    if (tools_.lasso && stroke_.size() > 1) draw->AddPolyline(stroke_.data(), static_cast<int>(stroke_.size()), IM_COL32(255, 230, 60, 255), 0, 1.5f);
    if (!tools_.lasso && !ImGui::GetIO().WantCaptureMouse) {
      if (const auto brush = brush_on_screen(mouse, ViewPicker::Need::Outline)) {
        const ImU32 color = tools_.erase ? IM_COL32(255, 80, 80, 255) : tools_.paint_through ? IM_COL32(120, 220, 255, 255) : IM_COL32(255, 255, 255, 220);
        draw->AddCircle(brush->first, brush->second, color, 48, 1.5f);
        if (tools_.paint_through) draw->AddCircle(brush->first, brush->second - 3.0f, color, 48, 1.0f);
      }
    }
    return;
  }
  const int h = document_->active_handle();
  if (document_->handle_count() == 0 || document_->handle_size(h) == 0) return;
  const HandleTransform& pose = document_->pose(h);
  const Eigen::Vector3f centre = (pose.pivot + pose.shift).cast<float>();
  const ImVec2 c = project(centre);
  lay_out_gizmo();
  // Under the panel and the dialogs: the background list.
  ImDrawList* under = ImGui::GetBackgroundDrawList();
  if (gizmo_.laid_out()) {
    const GizmoPart lit = gizmo_drag_ != GizmoPart::None ? gizmo_drag_ : ImGui::GetIO().WantCaptureMouse ? GizmoPart::None : gizmo_.hit({mouse.x, mouse.y});
    gizmo_.draw(under, lit);
  } else {
    under->AddCircle(c, 6.0f, IM_COL32(255, 255, 255, 255), 16, 2.0f);
  }
  char text[128];
  std::snprintf(text, sizeof text, "%s%s  %.1f°  ×%.2f", tool_name(tools_.tool), tools_.lock_text().c_str(), pose.angle * 180.0 / std::numbers::pi, pose.scale);
  under->AddText(ImVec2(c.x + 10, c.y + 8), IM_COL32(255, 255, 255, 255), text);
}

void EditorApp::lay_out_gizmo() {
  const int h = document_->active_handle();
  if ((tools_.tool != Tool::Grab && tools_.tool != Tool::Rotate) || document_->handle_count() == 0 || document_->handle_size(h) == 0) {
    gizmo_ = HandleGizmo{};
    return;
  }
  const HandleTransform& pose = document_->pose(h);
  const Eigen::Matrix3f axes = pose.rotation().toRotationMatrix().cast<float>();
  const ImVec2 size = ImGui::GetIO().DisplaySize;
  gizmo_.layout([this](const Eigen::Vector3f& point) { return project_to_window(point); }, (pose.pivot + pose.shift).cast<float>(), axes,
                0.08f * scene_size(), tools_.tool == Tool::Grab ? GizmoMode::Move : GizmoMode::Rotate, Eigen::Vector2f(kPanelWidth + 8.0f, 8.0f),
                Eigen::Vector2f(size.x - 8.0f, size.y - 8.0f));
}

}  // namespace hdeform::cli::gui
