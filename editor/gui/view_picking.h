#pragma once
// Picking on what a view shows, the same in both editor modes: a MeshPicker over the mesh's
// triangles, refitted when the geometry on screen changes (for the brush's outline at most a few
// times a second), so that a click hits the deformed shape the user sees. It is built ahead of
// need (prepare()) where the editor has cores to spare, else on first use.
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/mesh.h"
#include "hdeform/trace.h"
#include "model/background_task.h"
#include "model/mesh_picker.h"

namespace hdeform::cli {

class ViewPicker {
 public:
  // Starts building the picker for `rest` (the mesh's rest shape) on a thread of its own, so that
  // the first pick (the brush's outline as the pointer enters the view) does not stall a frame for
  // the build: half a second at 3.3 million triangles, two at 13 million. The shape on screen is
  // a refit away, which the first follow() makes: copying it here for the build held the main
  // thread for 0.57 s at 3.3 million triangles.
  void prepare(std::shared_ptr<const Mesh> rest) {
    if (picker_ || building_.running()) return;
    building_version_ = 0;  // no publication's (they count from 1)
    building_.start("Preparing picking", [rest = std::move(rest)] {
      const trace::Scope traced("picker (bounding boxes)", "set-up");
      return std::make_unique<MeshPicker>(rest->triangles, rest->positions);
    });
  }
  // Built or being built.
  bool prepared() const { return picker_ != nullptr || building_.running(); }

  // What a pick needs: the shape on screen now (a pick that paints or selects), or a recent one
  // (the brush's outline, drawn every frame), for which the picker is refitted at most once per
  // outline lag. While the refinement settles, each of its iterations shows a new shape, and a
  // refit for each outline took 40–110 ms of the frame at 3.3 million triangles, beside the
  // refinement.
  enum class Need { Exact, Outline };
  static constexpr std::chrono::milliseconds kOutlineLag{250};

  explicit ViewPicker(std::chrono::milliseconds outline_lag = kOutlineLag) : outline_lag_(outline_lag) {}

  // The picker for `shown` (the renderer's newest snapshot of a mesh with `triangles`), or nullptr
  // while nothing is shown. Waits for a build prepare() started.
  MeshPicker* follow(const Eigen::MatrixXi& triangles, const engine::GeometrySnapshot* shown, Need need = Need::Exact) {
    if (shown == nullptr) return nullptr;
    if (building_.running()) {
      auto outcome = building_.take();
      if (outcome.result) {
        picker_ = std::move(*outcome.result);
        version_ = building_version_;
        refitted_at_.reset();  // built on the rest shape, never on one shown: even the outline refits
      }
    }
    if (!picker_) {
      const trace::Scope traced("picker (bounding boxes)", "input");
      picker_ = std::make_unique<MeshPicker>(triangles, shown->position_normal);
      refitted_at_ = std::chrono::steady_clock::now();
    } else if (version_ != shown->version) {
      if (need == Need::Outline && refitted_at_ && std::chrono::steady_clock::now() - *refitted_at_ < outline_lag_) return picker_.get();
      {
        const trace::Scope traced("picker (refit)", "input");
        picker_->refit(shown->position_normal);
      }
      refitted_at_ = std::chrono::steady_clock::now();
    }
    version_ = shown->version;
    return picker_.get();
  }
  // The picker of the last follow() that found something shown (nullptr before).
  MeshPicker* current() const { return picker_.get(); }
  // Another mesh: the next follow() builds anew.
  void reset() {
    building_.abandon();
    picker_.reset();
  }

 private:
  std::unique_ptr<MeshPicker> picker_;
  std::uint64_t version_ = 0;
  std::chrono::milliseconds outline_lag_;
  // When the picker's shape was last made one shown; none for one built on the rest shape. (Not
  // the clock's epoch: steady_clock counts from boot, so a machine up for less than the lag would
  // take the rest shape for a recent one.)
  std::optional<std::chrono::steady_clock::time_point> refitted_at_;
  BackgroundTask<std::unique_ptr<MeshPicker>> building_;
  std::uint64_t building_version_ = 0;
};

}  // namespace hdeform::cli
