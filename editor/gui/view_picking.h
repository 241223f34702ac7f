#pragma once
// Picking on what a view shows, the same in both editor modes: a MeshPicker over the mesh's
// triangles, built on first use and refitted whenever the geometry on screen changes, so that a
// click hits the deformed shape the user sees.
#include <cstdint>
#include <memory>

#include "hdeform/engine/geometry_exchange.h"
#include "model/mesh_picker.h"

namespace hdeform::cli {

class ViewPicker {
 public:
  // The picker for `shown` (the renderer's newest snapshot of a mesh with `triangles`), or nullptr
  // while nothing is shown.
  MeshPicker* follow(const Eigen::MatrixXi& triangles, const engine::GeometrySnapshot* shown) {
    if (shown == nullptr) return nullptr;
    if (!picker_) picker_ = std::make_unique<MeshPicker>(triangles, shown->position_normal);
    else if (version_ != shown->version) picker_->refit(shown->position_normal);
    version_ = shown->version;
    return picker_.get();
  }
  // The picker of the last follow() that found something shown (nullptr before).
  MeshPicker* current() const { return picker_.get(); }
  // Another mesh: the next follow() builds anew.
  void reset() { picker_.reset(); }

 private:
  std::unique_ptr<MeshPicker> picker_;
  std::uint64_t version_ = 0;
};

}  // namespace hdeform::cli
