#pragma once
// The window's input as a queue of events, handed to Dear ImGui one frame's worth at a time.
//
// Debian 12's ImGui (1.86) reads key and mouse-button state once per frame, so a press and its
// release between two frames are never seen: a quick tap of Backspace was dropped while the
// editor idled, and a double click that landed within one frame was a single click (so a
// numeric field never opened for typing, and the digits typed next went to the shortcuts). Here
// each key or button changes at most once per frame and later events wait, in order, for the
// next frames; text waits for the frame after a key or button change, so the characters typed
// after the click that opens a field reach the field (what ImGui 1.87 later called trickling).
#include <array>
#include <chrono>
#include <deque>
#include <span>
#include <vector>

namespace hdeform::cli {

struct InputEvent {
  enum class Kind { Key, Character, Button, Move, Scroll };
  Kind kind = Kind::Move;
  int code = 0;    // Key: the GLFW key; Button: the GLFW mouse button
  int action = 0;  // Key and Button: GLFW_RELEASE (0), GLFW_PRESS (1) or GLFW_REPEAT (2)
  int mods = 0;    // Key: GLFW modifier bits
  double x = 0.0, y = 0.0;  // Move: the cursor in window coordinates; Scroll: the offsets
  unsigned character = 0;   // Character: a Unicode code point
  std::chrono::steady_clock::time_point time{};
};

class InputQueue {
 public:
  void push(const InputEvent& event) { events_.push_back(event); }
  bool empty() const { return events_.empty(); }
  // The events of the next frame, oldest first, ending before the first one that would change a
  // key or button already changed in this frame (or that follows such a change, for text and
  // moves); an event that changes nothing (a repeat, a release of a key never pressed here)
  // never ends a frame.
  std::vector<InputEvent> take_frame();

 private:
  std::deque<InputEvent> events_;
  std::array<bool, 512> keys_down_{};
  std::array<bool, 8> buttons_down_{};
};

// Dear ImGui's side, without its GLFW backend's input callbacks (the editor installs its own,
// which fill the queue): the key map, once; then each frame's events, after the backend's
// NewFrame (which polls the buttons and the cursor: what the queue says replaces that).
void configure_imgui_keys();
class ImGuiInputFeed {
 public:
  void apply(std::span<const InputEvent> events);

 private:
  std::array<bool, 8> buttons_down_{};
  bool have_position_ = false;
  float x_ = 0.0f, y_ = 0.0f;
};

}  // namespace hdeform::cli
