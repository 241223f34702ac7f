// The editor's frame on the device: the scene drawn (whole, in slices, or kept), the panel over
// it, presentation, screenshots, and the frame times the profiler and the statistics read.
#include "gui/editor_app_parts.h"

namespace hdeform::cli::gui {

void EditorApp::render(ImDrawData* draw_data) {
  if (document_ && document_->last_update_ms() != last_update_seen_) {
    last_update_seen_ = document_->last_update_ms();
    statistics_.note_update(last_update_seen_);
  }
  panel_behind_picture_ = false;  // this frame's panel was made after the last picture was completed
  engine::FrameSlots::Slot& slot = slots_->begin();
  const auto now = Clock::now();
  note_finished_frames();
  uint32_t image = 0;
  if (!target_->acquire(slot.image_available, image)) return;  // minimised or rebuilt: draw next time
  const VkExtent2D extent = target_->extent();
  bool moving = false;
  if (mode_ == Mode::Transfer) {
    transfer_->prepare(slot.index, extent, kPanelWidth * ImGui::GetIO().DisplayFramebufferScale.x);
  } else {
    moving = motion_detail_.note_frame(now, view_motion(), [&] { return document_ && document_->settled(); });
    camera_.covered_left = panel_fraction();  // the window may have been resized
    engine::RenderSettings frame_settings = settings_;
    frame_settings.proxy = motion_detail_.proxy(now);
    renderer_->prepare(slot.index, camera_, frame_settings, extent);
    motion_detail_.note_drawn(frame_settings.proxy || renderer_->prepared_proxy());
    shown_tag_ = renderer_->drawn_geometry_tag();
  }
  // The scene is drawn again only when it changed: while only the panel or a progress line does, a
  // frame of a scan of millions of triangles on a CPU device would take seconds of the cores the
  // solver is using (the 13M Buddha on lavapipe: 2 to 4 s a frame). A large picture is drawn in
  // slices over several frames (scene_slices.h), the last whole one shown meanwhile; a change
  // before its last slice starts it again.
  // (The transfer views' meshes are small; their scene is drawn whole every frame.)
  const bool transfer = mode_ == Mode::Transfer;
  const engine::SwapchainTarget::SceneBuild build = target_->scene_build();
  const SceneState scene{.same_scene = !transfer && !scene_shows_transfer_ && renderer_->prepared_as_before(),
                         .shown = target_->scene_kept(),
                         .next_slice = build.next,
                         .slices = build.slices,
                         .ramp = scene_ramp_,
                         .moving = moving,
                         .triangles = transfer ? 0 : renderer_->prepared_triangles()};
  if (const auto slice = next_scene_slice(scene, target_->slices_supported() ? slice_triangles_ : 0)) {
    const trace::Scope traced(slice->count == 1 ? "scene pass" : "scene pass, a slice", "frame");
    target_->begin_scene(slot.commands, slice->index, slice->count);
    scene_ramp_ = slice->ramp;
    if (transfer) transfer_->record(slot.commands, slot.index);
    else renderer_->record(slot.commands, slot.index, extent, {slice->index, slice->count, slice->ramp});
    target_->end_scene(slot.commands);
    // This frame's panel was made before the picture was complete: the next one says so.
    panel_behind_picture_ = slice->count > 1 && target_->scene_build().slices == 0;
    scene_shows_transfer_ = transfer;
    ++scene_frames_;
  }
  ++frames_drawn_;
  target_->begin(slot.commands, image);
  // A screenshot is of the whole picture: while one is being built, the frame that completes it.
  const bool screenshot = screenshot_requested_ && target_->scene_build().slices == 0;
  if (!view_only_screenshot()) ImGui_ImplVulkan_RenderDrawData(draw_data, slot.commands);
  target_->end(slot.commands, image, screenshot);
  const std::uint64_t frame = slots_->submit(slot, slot.image_available, target_->render_finished(image));
  last_submitted_frame_ = frame;
  statistics_.note_submitted(frame, shown_tag_, waited_idle_, now);
  waited_idle_ = false;
  target_->present(image);
  if (screenshot) {
    slots_->wait_all();
    write_screenshot(target_->read_last_image());
    screenshot_requested_ = false;
  }
}

MotionDetail::Motion EditorApp::view_motion() {
  // A handle dragged, or a brush stroke: each of its frames shows new paint, and a stroke painted
  // at one frame a second (the 3.3M Buddha on lavapipe) is a brush that lags its pointer. A lasso
  // changes only what is drawn over the kept scene.
  const bool pointer_drag = dragging_ && !(is_paint_tool(tools_.tool) && tools_.lasso);
  // A new solve, or a refinement iteration of the same request (a settling shape moves too).
  const engine::GeometrySnapshot* newest = exchange_ ? exchange_->acquire() : nullptr;
  const bool new_solve = (document_ && document_->last_published_request() != shown_tag_) ||
                         (newest != nullptr && newest->version != renderer_->drawn_geometry_version());
  if (pointer_drag || camera_drag_ || ImGui::GetIO().MouseWheel != 0.0f) return MotionDetail::Motion::Input;
  // (A settled shape's solve is drawn whole at once, MotionDetail::note_frame: settled() reads the
  // state recorded after the positions went out, so the snapshot the renderer takes next is that
  // shape.)
  return new_solve ? MotionDetail::Motion::Solve : MotionDetail::Motion::None;
}

void EditorApp::take_profile() {
  if (document_) {
    for (const auto& timings : document_->take_update_timings()) profiler_.add_update(timings);
    for (const auto& timings : document_->take_refinement_timings()) profiler_.add_refinement(timings);
  }
  if (!slots_->has_device_times()) {
    for (const auto& [frame, cpu_ms] : frame_work_) profiler_.add_frame(cpu_ms, 0.0);
    frame_work_.clear();
    return;
  }
  for (const auto& device : slots_->take_device_times()) {
    const auto it = std::find_if(frame_work_.begin(), frame_work_.end(), [&](const auto& work) { return work.first == device.frame; });
    if (it == frame_work_.end()) continue;
    profiler_.add_frame(it->second, device.milliseconds);
    frame_work_.erase(frame_work_.begin(), it + 1);
  }
  while (frame_work_.size() > 16) frame_work_.pop_front();
}

void EditorApp::note_frame_work(double cpu_ms) {
  if (last_submitted_frame_ != 0) frame_work_.emplace_back(last_submitted_frame_, cpu_ms);
  last_submitted_frame_ = 0;
}

void EditorApp::note_finished_frames() {
  for (const auto& completion : slots_->take_completions()) statistics_.note_finished(completion.frame, completion.time);
}

void EditorApp::write_screenshot(const engine::Pixels& pixels) {
  const auto path = std::filesystem::path(options_.screenshot_dir) / ("screenshot-" + std::to_string(++screenshots_) + ".png");
  try {
    engine::write_png(path, pixels);
    status_ = "Screenshot " + path.string();
    print_json_line({{"event", "screenshot"}, {"path", path.string()}});
  } catch (const std::exception& error) {
    error_message_ = error.what();
  }
}

}  // namespace hdeform::cli::gui
