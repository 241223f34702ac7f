#pragma once
/// @file
/// Elapsed time, as every figure hdeform reports it: the steady clock, in milliseconds (or
/// seconds), one definition for the library, the commands and the editor.
#include <chrono>

namespace hdeform {

/// The clock every figure is measured with.
using SteadyClock = std::chrono::steady_clock;

/// Milliseconds from one time point to another.
inline double milliseconds_between(SteadyClock::time_point from, SteadyClock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}
/// Milliseconds since `start`.
inline double milliseconds_since(SteadyClock::time_point start) { return milliseconds_between(start, SteadyClock::now()); }
/// Seconds since `start`.
inline double seconds_since(SteadyClock::time_point start) { return milliseconds_since(start) / 1000.0; }

}  // namespace hdeform
