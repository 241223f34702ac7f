#pragma once
// Small Dear ImGui pieces both editor modes use.
#include <optional>
#include <span>
#include <string>

struct ImVec4;

namespace hdeform::cli {

// Text in a colour (errors, notes) that wraps at the window's edge instead of running past it.
void wrapped_in_color(const ImVec4& color, const std::string& text);

// A modal that asks for a path (`title` names it and its confirm button), its box focused with
// the text selected. Opens while `open` is set; returns the text when confirmed (Enter or the button) and clears `open` then, or when
// cancelled (the button or `cancel_pressed`, the frame's Escape).
// `suggestions` (recent files) are listed below the box: a click puts one in the box, a double
// click chooses it.
std::optional<std::string> path_prompt(const char* title, bool& open, std::span<char> buffer, bool cancel_pressed,
                                       std::span<const std::string> suggestions = {});

// What an action is about to throw away, for the question asked first ("" where all is saved).
struct UnsavedWork {
  std::string edits;    // e.g. "the edits of cactus.obj"
  std::string markers;  // e.g. "12 marker pairs"
  bool any() const { return !edits.empty() || !markers.empty(); }
};

enum class UnsavedChoice { Undecided, Save, Discard, Cancel };

// A frame's presses of the keys that answer dialogs.
struct DialogKeys {
  bool enter = false;
  bool escape = false;
  bool d = false;  // Discard
};

// The modal asked before `action` ("Quitting", "Opening horse.obj") discards unsaved work, with
// Save (Enter), Discard (D) and Cancel (Escape). Says on stdout when it opens and what was chosen ({"event": "dialog", "title":
// "Unsaved changes", ...}, {"event": "dialog closed", "choice": ...}), for scripts.
UnsavedChoice unsaved_prompt(const std::string& action, const UnsavedWork& work, DialogKeys keys);

}  // namespace hdeform::cli
