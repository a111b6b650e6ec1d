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
/// Prints the share of frames within 50 ms of their schedule, lateness percentiles, the server's
/// RSS and CPU.
void run_broadcast(const BroadcastArgs& a, unsigned short port, pid_t pid);

}  // namespace bench
