#pragma once
// Crash safety: the session goes to a recovery file after every finished action and every few
// seconds, written atomically on a thread of its own (a large session's JSON must not stall a
// frame). A clean exit removes the file; finding it at start means the last run ended without
// one, and the editor offers to restore it.
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "model/session.h"

namespace hdeform::cli {

// $HDEFORM_RECOVERY_FILE, else $XDG_STATE_HOME/hdeform/recovery.json, else
// ~/.local/state/hdeform/recovery.json.
std::filesystem::path default_recovery_path();

// What a recovery file holds, in words for the restore prompt: the mesh, then the handles (and
// whether any is moved), the fixed vertices, the region of interest and the applied stages, for
// example "1 handle (193 vertices, moved), 412 fixed vertices, 2 applied stages".
std::string describe_session(const Session& session);
// "18:42:07, 12 minutes ago": when the file was last written, in local time.
std::string describe_age(std::filesystem::file_time_type written, std::filesystem::file_time_type now);

// Moves a recovery file the user chose not to restore out of the way, beside it and named by
// the time (recovery-2026-12-01-184207.json, a number added if that exists), so that the new
// session's recovery writes do not overwrite it; returns the new path.
std::filesystem::path set_recovery_aside(const std::filesystem::path& path);

class RecoveryWriter {
 public:
  // Called on the writer's thread with each session just before it is written: whatever the
  // file holds after a kill was announced first.
  using Announce = std::function<void(const Session&)>;

  explicit RecoveryWriter(std::filesystem::path path, Announce announce = {});
  ~RecoveryWriter();  // writes what is pending, then stops
  RecoveryWriter(const RecoveryWriter&) = delete;
  RecoveryWriter& operator=(const RecoveryWriter&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // Queues a write; a newer session replaces one not yet written.
  void post(Session session);
  // Waits until everything posted is on disk.
  void flush();
  // Removes the file (clean exit); later posts write it again.
  void discard();

 private:
  void run();

  std::filesystem::path path_;
  Announce announce_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable written_;
  std::optional<Session> pending_;
  bool writing_ = false;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace hdeform::cli
