#include "gui/recent_files.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <iostream>

#include "hdeform/atomic_file.h"

namespace hdeform::cli {

RecentFiles::RecentFiles(std::filesystem::path path) : path_(std::move(path)) {
  std::ifstream in(path_);
  if (!in) return;
  try {
    const nlohmann::json json = nlohmann::json::parse(in);
    for (const auto& file : json.at("recent")) files_.push_back(file.get<std::string>());
  } catch (const std::exception&) {
    files_.clear();
  }
  if (files_.size() > kKept) files_.resize(kKept);
}

std::vector<std::string> RecentFiles::list() const {
  std::vector<std::string> existing;
  for (const auto& file : files_) {
    std::error_code ignored;
    if (std::filesystem::exists(file, ignored)) existing.push_back(file);
  }
  return existing;
}

void RecentFiles::add(const std::string& file) {
  files_.erase(std::remove(files_.begin(), files_.end(), file), files_.end());
  files_.insert(files_.begin(), file);
  if (files_.size() > kKept) files_.resize(kKept);
  try {
    std::filesystem::create_directories(path_.parent_path());
    const std::string text = nlohmann::json{{"recent", files_}}.dump(1) + "\n";
    write_file_atomically(path_, [&](std::ostream& out) { out << text; });
  } catch (const std::exception& error) {
    std::cerr << "hdeform: warning: could not write the recent files: " << error.what() << '\n';
  }
}

}  // namespace hdeform::cli
