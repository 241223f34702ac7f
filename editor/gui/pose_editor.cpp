#include "gui/pose_editor.h"

#include <imgui.h>

#include <algorithm>

namespace hdeform::cli {

PoseFieldsEdit pose_fields(PoseFields& fields, float move_step) {
  float shift[3] = {static_cast<float>(fields.shift.x()), static_cast<float>(fields.shift.y()), static_cast<float>(fields.shift.z())};
  float axis[3] = {static_cast<float>(fields.axis.x()), static_cast<float>(fields.axis.y()), static_cast<float>(fields.axis.z())};
  auto degrees = static_cast<float>(fields.degrees);
  auto scale = static_cast<float>(fields.scale);
  PoseFieldsEdit edit;
  // Each field is asked on its own whether its edit ended: ImGui answers for the last item only.
  const auto field = [&edit](bool changed) {
    edit.changed |= changed;
    edit.finished |= ImGui::IsItemDeactivatedAfterEdit();
  };
  field(ImGui::DragFloat3("Move", shift, move_step));
  field(ImGui::DragFloat3("Axis", axis, 0.01f, -1.0f, 1.0f));
  field(ImGui::DragFloat("Angle°", &degrees, 0.5f));
  field(ImGui::DragFloat("Scale", &scale, 0.005f, 0.05f, 20.0f));
  edit.finished |= edit.changed && !ImGui::IsAnyItemActive();  // a change without an edit session
  if (edit.changed) {
    const Eigen::Vector3d new_axis(axis[0], axis[1], axis[2]);
    if (new_axis.norm() >= 1e-6) fields.axis = new_axis.normalized();
    fields.shift = Eigen::Vector3d(shift[0], shift[1], shift[2]);
    fields.degrees = degrees;
    fields.scale = std::clamp(static_cast<double>(scale), 0.05, 20.0);
  }
  return edit;
}

}  // namespace hdeform::cli
