#include "gui/widgets.h"

#include <imgui.h>

namespace hdeform::cli {

std::optional<std::string> path_prompt(const char* title, bool& open, std::span<char> buffer, bool cancel_pressed) {
  if (open && !ImGui::IsPopupOpen(title)) ImGui::OpenPopup(title);
  if (!ImGui::BeginPopupModal(title, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return std::nullopt;
  std::optional<std::string> chosen;
  ImGui::SetNextItemWidth(520);
  // Focused when it appears, and all selected: typing replaces the suggestion.
  if (ImGui::IsWindowAppearing()) ImGui::SetKeyboardFocusHere();
  const bool entered = ImGui::InputText("Path", buffer.data(), buffer.size(), ImGuiInputTextFlags_EnterReturnsTrue | ImGuiInputTextFlags_AutoSelectAll);
  if (ImGui::Button(title) || entered) {
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
