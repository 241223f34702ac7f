#pragma once
// The edit mode's tools as state, free of any window: which tool is active, how the brush paints
// (erase, lasso, through to the back), the twist axis and the axis lock of the move and rotate
// tools (Blender's G/R then X/Y/Z). The editor hands it the frame's key presses; the panel and
// the drags read it.
#include <optional>
#include <string>

#include "model/document.h"

namespace hdeform::cli {

enum class Tool { PaintRoi, PaintFixed, PaintHandle, Grab, Rotate, Scale, Twist };
enum class TwistAxis { X, Y, Z, View };

const char* tool_name(Tool tool);
bool is_paint_tool(Tool tool);
Layer layer_of(Tool tool);  // for a paint tool

struct EditTools {
  Tool tool = Tool::Grab;
  TwistAxis twist_axis = TwistAxis::Z;
  bool erase = false;
  bool lasso = false;
  bool paint_through = false;
  bool connected_armed = false;     // C: the next click paints the connected part
  std::optional<int> axis_lock;     // 0–2: move along, or rotate about, that world axis only
  bool lock_plane = false;          // with axis_lock, move in the plane normal to it

  // A key press (a GLFW key, its Ctrl/Shift/Alt modifiers): returns whether it was the tools'.
  // 1/2/3 and G/R/S/T pick a tool (and drop the lock); X/Y/Z lock the move and rotate
  // tools to an axis (again: free; Shift+X/Y/Z: the plane, for moving) and set the twist axis
  // otherwise, V the view's; E, L, Alt+Z toggle erase, lasso, paint through; C arms Connected.
  bool press(int key, int mods);
  // " along x", " about y", " in the plane normal to z", or "" (for the handle's label).
  std::string lock_text() const;
};

}  // namespace hdeform::cli
