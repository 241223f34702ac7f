// The editor's input path without a window: the event queue that hands Dear ImGui one frame's
// worth at a time, and the panel's pose fields, driven through a headless ImGui context exactly
// as the editor's frame drives them (events, then NewFrame, widgets, Render).
#include <GLFW/glfw3.h>
#include <gtest/gtest.h>
#include <imgui.h>

#include <algorithm>
#include <map>
#include <numbers>
#include <string>

#include "gui/edit_tools.h"
#include "gui/gizmo.h"
#include "gui/handle_drag.h"
#include "gui/input_queue.h"
#include "gui/motion_detail.h"
#include "gui/pose_editor.h"
#include "gui/scene_slices.h"
#include "gui/view_navigation.h"

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

// The gizmo's arithmetic against closed forms, with the eye on the +z axis looking down.
Ray ray_through(const Eigen::Vector3f& point, const Eigen::Vector3f& eye = Eigen::Vector3f(0.3f, -0.2f, 10.0f)) {
  return Ray(eye, (point - eye).normalized());
}

// The proxy while the mesh moves, the whole mesh once it has rested for the rest time, and the
// event loop told when that is due; never the proxy when it is off.
TEST(MotionDetail, TheProxyWhileMovingTheMeshOnceAtRest) {
  using namespace std::chrono_literals;
  const MotionDetail::Clock::time_point start{};
  MotionDetail detail(250ms);
  detail.note_motion(start);
  EXPECT_FALSE(detail.proxy(start + 10ms)) << "off until a proxy is enabled";
  EXPECT_FALSE(detail.until_rest(start));
  detail.enable(true);
  EXPECT_TRUE(detail.proxy(start + 10ms));
  EXPECT_TRUE(detail.proxy(start + 249ms));
  EXPECT_FALSE(detail.proxy(start + 250ms));
  ASSERT_TRUE(detail.until_rest(start + 100ms));
  EXPECT_EQ(*detail.until_rest(start + 100ms), 150ms);
  EXPECT_EQ(*detail.until_rest(start + 400ms), 0ms) << "overdue: wake at once";
  detail.note_drawn(true);  // a proxy frame: the whole mesh still due
  EXPECT_TRUE(detail.until_rest(start + 100ms));
  detail.note_motion(start + 200ms);  // moving again: the rest starts over
  EXPECT_TRUE(detail.proxy(start + 400ms));
  detail.note_drawn(false);  // the whole mesh drawn: nothing due until the next motion
  EXPECT_FALSE(detail.until_rest(start + 400ms));
  EXPECT_FALSE(detail.proxy(start + 410ms));
  detail.note_motion(start + 500ms);
  detail.enable(false);
  EXPECT_FALSE(detail.proxy(start + 510ms));
  EXPECT_FALSE(detail.until_rest(start + 510ms));
}

// A frame's motion: the user's always waits out the rest, whatever the solver says; the solver's
// final shape ends it at once, shown as a new solve or in a frame while the rest waits out solves.
TEST(MotionDetail, TheSolversFinalShapeEndsTheRestTheUsersMotionWaitsItOut) {
  using namespace std::chrono_literals;
  using Motion = MotionDetail::Motion;
  const MotionDetail::Clock::time_point start{};
  MotionDetail detail(250ms);
  detail.enable(true);
  int asked = 0;
  const auto settled = [&] { ++asked; return true; };
  const auto unsettled = [&] { ++asked; return false; };

  EXPECT_TRUE(detail.note_frame(start, Motion::Input, settled)) << "a turn of the view";
  EXPECT_EQ(asked, 0) << "the user's motion does not ask";
  EXPECT_FALSE(detail.note_frame(start + 10ms, Motion::None, settled));
  EXPECT_EQ(asked, 0) << "nor does the rest after it";
  EXPECT_TRUE(detail.proxy(start + 10ms)) << "the rest after the user's motion is waited out";
  EXPECT_FALSE(detail.proxy(start + 250ms));

  EXPECT_TRUE(detail.note_frame(start + 300ms, Motion::Solve, unsettled)) << "a settling shape";
  EXPECT_TRUE(detail.proxy(start + 310ms));
  EXPECT_FALSE(detail.note_frame(start + 320ms, Motion::None, unsettled));
  EXPECT_TRUE(detail.proxy(start + 330ms));
  EXPECT_FALSE(detail.note_frame(start + 340ms, Motion::None, settled)) << "the final shape was recorded after it was shown";
  EXPECT_FALSE(detail.proxy(start + 340ms)) << "whole at once";
  EXPECT_FALSE(detail.until_rest(start + 340ms)) << "nothing due";

  EXPECT_TRUE(detail.note_frame(start + 400ms, Motion::Solve, unsettled));
  EXPECT_FALSE(detail.note_frame(start + 410ms, Motion::Solve, settled)) << "the final shape, a new solve";
  EXPECT_FALSE(detail.proxy(start + 410ms));

  EXPECT_TRUE(detail.note_frame(start + 500ms, Motion::Solve, unsettled));
  EXPECT_TRUE(detail.note_frame(start + 510ms, Motion::Input, settled)) << "the user turns the view meanwhile";
  const int before = asked;
  EXPECT_FALSE(detail.note_frame(start + 520ms, Motion::None, settled));
  EXPECT_EQ(asked, before);
  EXPECT_TRUE(detail.proxy(start + 520ms)) << "the user's motion was the last";

  detail.enable(false);
  EXPECT_TRUE(detail.note_frame(start + 600ms, Motion::Solve, settled)) << "off: a solve is motion, never the proxy";
  EXPECT_FALSE(detail.proxy(start + 610ms));
}

// A scan's still picture in slices of at most the given triangles, each slice in turn while the
// scene stays the same, nothing once it is shown; whole while the view moves over a picture
// shown, and whole when it replaces an unfinished one (a scene that keeps changing is still drawn).
TEST(SceneSlices, AStillPictureInSlicesAMovingOneWhole) {
  EXPECT_EQ(scene_slices(3'290'496, 1'000'000), 4);
  EXPECT_EQ(scene_slices(3'000'000, 1'000'000), 3);
  EXPECT_EQ(scene_slices(1'000'000, 1'000'000), 1);
  EXPECT_EQ(scene_slices(13'161'984, 1'000'000), 14);
  EXPECT_EQ(scene_slices(13'161'984, 0), 1) << "slices off";
  EXPECT_EQ(scene_slices(0, 1'000'000), 1);

  constexpr std::size_t kPerSlice = 1'000'000;
  SceneState scan{.same_scene = false, .shown = true, .next_slice = 0, .slices = 0, .moving = false, .triangles = 3'290'496};
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 4})) << "a new still picture";
  scan.same_scene = true;
  scan.next_slice = 1;
  scan.slices = 4;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{1, 4})) << "the next slice while nothing changes";
  scan.moving = true;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{1, 4})) << "the same scene: the picture goes on";
  scan.same_scene = false;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 1})) << "changed while moving: whole";
  scan.moving = false;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 1})) << "replacing an unfinished picture: whole";
  scan.slices = scan.next_slice = 0;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 4})) << "a still picture again";
  scan.same_scene = true;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), std::nullopt) << "shown, and nothing changed";
  scan.shown = false;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 4 + kFirstPictureRamp, kFirstPictureRamp})) << "nothing shown (a new size): smaller slices first";
  scan.same_scene = false;
  scan.moving = true;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 4 + kFirstPictureRamp, kFirstPictureRamp})) << "the first picture, even of a moving view";
  scan.same_scene = true;
  scan.next_slice = 2;
  scan.slices = 7;
  scan.ramp = 3;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{2, 7, 3})) << "the picture goes on with its ramp";
  scan.slices = scan.next_slice = scan.ramp = 0;
  scan.same_scene = false;
  scan.triangles = 900'000;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 1})) << "one slice: no ramp";
  scan.triangles = 23'645;  // the proxy
  scan.shown = true;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 1}));
  scan.moving = false;
  EXPECT_EQ(next_scene_slice(scan, kPerSlice), (SceneSlice{0, 1})) << "small enough for one slice";
  scan.triangles = 3'290'496;
  EXPECT_EQ(next_scene_slice(scan, 0), (SceneSlice{0, 1})) << "slices off";
}

TEST(Gizmo, AnAxisDragMovesAlongThatAxisOnlyAndByWhatTheCursorCovers) {
  const Eigen::Vector3f origin(0.5f, 0.25f, 0.0f);
  const Eigen::Vector3f x = Eigen::Vector3f::UnitX();
  // Rays through points beside the axis (off it in y and z): what counts is their nearest approach.
  const Eigen::Vector3f move = drag_along_axis(ray_through(origin + Eigen::Vector3f(1.0f, 0.0f, 0.0f)), ray_through(origin + Eigen::Vector3f(3.0f, 0.0f, 0.0f)), origin, x);
  EXPECT_NEAR(move.x(), 2.0f, 1e-4f);
  EXPECT_EQ(move.y(), 0.0f);
  EXPECT_EQ(move.z(), 0.0f);
  // A skew axis: the move is exactly a multiple of it.
  const Eigen::Vector3f skew = Eigen::Vector3f(1.0f, 2.0f, 0.5f).normalized();
  const Eigen::Vector3f along = drag_along_axis(ray_through(origin), ray_through(origin + 1.5f * skew), origin, skew);
  EXPECT_NEAR(along.dot(skew), 1.5f, 1e-3f);
  EXPECT_LT((along - along.dot(skew) * skew).norm(), 1e-6f);
  // Looking straight down the axis there is nothing to follow.
  const Eigen::Vector3f down = Eigen::Vector3f(0.3f, -0.2f, 10.0f).normalized();
  EXPECT_EQ(drag_along_axis(ray_through(origin + Eigen::Vector3f(0.1f, 0, 0)), ray_through(origin + Eigen::Vector3f(0.4f, 0, 0)), Eigen::Vector3f::Zero(), down),
            Eigen::Vector3f::Zero());
}

TEST(Gizmo, APlaneDragStaysInThePlaneAndARingTurnsByTheAngleBetweenTheRays) {
  const Eigen::Vector3f origin(0.0f, 0.0f, 1.0f);
  const Eigen::Vector3f normal = Eigen::Vector3f(0.2f, 0.1f, 1.0f).normalized();
  const Eigen::Vector3f a = origin + Eigen::Vector3f(1.0f, 0.0f, -0.2f), b = origin + Eigen::Vector3f(-0.5f, 0.8f, 0.05f);
  const Eigen::Vector3f move = drag_in_plane(ray_through(a), ray_through(b), origin, normal);
  EXPECT_LT(std::abs(move.dot(normal)), 1e-6f);
  EXPECT_GT(move.norm(), 0.5f);

  const Eigen::Vector3f centre(0.2f, -0.1f, 0.0f);
  const float radius = 0.7f;
  for (const double turn : {0.3, -1.2, 2.5}) {
    const double start = 0.4;
    const auto on_ring = [&](double angle) {
      return Eigen::Vector3f(centre + radius * Eigen::Vector3f(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)), 0.0f));
    };
    EXPECT_NEAR(drag_about_axis(ray_through(on_ring(start)), ray_through(on_ring(start + turn)), centre, Eigen::Vector3f::UnitZ()), turn, 1e-5);
    // About -z the same move is the opposite turn.
    EXPECT_NEAR(drag_about_axis(ray_through(on_ring(start)), ray_through(on_ring(start + turn)), centre, -Eigen::Vector3f::UnitZ()), -turn, 1e-5);
  }
}

// An orthographic view down -z: a point's pixel is 100·(x, −y) plus an offset (y down).
std::optional<Eigen::Vector2f> orthographic(const Eigen::Vector3f& p) { return Eigen::Vector2f(400.0f + 100.0f * p.x(), 300.0f - 100.0f * p.y()); }

TEST(Gizmo, AnEdgeOnRingFollowsItsNearSide) {
  // The x ring seen edge-on from +z: its near side (at +z) moves along −y for a positive turn,
  // which is +y on screen (y down): 0.5 radians need 0.5 · 100 · radius pixels.
  const double turn = drag_about_axis_edge_on(Eigen::Vector2f(0.0f, 25.0f), Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), 0.5f,
                                              Eigen::Vector3f::UnitZ(), orthographic);
  EXPECT_NEAR(turn, 0.5, 1e-3);
  EXPECT_NEAR(drag_about_axis_edge_on(Eigen::Vector2f(40.0f, 0.0f), Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), 0.5f, Eigen::Vector3f::UnitZ(),
                                      orthographic),
              0.0, 1e-3)
      << "a move across the ring's path does not turn it";
}

TEST(Gizmo, PartsAreFoundWhereTheyAreDrawnAndTheGizmoStaysInTheView) {
  HandleGizmo gizmo;
  const Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();
  gizmo.layout(orthographic, Eigen::Vector3f::Zero(), axes, 1.0f, GizmoMode::Move, Eigen::Vector2f(0, 0), Eigen::Vector2f(800, 600));
  ASSERT_TRUE(gizmo.laid_out());
  EXPECT_EQ(gizmo.length(), 1.0f);
  EXPECT_EQ(gizmo.hit({480.0f, 302.0f}), GizmoPart::AxisX);  // along +x on screen
  EXPECT_EQ(gizmo.hit({401.0f, 230.0f}), GizmoPart::AxisY);  // +y is up on screen
  EXPECT_EQ(gizmo.hit({435.0f, 265.0f}), GizmoPart::PlaneXY);  // the square between x and y
  EXPECT_EQ(gizmo.hit({400.0f, 300.0f}), GizmoPart::None);     // the centre: a free move
  EXPECT_EQ(gizmo.hit({600.0f, 500.0f}), GizmoPart::None);
  // Near the top edge, the gizmo shortens until its tips are inside.
  gizmo.layout(orthographic, Eigen::Vector3f(0.0f, 2.5f, 0.0f), axes, 1.0f, GizmoMode::Move, Eigen::Vector2f(0, 0), Eigen::Vector2f(800, 600));
  ASSERT_TRUE(gizmo.laid_out());
  EXPECT_LT(gizmo.length(), 0.5f + 1e-6f);
  EXPECT_GE(300.0f - 100.0f * (2.5f + gizmo.length()), 0.0f);
  // Turned with the handle: a handle rotated 90° about z has its x axis pointing up the screen.
  const Eigen::Matrix3f turned = Eigen::AngleAxisf(std::numbers::pi_v<float> / 2, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  gizmo.layout(orthographic, Eigen::Vector3f::Zero(), turned, 1.0f, GizmoMode::Move, Eigen::Vector2f(0, 0), Eigen::Vector2f(800, 600));
  EXPECT_EQ(gizmo.hit({401.0f, 230.0f}), GizmoPart::AxisX);
  gizmo.layout(orthographic, Eigen::Vector3f::Zero(), axes, 1.0f, GizmoMode::Rotate, Eigen::Vector2f(0, 0), Eigen::Vector2f(800, 600));
  EXPECT_EQ(gizmo.hit({400.0f + 80.0f * std::cos(0.7f), 300.0f - 80.0f * std::sin(0.7f)}), GizmoPart::RingZ);  // the z ring, seen face-on
}

// Blender's convention for the keys: G or R, then X/Y/Z to lock (again to free, Shift for the
// plane); the same keys set the twist axis for the twist tool; modified keys are not the tools'.
TEST(EditTools, KeysPickToolsAndLockAxesAsInBlender) {
  EditTools tools;
  EXPECT_TRUE(tools.press(GLFW_KEY_G, 0));
  EXPECT_EQ(tools.tool, Tool::Grab);
  EXPECT_TRUE(tools.press(GLFW_KEY_X, 0));
  EXPECT_EQ(tools.axis_lock, 0);
  EXPECT_FALSE(tools.lock_plane);
  EXPECT_EQ(tools.lock_text(), " along x");
  EXPECT_TRUE(tools.press(GLFW_KEY_X, 0));
  EXPECT_FALSE(tools.axis_lock) << "the same axis again frees the move";
  EXPECT_TRUE(tools.press(GLFW_KEY_Z, GLFW_MOD_SHIFT));
  EXPECT_EQ(tools.axis_lock, 2);
  EXPECT_TRUE(tools.lock_plane);
  EXPECT_EQ(tools.lock_text(), " in the plane normal to z");
  EXPECT_TRUE(tools.press(GLFW_KEY_Y, 0));
  EXPECT_EQ(tools.axis_lock, 1);
  EXPECT_FALSE(tools.lock_plane) << "an axis after a plane: the axis";
  EXPECT_TRUE(tools.press(GLFW_KEY_R, 0));
  EXPECT_FALSE(tools.axis_lock) << "a tool picked drops the lock";
  EXPECT_TRUE(tools.press(GLFW_KEY_Y, GLFW_MOD_SHIFT));
  EXPECT_EQ(tools.axis_lock, 1);
  EXPECT_FALSE(tools.lock_plane) << "rotation has no plane lock: about the axis";
  EXPECT_EQ(tools.lock_text(), " about y");
  EXPECT_TRUE(tools.press(GLFW_KEY_T, 0));
  EXPECT_TRUE(tools.press(GLFW_KEY_X, 0));
  EXPECT_EQ(tools.twist_axis, TwistAxis::X);
  EXPECT_FALSE(tools.axis_lock);
  EXPECT_EQ(tools.lock_text(), "");
  EXPECT_TRUE(tools.press(GLFW_KEY_V, 0));
  EXPECT_EQ(tools.twist_axis, TwistAxis::View);
  EXPECT_FALSE(tools.press(GLFW_KEY_Z, GLFW_MOD_CONTROL)) << "Ctrl+Z is undo, not the z axis";
  EXPECT_FALSE(tools.press(GLFW_KEY_S, GLFW_MOD_CONTROL)) << "Ctrl+S is save, not the scale tool";
  EXPECT_EQ(tools.tool, Tool::Twist);
  EXPECT_TRUE(tools.press(GLFW_KEY_Z, GLFW_MOD_ALT));
  EXPECT_TRUE(tools.paint_through);
  EXPECT_TRUE(tools.press(GLFW_KEY_2, 0));
  EXPECT_TRUE(is_paint_tool(tools.tool));
  EXPECT_EQ(layer_of(tools.tool), Layer::Fixed);
  EXPECT_TRUE(tools.press(GLFW_KEY_E, 0));
  EXPECT_TRUE(tools.erase);
  EXPECT_FALSE(tools.press(GLFW_KEY_Q, 0));
}

// A drag step seen by a camera on the +z axis looking down (right = x, up = y).
DragStep step_between(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector2f& delta) {
  DragStep step;
  step.from = ray_through(a);
  step.to = ray_through(b);
  step.cursor = *orthographic(b);
  step.delta = delta;
  step.forward = -Eigen::Vector3f::UnitZ();
  step.right = Eigen::Vector3f::UnitX();
  step.up = Eigen::Vector3f::UnitY();
  step.world_per_pixel = 0.01f;
  step.project = orthographic;
  step.ring_radius = 0.5f;
  return step;
}

TEST(HandleDrag, EachToolAndConstraintMovesThePoseAsItSays) {
  const Eigen::Vector3d pivot(0.2, -0.1, 0.0);
  const HandleTransform rest = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), pivot, 0.0);
  const Eigen::Vector3f centre = pivot.cast<float>();
  EditTools tools;
  tools.tool = Tool::Grab;
  // Free: in the view plane, by the pixels times the world size of one.
  HandleTransform moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(10.0f, -5.0f)));
  EXPECT_NEAR((moved.shift - Eigen::Vector3d(0.1, 0.05, 0.0)).norm(), 0.0, 1e-6);
  // Locked to x: the cursor's move in y is ignored.
  tools.axis_lock = 0;
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre + Eigen::Vector3f(0.5f, 0.3f, 0.0f), Eigen::Vector2f(50, -30)));
  EXPECT_NEAR(moved.shift.x(), 0.5, 2e-3);  // the slanted ray passes beside the axis: its nearest approach is a little off
  EXPECT_EQ(moved.shift.y(), 0.0);
  EXPECT_EQ(moved.shift.z(), 0.0);
  // The gizmo's y axis of a handle turned 90° about z is the world's −x.
  tools.axis_lock.reset();
  const HandleTransform turned = HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), pivot, std::numbers::pi / 2);
  moved = drag_pose(turned, tools, GizmoPart::AxisY, step_between(centre, centre + Eigen::Vector3f(-0.4f, 0.2f, 0.0f), Eigen::Vector2f(-40, -20)));
  EXPECT_NEAR(moved.shift.x(), -0.4, 2e-3);
  EXPECT_NEAR(moved.shift.y(), 0.0, 1e-6);
  EXPECT_EQ(moved.angle, turned.angle) << "a move does not turn";
  // Rotate on the z ring: by the angle the cursor went round the centre.
  tools.tool = Tool::Rotate;
  const Eigen::Vector3f on_ring = centre + Eigen::Vector3f(0.5f, 0.0f, 0.0f);
  const Eigen::Vector3f turned_on_ring = centre + 0.5f * Eigen::Vector3f(std::cos(0.3f), std::sin(0.3f), 0.0f);
  moved = drag_pose(rest, tools, GizmoPart::RingZ, step_between(on_ring, turned_on_ring, *orthographic(turned_on_ring) - *orthographic(on_ring)));
  EXPECT_NEAR(moved.angle, 0.3, 1e-4);
  EXPECT_NEAR(moved.axis.z(), 1.0, 1e-9);
  // Scale: up or right the screen grows it, down or left shrinks it; a diagonal adds both.
  tools.tool = Tool::Scale;
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(0.0f, -100.0f)));
  EXPECT_NEAR(moved.scale, std::exp(1.0), 1e-9);
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(100.0f, 0.0f)));
  EXPECT_NEAR(moved.scale, std::exp(1.0), 1e-9) << "a horizontal drag scales too";
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(-50.0f, 0.0f)));
  EXPECT_NEAR(moved.scale, std::exp(-0.5), 1e-9);
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(30.0f, -20.0f)));
  EXPECT_NEAR(moved.scale, std::exp(0.5), 1e-9);
  // Twist about x: 100 pixels right is one radian.
  tools.tool = Tool::Twist;
  tools.twist_axis = TwistAxis::X;
  moved = drag_pose(rest, tools, GizmoPart::None, step_between(centre, centre, Eigen::Vector2f(100.0f, 0.0f)));
  EXPECT_NEAR(moved.angle, 1.0, 1e-9);
  EXPECT_NEAR(moved.axis.x(), 1.0, 1e-9);
  // Paint tools leave the pose alone.
  tools.tool = Tool::PaintFixed;
  moved = drag_pose(turned, tools, GizmoPart::None, step_between(centre, centre + Eigen::Vector3f(1, 1, 0), Eigen::Vector2f(100, 100)));
  EXPECT_EQ(moved.angle, turned.angle);
  EXPECT_EQ(moved.shift, turned.shift);
}

TEST(ViewNavigation, BothModesReadTheMouseAlikeAndMoveTheCameraAsItsOwnCallsDo) {
  //                                  left   middle right  shift  alt
  EXPECT_EQ(camera_gesture(false, false, true, false, false), CameraGesture::Orbit);
  EXPECT_EQ(camera_gesture(true, false, false, false, true), CameraGesture::Orbit);  // Alt+left
  EXPECT_EQ(camera_gesture(false, true, false, false, false), CameraGesture::Pan);
  EXPECT_EQ(camera_gesture(false, false, true, true, false), CameraGesture::Pan);  // Shift+right
  EXPECT_EQ(camera_gesture(true, false, false, false, false), CameraGesture::None);  // a plain left drag is the tool's
  EXPECT_EQ(camera_gesture(true, false, false, true, false), CameraGesture::None);
  const engine::Bounds bounds{Eigen::Vector3f(-1, -1, -1), Eigen::Vector3f(1, 1, 1)};
  const engine::Camera start = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, 1.5f);
  engine::Camera moved = start, expected = start;
  apply_camera_gesture(moved, CameraGesture::Orbit, Eigen::Vector2f(50, -20), 600, 0);
  expected.orbit(-50 * 0.008f, -20 * 0.008f);
  EXPECT_LT((moved.position() - expected.position()).norm(), 1e-6f);
  moved = expected = start;
  apply_camera_gesture(moved, CameraGesture::Pan, Eigen::Vector2f(60, 30), 600, 2);
  expected.pan(-0.1f, 0.05f);
  expected.zoom(0.88f * 0.88f);
  EXPECT_LT((moved.position() - expected.position()).norm(), 1e-5f);
  EXPECT_LT((moved.target - expected.target).norm(), 1e-6f);
}

}  // namespace
}  // namespace hdeform::cli
