#pragma once
// Picking on what a view shows, the same in both editor modes: a MeshPicker over the mesh's
// triangles, refitted whenever the geometry on screen changes, so that a click hits the deformed
// shape the user sees. It is built ahead of need (prepare()) where the editor has cores to spare,
// else on first use.
#include <cstdint>
#include <memory>
#include <vector>

#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/trace.h"
#include "model/background_task.h"
#include "model/mesh_picker.h"

namespace hdeform::cli {

class ViewPicker {
 public:
  // Starts building the picker for `shown` on a thread of its own, so that the first pick (the
  // brush's outline as the pointer enters the view) does not stall a frame for the build: half a
  // second at 3.3 million triangles, two at 13 million.
  void prepare(const Eigen::MatrixXi& triangles, const engine::GeometrySnapshot& shown) {
    if (picker_ || building_.running()) return;
    building_version_ = shown.version;
    building_.start("Preparing picking", [triangles, positions = std::vector<float>(shown.position_normal.begin(), shown.position_normal.end())] {
      const trace::Scope traced("picker (bounding boxes)", "set-up");
      return std::make_unique<MeshPicker>(triangles, positions);
    });
  }
  // Built or being built.
  bool prepared() const { return picker_ != nullptr || building_.running(); }

  // The picker for `shown` (the renderer's newest snapshot of a mesh with `triangles`), or nullptr
  // while nothing is shown. Waits for a build prepare() started.
  MeshPicker* follow(const Eigen::MatrixXi& triangles, const engine::GeometrySnapshot* shown) {
    if (shown == nullptr) return nullptr;
    if (building_.running()) {
      auto outcome = building_.take();
      if (outcome.result) {
        picker_ = std::move(*outcome.result);
        version_ = building_version_;
      }
    }
    if (!picker_) {
      const trace::Scope traced("picker (bounding boxes)", "input");
      picker_ = std::make_unique<MeshPicker>(triangles, shown->position_normal);
    } else if (version_ != shown->version) {
      picker_->refit(shown->position_normal);
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
  BackgroundTask<std::unique_ptr<MeshPicker>> building_;
  std::uint64_t building_version_ = 0;
};

}  // namespace hdeform::cli
