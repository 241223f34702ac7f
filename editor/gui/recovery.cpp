#include "gui/recovery.h"

#include <cstdlib>
#include <iostream>

#include "hdeform/atomic_file.h"

namespace hdeform::cli {

std::filesystem::path default_recovery_path() {
  if (const char* explicit_path = std::getenv("HDEFORM_RECOVERY_FILE"); explicit_path != nullptr && *explicit_path != '\0') {
    return explicit_path;
  }
  if (const char* state = std::getenv("XDG_STATE_HOME"); state != nullptr && *state != '\0') {
    return std::filesystem::path(state) / "hdeform" / "recovery.json";
  }
  const char* home = std::getenv("HOME");
  return std::filesystem::path(home != nullptr ? home : ".") / ".local" / "state" / "hdeform" / "recovery.json";
}

RecoveryWriter::RecoveryWriter(std::filesystem::path path, Announce announce) : path_(std::move(path)), announce_(std::move(announce)) {
  remove_abandoned_temporaries(path_);  // a run killed in the middle of a write
  thread_ = std::thread([this] { run(); });
}

RecoveryWriter::~RecoveryWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void RecoveryWriter::post(Session session) {
  {
    std::lock_guard lock(mutex_);
    pending_ = std::move(session);
  }
  wake_.notify_all();
}

void RecoveryWriter::flush() {
  std::unique_lock lock(mutex_);
  written_.wait(lock, [this] { return !pending_ && !writing_; });
}

void RecoveryWriter::discard() {
  flush();
  std::error_code ignored;
  std::filesystem::remove(path_, ignored);
}

void RecoveryWriter::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return pending_ || stopping_; });
    if (!pending_) return;  // stopping with nothing left
    Session session = std::move(*pending_);
    pending_.reset();
    writing_ = true;
    lock.unlock();
    try {
      if (announce_) announce_(session);
      std::filesystem::create_directories(path_.parent_path());
      write_session(path_, session);
    } catch (const std::exception& error) {
      std::cerr << "hdeform: warning: could not write the recovery file: " << error.what() << '\n';
    }
    lock.lock();
    writing_ = false;
    written_.notify_all();
  }
}

}  // namespace hdeform::cli
