#pragma once
// Over how many frames the editor draws a picture of the scene (SwapchainTarget's slices). On a
// CPU device a picture of every triangle of a scan holds the device for a long time (the 3.3M
// Buddha on lavapipe: 0.2–0.5 s, the 13M one about a second), and until it is done the window
// answers nothing: not the next drag, not the panel. Drawn in slices, each frame draws a share of
// the triangles into a picture of its own, the window shows the last whole picture meanwhile
// (the proxy where a drag left off) and answers between slices. No window needed.
#include <cstddef>
#include <optional>

namespace hdeform::cli {

// Triangles a slice draws by default on a CPU device: lavapipe draws a million in 50–140 ms on
// two cores at 1280×800, so the window answers several times a second while a scan is drawn.
inline constexpr std::size_t kSliceTriangles = 1'000'000;

// A first picture in slices (none shown yet: a mesh just opened) begins with slices
// of an eighth, a quarter and a half of the others (engine::DrawSlice::ramp): its first slice
// also draws into memory lavapipe has not used yet, beside the solver's set-up, and at a million
// triangles held the window 0.5–0.9 s where an eighth of that took 0.2 s.
inline constexpr int kFirstPictureRamp = 3;

// The slices for a picture of `triangles`: one when slices are off (`per_slice` 0) or it fits in
// one; otherwise as many as keep each to at most `per_slice` triangles.
inline int scene_slices(std::size_t triangles, std::size_t per_slice) {
  if (per_slice == 0 || triangles <= per_slice) return 1;
  return static_cast<int>((triangles + per_slice - 1) / per_slice);
}

// What a frame knows about its scene.
struct SceneState {
  bool same_scene = false;  // it prepared exactly the picture of the frame before
  bool shown = false;       // a whole picture is shown (SwapchainTarget::scene_kept)
  int next_slice = 0;       // the picture being built: its next slice, of `slices` (0 of 0: none)
  int slices = 0;
  int ramp = 0;             // ... and its ramp
  bool moving = false;      // the view moves: a drag, a new solve, the camera
  std::size_t triangles = 0;  // what the frame draws
};

// A slice to draw: `index` of `count`, the first `ramp` of them smaller (engine::DrawSlice).
struct SceneSlice {
  int index = 0;
  int count = 1;
  int ramp = 0;
  bool operator==(const SceneSlice&) const = default;
};

// Which slice, if any, this frame draws, given `per_slice` (0: always whole):
//  - the next slice of the picture being built, while the scene stays the same;
//  - nothing when the scene is the same and shown;
//  - otherwise a new picture, in scene_slices() slices, but whole while the view moves (it would
//    be outdated before its last slice) unless none is shown yet (nothing better would show
//    meanwhile), and whole when it replaces an unfinished one (so that a scene that keeps changing
//    is still drawn, if with the window held);
//  - a first picture (none shown) in slices begins with kFirstPictureRamp smaller ones.
inline std::optional<SceneSlice> next_scene_slice(const SceneState& state, std::size_t per_slice) {
  const bool building = state.slices > 0;
  if (state.same_scene && building) return SceneSlice{state.next_slice, state.slices, state.ramp};
  if (state.same_scene && state.shown) return std::nullopt;
  const bool whole = building || (state.moving && state.shown);
  const int slices = whole ? 1 : scene_slices(state.triangles, per_slice);
  if (slices > 1 && !state.shown) return SceneSlice{0, slices + kFirstPictureRamp, kFirstPictureRamp};
  return SceneSlice{0, slices};
}

}  // namespace hdeform::cli
