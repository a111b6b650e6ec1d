#pragma once
// The subscribers of bench_server's broadcast case, made cheap enough that 10,000 of them fit on
// the same 2 cores as the server: plain sockets, a few threads each with one epoll set, reads of
// up to 256 KB at a time, and WebSocket frames walked by their headers only (server frames are
// unmasked). Of each message only what the measure needs is looked at: the first bytes of a text
// message (is it a stream_start?) and the 24-byte media header of a weights message (pts, count).
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace bench {

class RawSubscribers {
 public:
  struct Totals {
    std::uint64_t frames = 0, on_time = 0, streams = 0;
    std::vector<float> lateness;  // seconds, 1 frame in 16
    int closed = 0;
  };
  /// Connects `n` subscribers of `channel` (WebSocket handshake and subscribe, blocking, spread
  /// over `ramp` seconds); throws std::runtime_error naming what failed.
  RawSubscribers(unsigned short port, const std::string& channel, int n, double ramp, int threads,
                 double fps, double lead);
  ~RawSubscribers();
  /// Starts the reader threads.
  void start();
  /// Stops them and adds up what every subscriber measured.
  Totals stop();
  int connected() const { return static_cast<int>(conns_.size()); }

 private:
  struct Conn;
  void reader(int epfd);
  std::vector<Conn*> conns_;
  std::vector<int> epolls_;
  std::vector<std::thread> threads_;
  std::atomic<bool> stopping_{false};
  double fps_, lead_;
};

}  // namespace bench
