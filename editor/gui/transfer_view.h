#pragma once
// The editor's transfer mode: the source mesh and the target mesh side by side, each in its own
// viewport and camera. Click a vertex on one and its counterpart on the other to make a marker
// pair; drag a marker to move it, Delete removes the selected pair, Ctrl+Z undoes; load and save
// marker files. Compute runs the transfer (paper §6 or §7) for every source pose on a worker
// thread; the sequence then plays, source pose and transferred target side by side.
#include <vulkan/vulkan.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "hdeform/engine/camera.h"
#include "hdeform/engine/render_targets.h"
#include "hdeform/engine/vulkan_context.h"
#include "hdeform/mesh.h"
#include "hdeform/transfer.h"
#include "model/background_task.h"
#include "model/marker_editor.h"
#include "model/transfer_state.h"
#include "gui/widgets.h"

struct ImVec2;

namespace hdeform::cli {

// The files transfer mode opens (paths, not yet read).
struct TransferPaths {
  std::string source_rest;
  std::string target;
  std::vector<std::string> poses;  // paths; a name with * or ? is a pattern in its folder
  std::string markers;             // loaded when it exists; where Save writes
  int source_column = 1;
};

class TransferView {
 public:
  // `up`: every mesh's up axis, or none: each mesh's guessed (engine::guess_up_axis).
  TransferView(const engine::VulkanContext& context, VkRenderPass render_pass, const engine::PassFormat& format, uint32_t frames_in_flight,
               std::optional<engine::UpAxis> up);
  ~TransferView();
  TransferView(const TransferView&) = delete;
  TransferView& operator=(const TransferView&) = delete;

  // Starts reading the meshes, poses and markers on a worker thread.
  void open(const TransferPaths& inputs);
  // A file dropped on the window at `cursor` (window coordinates): on the source's view it
  // becomes the source rest (and further files its poses), on the target's view the target.
  void drop(const std::vector<std::string>& paths, const ImVec2& cursor);

  // Each frame, on the UI thread, in this order.
  void poll();                                        // finished work, playback
  void draw_panel(const DialogKeys& keys);            // inside the side panel window
  void handle_mouse();                                // clicks, marker drags, cameras
  void handle_key(int key, int mods);                 // shortcuts (not when ImGui takes the keyboard)
  void draw_overlays();                               // marker numbers, the pending marker
  void prepare(uint32_t slot, VkExtent2D framebuffer, float panel_pixels);
  void record(VkCommandBuffer commands, uint32_t slot) const;

  // What the mode holds, for the recovery file (nothing before meshes are loaded), and a number
  // that changes whenever it does.
  std::optional<TransferState> state() const;
  std::uint64_t state_version() const { return markers_.version() + settings_version_; }
  // Opens the state's files, then puts back its markers, up axes and settings.
  void restore(const TransferState& state);
  bool restoring() const { return restoring_.has_value(); }

  // "12 marker pairs" when the pairs differ from those last loaded or saved, else "".
  std::string unsaved_markers() const;
  // Saves them where they were loaded from or last saved; false (and the Save as dialog opens)
  // when there is no such file yet or the save failed.
  bool save_markers_in_place();

  // Whether frames must keep coming (work in progress, playing).
  bool busy() const;
  // What runs in the background and for how long, for the progress overlay.
  std::optional<std::pair<std::string, double>> work() const;

 private:
  struct Side;
  struct Loaded;
  struct Computed;

  void install(std::unique_ptr<Loaded> loaded);
  void apply_restored(const TransferState& state);
  void set_up(int side, engine::UpAxis up);
  void start_compute();
  void show_frame(int frame);
  void publish_markers();
  void fit_cameras();
  void save_markers(const std::string& path);
  void export_sequence(const std::string& folder);
  int side_under(const ImVec2& pixel) const;
  std::optional<int> pick_vertex(int side, const ImVec2& pixel);
  std::optional<std::size_t> marker_near(int side, const ImVec2& pixel, float reach_pixels) const;
  ImVec2 project(int side, const Eigen::Vector3d& point) const;
  const Eigen::MatrixXd& shown_positions(int side) const;
  void add_or_complete(int side, int vertex);

  const engine::VulkanContext& context_;
  VkRenderPass render_pass_;
  engine::PassFormat format_;
  uint32_t frames_in_flight_;
  std::optional<engine::UpAxis> up_;
  std::unique_ptr<Side> sides_[2];  // 0: source, 1: target

  std::vector<Eigen::MatrixXd> poses_;
  std::vector<std::string> pose_names_;
  std::vector<std::string> pose_paths_;
  std::uint64_t settings_version_ = 0;       // loads, up axes, method and its settings
  std::optional<TransferState> restoring_;  // applied when the load it started finishes
  MarkerEditor markers_;
  std::uint64_t saved_markers_version_ = 0;  // the markers' version as loaded or last saved
  std::string markers_path_;
  // Loading other meshes drops the markers: with unsaved ones, it waits for the user's answer.
  std::optional<TransferPaths> asked_open_;
  void open_or_ask(const TransferPaths& inputs);
  int source_column_ = 1;

  // Marker editing.
  struct Pending {
    int side;
    int vertex;
  };
  std::optional<Pending> pending_;
  int selected_ = -1;
  // Which marker numbers are drawn: with a hundred pairs, all of them pile up unreadably.
  enum class MarkerLabels { Selected, All, None };
  MarkerLabels labels_ = MarkerLabels::Selected;
  struct Drag {
    std::size_t pair;
    int side;
    int vertex;
  };
  std::optional<Drag> drag_;
  int camera_side_ = -1;  // the view whose camera a right or middle drag turns

  // Transfer.
  int method_ = 0;  // 0 correspondence, 1 interpolation
  int top_n_ = 0;
  float mismatch_threshold_ = static_cast<float>(kDefaultMismatchThreshold);
  std::unique_ptr<Computed> computed_;
  std::uint64_t computed_markers_version_ = 0;
  bool stale() const;

  // Playback: -1 shows the rest shapes.
  int frame_ = -1;
  int shown_frame_ = -2;
  bool shown_results_ = false;
  bool playing_ = false;
  float frames_per_second_ = 12.0f;
  std::chrono::steady_clock::time_point last_advance_{};

  // Background work: one at a time.
  BackgroundTask<std::unique_ptr<Loaded>> load_;
  BackgroundTask<std::unique_ptr<Computed>> compute_;
  bool working() const;

  // Panel state.
  char source_path_[1024] = {};
  char target_path_[1024] = {};
  char poses_path_[4096] = {};
  char markers_file_[1024] = {};
  char dialog_path_[1024] = {};
  bool save_as_open_ = false;
  bool export_open_ = false;
  std::string status_;
  std::string error_;
};

}  // namespace hdeform::cli
