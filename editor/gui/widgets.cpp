#include "gui/widgets.h"

#include <imgui.h>

#include <cstdio>

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

}  // namespace hdeform::cli
