#include "gui/input_queue.h"

#include <GLFW/glfw3.h>
#include <imgui.h>

namespace hdeform::cli {
namespace {

bool is_change(InputEvent::Kind kind, int action) {
  return (kind == InputEvent::Kind::Key || kind == InputEvent::Kind::Button) && (action == GLFW_PRESS || action == GLFW_RELEASE);
}

}  // namespace

std::vector<InputEvent> InputQueue::take_frame() {
  std::vector<InputEvent> frame;
  std::array<bool, 512> key_changed{};
  std::array<bool, 8> button_changed{};
  bool any_key_changed = false, any_button_changed = false, text = false, moved = false, scrolled = false;
  while (!events_.empty()) {
    const InputEvent& event = events_.front();
    switch (event.kind) {
      case InputEvent::Kind::Key: {
        const bool known = event.code >= 0 && event.code < static_cast<int>(keys_down_.size());
        const auto k = static_cast<std::size_t>(known ? event.code : 0);
        const bool changes = known && is_change(event.kind, event.action) && keys_down_[k] != (event.action == GLFW_PRESS);
        if (changes && (key_changed[k] || text || any_button_changed)) return frame;
        if (changes) {
          keys_down_[k] = event.action == GLFW_PRESS;
          key_changed[k] = any_key_changed = true;
        }
        break;
      }
      case InputEvent::Kind::Button: {
        const bool known = event.code >= 0 && event.code < static_cast<int>(buttons_down_.size());
        const auto b = static_cast<std::size_t>(known ? event.code : 0);
        const bool changes = known && is_change(event.kind, event.action) && buttons_down_[b] != (event.action == GLFW_PRESS);
        if (changes && (button_changed[b] || scrolled)) return frame;
        if (changes) {
          buttons_down_[b] = event.action == GLFW_PRESS;
          button_changed[b] = any_button_changed = true;
        }
        break;
      }
      case InputEvent::Kind::Character:
        if (any_key_changed || any_button_changed || moved || scrolled) return frame;
        text = true;
        break;
      case InputEvent::Kind::Move:
        if (any_button_changed || any_key_changed || text || scrolled) return frame;
        moved = true;
        break;
      case InputEvent::Kind::Scroll:
        if (any_button_changed || moved) return frame;
        scrolled = true;
        break;
    }
    frame.push_back(event);
    events_.pop_front();
  }
  return frame;
}

void configure_imgui_keys() {
  ImGuiIO& io = ImGui::GetIO();
  io.KeyMap[ImGuiKey_Tab] = GLFW_KEY_TAB;
  io.KeyMap[ImGuiKey_LeftArrow] = GLFW_KEY_LEFT;
  io.KeyMap[ImGuiKey_RightArrow] = GLFW_KEY_RIGHT;
  io.KeyMap[ImGuiKey_UpArrow] = GLFW_KEY_UP;
  io.KeyMap[ImGuiKey_DownArrow] = GLFW_KEY_DOWN;
  io.KeyMap[ImGuiKey_PageUp] = GLFW_KEY_PAGE_UP;
  io.KeyMap[ImGuiKey_PageDown] = GLFW_KEY_PAGE_DOWN;
  io.KeyMap[ImGuiKey_Home] = GLFW_KEY_HOME;
  io.KeyMap[ImGuiKey_End] = GLFW_KEY_END;
  io.KeyMap[ImGuiKey_Insert] = GLFW_KEY_INSERT;
  io.KeyMap[ImGuiKey_Delete] = GLFW_KEY_DELETE;
  io.KeyMap[ImGuiKey_Backspace] = GLFW_KEY_BACKSPACE;
  io.KeyMap[ImGuiKey_Space] = GLFW_KEY_SPACE;
  io.KeyMap[ImGuiKey_Enter] = GLFW_KEY_ENTER;
  io.KeyMap[ImGuiKey_Escape] = GLFW_KEY_ESCAPE;
  io.KeyMap[ImGuiKey_KeyPadEnter] = GLFW_KEY_KP_ENTER;
  io.KeyMap[ImGuiKey_A] = GLFW_KEY_A;
  io.KeyMap[ImGuiKey_C] = GLFW_KEY_C;
  io.KeyMap[ImGuiKey_V] = GLFW_KEY_V;
  io.KeyMap[ImGuiKey_X] = GLFW_KEY_X;
  io.KeyMap[ImGuiKey_Y] = GLFW_KEY_Y;
  io.KeyMap[ImGuiKey_Z] = GLFW_KEY_Z;
}

void ImGuiInputFeed::apply(std::span<const InputEvent> events) {
  ImGuiIO& io = ImGui::GetIO();
  for (const InputEvent& event : events) {
    switch (event.kind) {
      case InputEvent::Kind::Key:
        if (event.code >= 0 && event.code < static_cast<int>(IM_ARRAYSIZE(io.KeysDown))) {
          if (event.action == GLFW_PRESS) io.KeysDown[event.code] = true;
          if (event.action == GLFW_RELEASE) io.KeysDown[event.code] = false;
        }
        break;
      case InputEvent::Kind::Button:
        if (event.code >= 0 && event.code < static_cast<int>(buttons_down_.size())) {
          if (event.action == GLFW_PRESS) buttons_down_[static_cast<std::size_t>(event.code)] = true;
          if (event.action == GLFW_RELEASE) buttons_down_[static_cast<std::size_t>(event.code)] = false;
        }
        break;
      case InputEvent::Kind::Character:
        if (event.character > 0 && event.character <= IM_UNICODE_CODEPOINT_MAX) io.AddInputCharacter(event.character);
        break;
      case InputEvent::Kind::Move:
        have_position_ = true;
        x_ = static_cast<float>(event.x);
        y_ = static_cast<float>(event.y);
        break;
      case InputEvent::Kind::Scroll:
        io.MouseWheelH += static_cast<float>(event.x);
        io.MouseWheel += static_cast<float>(event.y);
        break;
    }
  }
  io.KeyCtrl = io.KeysDown[GLFW_KEY_LEFT_CONTROL] || io.KeysDown[GLFW_KEY_RIGHT_CONTROL];
  io.KeyShift = io.KeysDown[GLFW_KEY_LEFT_SHIFT] || io.KeysDown[GLFW_KEY_RIGHT_SHIFT];
  io.KeyAlt = io.KeysDown[GLFW_KEY_LEFT_ALT] || io.KeysDown[GLFW_KEY_RIGHT_ALT];
  io.KeySuper = io.KeysDown[GLFW_KEY_LEFT_SUPER] || io.KeysDown[GLFW_KEY_RIGHT_SUPER];
  for (std::size_t b = 0; b < buttons_down_.size() && b < IM_ARRAYSIZE(io.MouseDown); ++b) io.MouseDown[b] = buttons_down_[b];
  if (have_position_) io.MousePos = ImVec2(x_, y_);
}

}  // namespace hdeform::cli
