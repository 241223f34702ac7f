#pragma once
// Checks a trace file written by hdeform::trace holds to the trace-event format as viewers read
// it, and finds its events: shared by the solver's trace test and the editor's.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace hdeform::test {

struct TraceEvent {
  std::string name;
  std::string category;
  std::string phase;
  int thread = 0;
  double start_us = 0.0;
  double duration_us = 0.0;
  double end_us() const { return start_us + duration_us; }
};

// Parses `path`; adds a gtest failure for any event without its fields, timestamps that go
// backwards on a thread, or complete events on one thread that overlap without nesting.
std::vector<TraceEvent> read_checked_trace(const std::filesystem::path& path);

std::vector<TraceEvent> named(const std::vector<TraceEvent>& events, const std::string& name);
std::set<int> threads_of(const std::vector<TraceEvent>& events);

}  // namespace hdeform::test
