#include "gui/edit_tools.h"

#include <GLFW/glfw3.h>

namespace hdeform::cli {

const char* tool_name(Tool tool) {
  switch (tool) {
    case Tool::PaintRoi: return "Paint region of interest";
    case Tool::PaintFixed: return "Paint fixed";
    case Tool::PaintHandle: return "Paint handle";
    case Tool::Grab: return "Move handle";
    case Tool::Rotate: return "Rotate handle";
    case Tool::Scale: return "Scale handle";
    case Tool::Twist: return "Twist handle";
  }
  return "";
}

bool is_paint_tool(Tool tool) { return tool == Tool::PaintRoi || tool == Tool::PaintFixed || tool == Tool::PaintHandle; }

Layer layer_of(Tool tool) {
  return tool == Tool::PaintRoi ? Layer::RegionOfInterest : tool == Tool::PaintFixed ? Layer::Fixed : Layer::Handle;
}

bool EditTools::press(int key, int mods) {
  const int modifiers = mods & (GLFW_MOD_CONTROL | GLFW_MOD_SHIFT | GLFW_MOD_ALT);
  const auto pick = [this](Tool picked) {
    axis_lock.reset();
    tool = picked;
    return true;
  };
  if (modifiers == GLFW_MOD_ALT && key == GLFW_KEY_Z) {
    paint_through = !paint_through;
    return true;
  }
  const bool shifted = modifiers == GLFW_MOD_SHIFT;
  if (modifiers != 0 && !shifted) return false;
  if (key == GLFW_KEY_X || key == GLFW_KEY_Y || key == GLFW_KEY_Z) {
    const int k = key == GLFW_KEY_X ? 0 : key == GLFW_KEY_Y ? 1 : 2;
    if (tool == Tool::Grab || tool == Tool::Rotate) {
      const bool plane = shifted && tool == Tool::Grab;
      const bool same = axis_lock == k && lock_plane == plane;
      axis_lock = same ? std::nullopt : std::optional<int>(k);
      lock_plane = plane;
      return true;
    }
    if (shifted) return false;
    twist_axis = k == 0 ? TwistAxis::X : k == 1 ? TwistAxis::Y : TwistAxis::Z;
    return true;
  }
  if (shifted) return false;
  switch (key) {
    case GLFW_KEY_1: return pick(Tool::PaintRoi);
    case GLFW_KEY_2: return pick(Tool::PaintFixed);
    case GLFW_KEY_3: return pick(Tool::PaintHandle);
    case GLFW_KEY_G: return pick(Tool::Grab);
    case GLFW_KEY_R: return pick(Tool::Rotate);
    case GLFW_KEY_S: return pick(Tool::Scale);
    case GLFW_KEY_T: return pick(Tool::Twist);
    case GLFW_KEY_V: twist_axis = TwistAxis::View; return true;
    case GLFW_KEY_E: erase = !erase; return true;
    case GLFW_KEY_L: lasso = !lasso; return true;
    case GLFW_KEY_C: connected_armed = true; return true;
    default: return false;
  }
}

std::string EditTools::lock_text() const {
  if (!axis_lock || (tool != Tool::Grab && tool != Tool::Rotate)) return "";
  const char* name[3] = {"x", "y", "z"};
  if (tool == Tool::Rotate) return std::string(" about ") + name[*axis_lock];
  return lock_plane ? std::string(" in the plane normal to ") + name[*axis_lock] : std::string(" along ") + name[*axis_lock];
}

}  // namespace hdeform::cli
