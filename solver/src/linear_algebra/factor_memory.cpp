#include "factor_memory.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hdeform/errors.h"

namespace hdeform::detail {
namespace {

std::string gigabytes(std::uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f GB", static_cast<double>(bytes) / 1e9);
  return text;
}

// The first number in `path` (a cgroup's control file), or nullopt ("max", missing, unreadable).
std::optional<std::uint64_t> read_number(const std::filesystem::path& path) {
  std::ifstream file(path);
  std::uint64_t value = 0;
  if (file >> value) return value;
  return std::nullopt;
}

// The value of `key` in a memory.stat file.
std::optional<std::uint64_t> stat_value(const std::filesystem::path& path, const std::string& key) {
  std::ifstream file(path);
  std::string name;
  std::uint64_t value = 0;
  while (file >> name >> value) {
    if (name == key) return value;
  }
  return std::nullopt;
}

// What the memory cgroup this process runs in (a container's, a systemd unit's) still allows: its
// limit less its working set (the usage less the inactive file cache, which the kernel reclaims
// first, as container runtimes count it). nullopt without a limit. /proc/meminfo does not see
// these limits, and the out-of-memory killer acts on them.
std::optional<std::uint64_t> cgroup_memory_left() {
  std::ifstream groups("/proc/self/cgroup");
  std::string line;
  std::optional<std::uint64_t> left;
  while (std::getline(groups, line)) {
    const auto first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1), path = line.substr(second + 1);
    const bool v2 = controllers.empty();
    if (!v2 && ("," + controllers + ",").find(",memory,") == std::string::npos) continue;
    const std::filesystem::path folder = std::filesystem::path(v2 ? "/sys/fs/cgroup" : "/sys/fs/cgroup/memory") / std::filesystem::path(path).relative_path();
    const auto limit = read_number(folder / (v2 ? "memory.max" : "memory.limit_in_bytes"));
    const auto usage = read_number(folder / (v2 ? "memory.current" : "memory.usage_in_bytes"));
    if (!limit || !usage || *limit >= (std::uint64_t{1} << 60)) continue;  // no limit (v1 writes a huge number)
    const std::uint64_t inactive = stat_value(folder / "memory.stat", v2 ? "inactive_file" : "total_inactive_file").value_or(0);
    const std::uint64_t working = *usage > inactive ? *usage - inactive : 0;
    const std::uint64_t here = *limit > working ? *limit - working : 0;
    left = left ? std::min(*left, here) : here;
  }
  return left;
}

}  // namespace

std::uint64_t factor_value_bytes(std::size_t nonzeros) { return 2 * sizeof(double) * static_cast<std::uint64_t>(nonzeros); }

std::optional<std::uint64_t> available_memory_bytes() {
  std::optional<std::uint64_t> available;
  std::ifstream meminfo("/proc/meminfo");
  std::string line;
  while (std::getline(meminfo, line)) {
    std::istringstream fields(line);
    std::string name, unit;
    std::uint64_t value = 0;
    if (fields >> name >> value >> unit && name == "MemAvailable:" && unit == "kB") available = value * 1024;
  }
  if (const auto left = cgroup_memory_left()) available = available ? std::min(*available, *left) : *left;
  return available;
}

void check_factor_memory(std::int64_t unknowns, std::uint64_t needed, std::optional<std::uint64_t> available) {
  if (!available || needed <= *available) return;
  throw SolveError("the factor of the " + std::to_string(unknowns) + "-unknown system needs " + gigabytes(needed) + " of memory and " +
                   gigabytes(*available) + " are available: solve on a base mesh (multiresolution), or on a smaller region of interest");
}

}  // namespace hdeform::detail
