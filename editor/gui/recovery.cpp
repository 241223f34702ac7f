#include "gui/recovery.h"

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>
#include <iostream>

#include "hdeform/atomic_file.h"
#include "hdeform/counted.h"

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

namespace {

std::tm local_time(std::filesystem::file_time_type time) {
  const auto system = std::chrono::time_point_cast<std::chrono::system_clock::duration>(std::chrono::file_clock::to_sys(time));
  const std::time_t seconds = std::chrono::system_clock::to_time_t(system);
  std::tm local{};
  localtime_r(&seconds, &local);
  return local;
}

}  // namespace

std::string describe_session(const Session& session) {
  const EditStage& stage = session.current;
  std::vector<std::string> parts;
  for (std::size_t h = 0; h < stage.handles.size() && h < 3; ++h) {
    const auto& handle = stage.handles[h];
    parts.push_back((stage.handles.size() == 1 ? std::string("1 handle") : "handle " + std::to_string(h + 1)) + " (" +
                    counted(handle.vertices.size(), "vertex", "vertices") + (handle.transform.is_identity() ? ", at rest)" : ", moved)"));
  }
  if (stage.handles.size() > 3) parts.push_back(counted(stage.handles.size() - 3, "more handle", "more handles"));
  if (stage.handles.empty()) parts.emplace_back("no handle");
  parts.push_back(counted(stage.fixed.size(), "fixed vertex", "fixed vertices"));
  if (!stage.region_of_interest.empty()) parts.push_back("a region of interest of " + counted(stage.region_of_interest.size(), "vertex", "vertices"));
  if (!session.applied.empty()) parts.push_back(counted(session.applied.size(), "applied stage", "applied stages"));
  std::string text;
  for (const auto& part : parts) text += (text.empty() ? "" : ", ") + part;
  return text;
}

std::string describe_age(std::filesystem::file_time_type written, std::filesystem::file_time_type now) {
  const std::tm local = local_time(written);
  char clock[32];
  std::strftime(clock, sizeof clock, "%H:%M:%S", &local);
  const auto minutes = std::chrono::duration_cast<std::chrono::minutes>(now - written).count();
  const std::string ago = minutes < 1    ? "less than a minute ago"
                          : minutes < 120 ? counted(static_cast<std::size_t>(minutes), "minute", "minutes") + " ago"
                          : minutes < 48 * 60 ? counted(static_cast<std::size_t>(minutes / 60), "hour", "hours") + " ago"
                                              : counted(static_cast<std::size_t>(minutes / (24 * 60)), "day", "days") + " ago";
  if (minutes >= 24 * 60) {
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%d ", &local);
    return date + std::string(clock) + ", " + ago;
  }
  return std::string(clock) + ", " + ago;
}

std::filesystem::path set_recovery_aside(const std::filesystem::path& path) {
  const std::tm local = local_time(std::filesystem::last_write_time(path));
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%d-%H%M%S", &local);
  const std::string base = (path.parent_path() / path.stem()).string() + "-" + stamp;
  std::filesystem::path aside = base + path.extension().string();
  for (int k = 2; std::filesystem::exists(aside); ++k) aside = base + "-" + std::to_string(k) + path.extension().string();
  std::filesystem::rename(path, aside);
  return aside;
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
