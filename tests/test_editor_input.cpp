// The editor's input path without a window: the event queue that hands Dear ImGui one frame's
// worth at a time, and the panel's pose fields, driven through a headless ImGui context exactly
// as the editor's frame drives them (events, then NewFrame, widgets, Render).
#include <GLFW/glfw3.h>
#include <gtest/gtest.h>
#include <imgui.h>

#include <algorithm>
#include <map>
#include <string>

#include "gui/input_queue.h"
#include "gui/pose_editor.h"

namespace hdeform::cli {
namespace {

InputEvent key(int code, int action) { return {.kind = InputEvent::Kind::Key, .code = code, .action = action}; }
InputEvent character(unsigned c) { return {.kind = InputEvent::Kind::Character, .character = c}; }
InputEvent button(int action) { return {.kind = InputEvent::Kind::Button, .code = GLFW_MOUSE_BUTTON_LEFT, .action = action}; }
InputEvent move(float x, float y) { return {.kind = InputEvent::Kind::Move, .x = x, .y = y}; }

// A key typed as a person (or xdotool) types it: press, its character, release.
void type(InputQueue& queue, int code, unsigned c) {
  queue.push(key(code, GLFW_PRESS));
  queue.push(character(c));
  queue.push(key(code, GLFW_RELEASE));
}

TEST(InputQueue, EachKeyAndButtonChangesAtMostOncePerFrameAndNothingIsLostOrReordered) {
  InputQueue queue;
  std::vector<InputEvent> pushed;
  const auto push = [&](const InputEvent& event) {
    queue.push(event);
    pushed.push_back(event);
  };
  for (int k = 0; k < 3; ++k) {  // three quick Backspaces
    push(key(GLFW_KEY_BACKSPACE, GLFW_PRESS));
    push(key(GLFW_KEY_BACKSPACE, GLFW_RELEASE));
  }
  push(move(10, 10));
  push(button(GLFW_PRESS));  // a double click
  push(button(GLFW_RELEASE));
  push(button(GLFW_PRESS));
  push(button(GLFW_RELEASE));
  push(key(GLFW_KEY_1, GLFW_PRESS));
  push(character('1'));
  push(key(GLFW_KEY_1, GLFW_REPEAT));
  push(key(GLFW_KEY_1, GLFW_RELEASE));
  std::vector<InputEvent> delivered;
  int frames = 0;
  while (!queue.empty()) {
    const auto frame = queue.take_frame();
    ASSERT_FALSE(frame.empty()) << "a frame must make progress";
    ++frames;
    std::map<std::pair<int, int>, int> changes;  // (kind, code) -> changes this frame
    bool key_or_button_changed = false;
    for (const InputEvent& event : frame) {
      if (event.kind == InputEvent::Kind::Character) {
        EXPECT_FALSE(key_or_button_changed) << "text in the same frame as the key change before it";
      }
      if ((event.kind == InputEvent::Kind::Key || event.kind == InputEvent::Kind::Button) && event.action != GLFW_REPEAT) {
        EXPECT_EQ(++changes[std::pair(static_cast<int>(event.kind), event.code)], 1) << "a key or button changed twice in one frame";
        key_or_button_changed = true;
      }
      delivered.push_back(event);
    }
  }
  ASSERT_EQ(delivered.size(), pushed.size());
  for (std::size_t k = 0; k < pushed.size(); ++k) {
    EXPECT_EQ(delivered[k].kind, pushed[k].kind) << k;
    EXPECT_EQ(delivered[k].code, pushed[k].code) << k;
    EXPECT_EQ(delivered[k].action, pushed[k].action) << k;
  }
  EXPECT_GE(frames, 6 + 4 + 2);  // each Backspace press and release, each button change, the key
}

class HeadlessImGui : public ::testing::Test {
 protected:
  void SetUp() override {
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(800, 600);
    io.DeltaTime = 1.0f / 30.0f;
    unsigned char* pixels = nullptr;
    int width = 0, height = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);
    configure_imgui_keys();
  }
  void TearDown() override { ImGui::DestroyContext(); }

  // One frame as the editor runs it; `widgets` draws inside a window at the top left. Returns
  // whether the frame's key presses would have reached the shortcuts (the editor dispatches
  // them only while ImGui does not want the keyboard).
  template <class Widgets>
  bool frame(std::span<const InputEvent> events, Widgets widgets) {
    feed.apply(events);
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(400, 300));
    ImGui::Begin("panel", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoTitleBar);
    widgets();
    ImGui::End();
    ImGui::Render();
    return !ImGui::GetIO().WantCaptureKeyboard;
  }

  ImGuiInputFeed feed;
};

// The case: double click Move X, type 10, Enter. Fed a frame at a time, the field opens
// for typing, takes both digits (no shortcut sees them), and the edit finishes once, with 10.
TEST_F(HeadlessImGui, ADoubleClickedFieldTakesTheTypedValueAndFinishesOneEdit) {
  PoseFields fields;
  ImVec2 move_field;
  int finished = 0;
  bool digit_reached_shortcuts = false;
  const auto widgets = [&] {
    move_field = ImGui::GetCursorScreenPos();
    const PoseFieldsEdit edit = pose_fields(fields, 0.01f);
    finished += edit.finished ? 1 : 0;
  };
  frame({}, widgets);
  InputQueue queue;
  queue.push(move(move_field.x + 12, move_field.y + 6));
  for (int click = 0; click < 2; ++click) {
    queue.push(button(GLFW_PRESS));
    queue.push(button(GLFW_RELEASE));
  }
  type(queue, GLFW_KEY_1, '1');
  type(queue, GLFW_KEY_0, '0');
  queue.push(key(GLFW_KEY_ENTER, GLFW_PRESS));
  queue.push(key(GLFW_KEY_ENTER, GLFW_RELEASE));
  for (int k = 0; k < 60 && !queue.empty(); ++k) {
    const auto events = queue.take_frame();
    const bool digit = std::any_of(events.begin(), events.end(), [](const InputEvent& e) {
      return e.kind == InputEvent::Kind::Key && e.action == GLFW_PRESS && (e.code == GLFW_KEY_1 || e.code == GLFW_KEY_0);
    });
    const bool shortcuts = frame(events, widgets);
    digit_reached_shortcuts |= digit && shortcuts;
  }
  frame({}, widgets);
  EXPECT_TRUE(queue.empty());
  EXPECT_EQ(fields.shift.x(), 10.0);
  EXPECT_EQ(fields.shift.y(), 0.0);
  EXPECT_EQ(finished, 1);
  EXPECT_FALSE(digit_reached_shortcuts);
}

// What the queue is for: the same burst given to ImGui in a single frame (as its GLFW backend
// did) loses the double click, so the field never opens and the digits go to the shortcuts.
TEST_F(HeadlessImGui, TheSameBurstInOneFrameLosesTheDoubleClick) {
  PoseFields fields;
  ImVec2 move_field;
  const auto widgets = [&] {
    move_field = ImGui::GetCursorScreenPos();
    pose_fields(fields, 0.01f);
  };
  frame({}, widgets);
  const InputEvent burst[] = {move(move_field.x + 12, move_field.y + 6), button(GLFW_PRESS), button(GLFW_RELEASE), button(GLFW_PRESS),
                              button(GLFW_RELEASE)};
  frame(burst, widgets);
  const InputEvent digits[] = {key(GLFW_KEY_1, GLFW_PRESS), character('1')};
  EXPECT_TRUE(frame(digits, widgets)) << "the digit would have reached the shortcuts";
  EXPECT_EQ(fields.shift.x(), 0.0);
}

TEST_F(HeadlessImGui, QuickBackspacesAreEachSeen) {
  char text[32] = "abcd";
  ImVec2 box;
  const auto widgets = [&] {
    box = ImGui::GetCursorScreenPos();
    ImGui::InputText("path", text, sizeof text);
  };
  frame({}, widgets);
  InputQueue queue;
  queue.push(move(box.x + 150, box.y + 6));  // the end of the text
  queue.push(button(GLFW_PRESS));
  queue.push(button(GLFW_RELEASE));
  queue.push(key(GLFW_KEY_END, GLFW_PRESS));
  queue.push(key(GLFW_KEY_END, GLFW_RELEASE));
  for (int k = 0; k < 3; ++k) {
    queue.push(key(GLFW_KEY_BACKSPACE, GLFW_PRESS));
    queue.push(key(GLFW_KEY_BACKSPACE, GLFW_RELEASE));
  }
  for (int k = 0; k < 60 && !queue.empty(); ++k) frame(queue.take_frame(), widgets);
  frame({}, widgets);
  EXPECT_STREQ(text, "a");
}

TEST_F(HeadlessImGui, AnAxisTypedToZeroLengthIsRefused) {
  PoseFields fields;
  fields.axis = Eigen::Vector3d::UnitY();
  ImVec2 start;
  bool changed = false;
  const auto widgets = [&] {
    start = ImGui::GetCursorScreenPos();
    changed |= pose_fields(fields, 0.01f).changed;
  };
  frame({}, widgets);
  const float row = ImGui::GetFrameHeightWithSpacing();
  InputQueue queue;
  // Type 0 into the Axis field's y (the second of three components).
  queue.push(move(start.x + 0.65f * 400 * 0.5f, start.y + row + 6));
  queue.push(button(GLFW_PRESS));
  queue.push(button(GLFW_RELEASE));
  queue.push(button(GLFW_PRESS));
  queue.push(button(GLFW_RELEASE));
  type(queue, GLFW_KEY_0, '0');
  queue.push(key(GLFW_KEY_ENTER, GLFW_PRESS));
  queue.push(key(GLFW_KEY_ENTER, GLFW_RELEASE));
  for (int k = 0; k < 60 && !queue.empty(); ++k) frame(queue.take_frame(), widgets);
  frame({}, widgets);
  EXPECT_TRUE(changed) << "the typed 0 reached the field";
  EXPECT_EQ(fields.axis, Eigen::Vector3d::UnitY());
}

}  // namespace
}  // namespace hdeform::cli
