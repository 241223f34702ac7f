#include "gui/widgets.h"

#include <imgui.h>

#include <cstdio>

#include <nlohmann/json.hpp>

#include "commands/cli_support.h"

namespace hdeform::cli {

void wrapped_in_color(const ImVec4& color, const std::string& text) {
  ImGui::PushStyleColor(ImGuiCol_Text, color);
  ImGui::TextWrapped("%s", text.c_str());
  ImGui::PopStyleColor();
}

std::optional<std::string> path_prompt(const char* title, bool& open, std::span<char> buffer, bool cancel_pressed,
                                       std::span<const std::string> suggestions) {
  if (open && !ImGui::IsPopupOpen(title)) ImGui::OpenPopup(title);
  if (!ImGui::BeginPopupModal(title, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return std::nullopt;
  std::optional<std::string> chosen;
  ImGui::SetNextItemWidth(520);
  // Focused when it appears, and all selected: typing replaces the suggestion.
  if (ImGui::IsWindowAppearing()) ImGui::SetKeyboardFocusHere();
  const bool entered = ImGui::InputText("Path", buffer.data(), buffer.size(), ImGuiInputTextFlags_EnterReturnsTrue | ImGuiInputTextFlags_AutoSelectAll);
  bool picked = false;
  if (!suggestions.empty()) {
    ImGui::TextDisabled("Recent");
    for (const auto& suggestion : suggestions) {
      if (ImGui::Selectable(suggestion.c_str(), suggestion == buffer.data(), ImGuiSelectableFlags_AllowDoubleClick)) {
        std::snprintf(buffer.data(), buffer.size(), "%s", suggestion.c_str());
        picked = ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left);
      }
    }
  }
  if (ImGui::Button(title) || entered || picked) {
    open = false;
    ImGui::CloseCurrentPopup();
    chosen = std::string(buffer.data());
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel") || cancel_pressed) {
    open = false;
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndPopup();
  return chosen;
}

UnsavedChoice unsaved_prompt(const std::string& action, const UnsavedWork& work, DialogKeys keys) {
  constexpr const char* kTitle = "Unsaved changes";
  if (!ImGui::IsPopupOpen(kTitle)) {
    ImGui::OpenPopup(kTitle);
    print_json_line({{"event", "dialog"}, {"title", kTitle}, {"action", action}, {"edits", work.edits}, {"markers", work.markers}});
  }
  if (!ImGui::BeginPopupModal(kTitle, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return UnsavedChoice::Undecided;
  // The key that confirmed the dialog before this one (Open's Enter) is not an answer to it.
  if (ImGui::IsWindowAppearing()) keys = {};
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
  ImGui::Text("%s would discard what is not saved:", action.c_str());
  if (!work.edits.empty()) ImGui::BulletText("%s", work.edits.c_str());
  if (!work.markers.empty()) ImGui::BulletText("%s", work.markers.c_str());
  ImGui::TextDisabled("Until you choose, the recovery file keeps it.");
  ImGui::PopTextWrapPos();
  ImGui::Spacing();
  UnsavedChoice choice = UnsavedChoice::Undecided;
  if (ImGui::Button("Save (Enter)") || keys.enter) choice = UnsavedChoice::Save;
  ImGui::SameLine();
  if (ImGui::Button("Discard (D)") || keys.d) choice = UnsavedChoice::Discard;
  ImGui::SameLine();
  if (ImGui::Button("Cancel (Esc)") || keys.escape) choice = UnsavedChoice::Cancel;
  if (choice != UnsavedChoice::Undecided) {
    ImGui::CloseCurrentPopup();
    print_json_line({{"event", "dialog closed"},
                     {"title", kTitle},
                     {"choice", choice == UnsavedChoice::Save ? "save" : choice == UnsavedChoice::Discard ? "discard" : "cancel"}});
  }
  ImGui::EndPopup();
  return choice;
}

}  // namespace hdeform::cli
