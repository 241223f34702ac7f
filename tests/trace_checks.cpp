#include "trace_checks.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>

namespace hdeform::test {

std::vector<TraceEvent> read_checked_trace(const std::filesystem::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path << " was not written";
  nlohmann::json trace;
  try {
    trace = nlohmann::json::parse(in);
  } catch (const std::exception& error) {
    ADD_FAILURE() << path << " is not JSON: " << error.what();
    return {};
  }
  EXPECT_TRUE(trace.contains("traceEvents") && trace["traceEvents"].is_array());
  std::vector<TraceEvent> events;
  std::map<int, std::vector<TraceEvent>> by_thread;
  std::set<int> tracks;  // tracks of their own (the device's), not threads: events there may overlap
  for (const auto& item : trace["traceEvents"]) {
    TraceEvent event;
    event.phase = item.value("ph", "");
    event.name = item.value("name", "");
    EXPECT_FALSE(event.phase.empty() || event.name.empty()) << item.dump();
    EXPECT_TRUE(item.contains("pid") && item.contains("tid")) << item.dump();
    event.thread = item.value("tid", 0);
    if (event.phase == "M") {
      const std::string name = item["args"].value("name", "");
      if (name.find("(thread ") == std::string::npos) tracks.insert(event.thread);
      continue;
    }
    event.category = item.value("cat", "");
    EXPECT_TRUE(item.contains("ts") && item["ts"].is_number()) << item.dump();
    event.start_us = item.value("ts", 0.0);
    if (event.phase == "X") {
      EXPECT_TRUE(item.contains("dur") && item["dur"].is_number() && item["dur"].get<double>() >= 0.0) << item.dump();
      event.duration_us = item.value("dur", 0.0);
    } else {
      EXPECT_TRUE(event.phase == "C" || event.phase == "i") << "unexpected phase in " << item.dump();
    }
    events.push_back(event);
    by_thread[event.thread].push_back(event);
  }
  for (const auto& [thread, list] : by_thread) {
    if (tracks.count(thread)) continue;
    std::vector<double> open;  // ends of the enclosing complete events
    double last_start = -1e300;
    for (const auto& event : list) {
      EXPECT_GE(event.start_us, last_start) << "thread " << thread << ": " << event.name << " starts before the event before it";
      last_start = event.start_us;
      if (event.phase != "X") continue;
      while (!open.empty() && event.start_us >= open.back()) open.pop_back();
      if (!open.empty()) {
        EXPECT_LE(event.end_us(), open.back() + 1e-3) << "thread " << thread << ": " << event.name << " overlaps its enclosing event";
      }
      open.push_back(event.end_us());
    }
  }
  return events;
}

std::vector<TraceEvent> named(const std::vector<TraceEvent>& events, const std::string& name) {
  std::vector<TraceEvent> found;
  for (const auto& event : events) {
    if (event.name == name) found.push_back(event);
  }
  return found;
}

std::set<int> threads_of(const std::vector<TraceEvent>& events) {
  std::set<int> threads;
  for (const auto& event : events) threads.insert(event.thread);
  return threads;
}

}  // namespace hdeform::test
