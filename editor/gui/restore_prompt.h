#pragma once
// The question at start when the last run did not end cleanly: what the recovery file holds
// (its mesh, its contents, when it was written) against what the command line asked for, and
// the user's answer.
#include <filesystem>
#include <string>

namespace hdeform::cli {

struct RestoreOffer {
  std::filesystem::path recovery;  // the edit session's ("" when only transfer mode left one)
  std::string mesh;       // the recovered session's mesh
  std::string holds;      // describe_session()
  std::filesystem::path transfer_recovery;  // transfer mode's ("" when it left none)
  std::string transfer;                     // describe_transfer_state()
  std::string written;    // describe_age()
  std::string requested;  // the mesh or session named on the command line ("": none)
  // Whether restoring leaves the requested file unopened (it names another mesh).
  bool conflicts() const { return !recovery.empty() && !requested.empty() && requested != mesh; }
};

// Reads the recovery files that exist (InputError naming one that cannot be read). `requested`
// is the command line's mesh or session, as given.
RestoreOffer make_restore_offer(const std::filesystem::path& recovery, const std::filesystem::path& transfer_recovery,
                                const std::string& requested);

enum class RestoreChoice { Undecided, Restore, OpenRequested, Discard };

// The modal (Dear ImGui); `enter` and `escape` are this frame's key presses.
RestoreChoice restore_prompt(const RestoreOffer& offer, bool enter, bool escape);

}  // namespace hdeform::cli
