#pragma once
// Durations in seconds (as the options give them) to and from the steady clock of timers; the
// wall clock in seconds since the epoch (what job records, keys and tokens store).
#include <chrono>

namespace facecast::server {

using Clock = std::chrono::steady_clock;

inline double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

inline Clock::duration from_seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

/// Seconds since 1970-01-01 UTC (the system clock).
inline double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace facecast::server
