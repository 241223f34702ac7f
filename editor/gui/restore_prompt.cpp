#include "gui/restore_prompt.h"

#include <imgui.h>

#include <algorithm>

#include "gui/recovery.h"
#include "hdeform/errors.h"
#include "commands/cli_support.h"
#include "model/session.h"
#include "model/transfer_state.h"

namespace hdeform::cli {
namespace {

std::string absolute_name(const std::string& name) {
  if (name.empty() || names_builtin_shape(name)) return name;
  return std::filesystem::absolute(name).lexically_normal().string();
}

}  // namespace

RestoreOffer make_restore_offer(const std::filesystem::path& recovery, const std::filesystem::path& transfer_recovery,
                                const std::string& requested) {
  RestoreOffer offer;
  std::filesystem::file_time_type written = std::filesystem::file_time_type::min();
  if (std::filesystem::exists(recovery)) {
    const Session session = read_session(recovery);
    offer.recovery = recovery;
    offer.mesh = session.mesh;
    offer.holds = describe_session(session);
    written = std::filesystem::last_write_time(recovery);
  }
  if (std::filesystem::exists(transfer_recovery)) {
    offer.transfer_recovery = transfer_recovery;
    offer.transfer = describe_transfer_state(read_transfer_state(transfer_recovery));
    written = std::max(written, std::filesystem::last_write_time(transfer_recovery));
  }
  if (offer.recovery.empty() && offer.transfer_recovery.empty()) throw InputError(recovery.string() + ": no recovery file");
  offer.written = describe_age(written, std::filesystem::file_time_type::clock::now());
  offer.requested = absolute_name(requested);
  return offer;
}

RestoreChoice restore_prompt(const RestoreOffer& offer, bool enter, bool escape) {
  constexpr const char* kTitle = "Restore the last session?";
  if (!ImGui::IsPopupOpen(kTitle)) ImGui::OpenPopup(kTitle);
  if (!ImGui::BeginPopupModal(kTitle, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return RestoreChoice::Undecided;
  RestoreChoice choice = RestoreChoice::Undecided;
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 40.0f);
  ImGui::TextUnformatted("hdeform did not close cleanly last time. Its recovery file was written at:");
  ImGui::BulletText("%s", offer.written.c_str());
  ImGui::TextDisabled("%s", (!offer.recovery.empty() ? offer.recovery : offer.transfer_recovery).string().c_str());
  ImGui::TextUnformatted("It holds:");
  if (!offer.recovery.empty()) {
    ImGui::BulletText("%s", offer.mesh.c_str());
    ImGui::BulletText("%s", offer.holds.c_str());
  }
  if (!offer.transfer.empty()) ImGui::BulletText("Transfer mode: %s", offer.transfer.c_str());
  if (offer.conflicts()) ImGui::TextDisabled("You asked for %s: restoring leaves it unopened (Ctrl+O opens it later).", offer.requested.c_str());
  ImGui::TextDisabled("Not restored, the recovery file is kept beside it, named by its time.");
  ImGui::PopTextWrapPos();
  ImGui::Spacing();
  if (ImGui::Button("Restore (Enter)") || enter) choice = RestoreChoice::Restore;
  ImGui::SameLine();
  const std::string open_label = offer.requested.empty() ? std::string("Start fresh (Esc)")
                                                         : "Open " + std::filesystem::path(offer.requested).filename().string() + " (Esc)";
  if (ImGui::Button(open_label.c_str()) || escape) choice = RestoreChoice::OpenRequested;
  ImGui::SameLine();
  if (ImGui::Button("Discard it")) choice = RestoreChoice::Discard;
  if (choice != RestoreChoice::Undecided) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
  return choice;
}

}  // namespace hdeform::cli
