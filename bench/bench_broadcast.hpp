#pragma once
// bench_server's broadcast case (bench_broadcast.cpp): one channel, many subscribers.
#include <sys/types.h>

#include <string>

namespace bench {

struct BroadcastArgs {
  int subscribers = 10000;
  double seconds = 60, ramp = 10, fps = 60;
  int client_threads = 1;
  std::string channel = "bench", token = "bench-producer-token";
};

/// Connects `subscribers` clients to channel `channel` of the server on `port` (process `pid`),
/// then a producer speaks (60 fps weights with audio) utterance after utterance for `seconds`.
/// Prints, for the ramp and for the show: frames, the share within 50 ms of their schedule,
/// lateness percentiles, frames the server dropped; then subscribers closed by the server, the
/// server's RSS peak and CPU (per second of show and per frame delivered), the load generator's
/// CPU and the load average before and after.
void run_broadcast(const BroadcastArgs& a, unsigned short port, pid_t pid);

/// GET `target` from the server on `port`: the body.
std::string http_get(unsigned short port, const std::string& target);

}  // namespace bench
