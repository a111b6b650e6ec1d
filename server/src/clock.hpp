#pragma once
// Durations in seconds (as the options give them) to and from the steady clock of timers.
#include <chrono>

namespace facecast::server {

using Clock = std::chrono::steady_clock;

inline double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

inline Clock::duration from_seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace facecast::server
