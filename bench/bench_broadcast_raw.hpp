#pragma once
// The subscribers of bench_server's broadcast case, made cheap enough that 10,000 of them fit on
// the same 2 cores as the server, so the figure measures the server, not the load generator:
//  - a few reader threads, each with one epoll set polled every 2 ms (not woken by each write),
//    run from the first connection on: a subscriber's socket is read as soon as it exists, so no
//    early subscriber's queue on the server fills while the others connect (the server's
//    slow-client rule stays: a subscriber that really does not read is closed with 1008, and the
//    bench counts it);
//  - connections are opened non-blocking at the ramp's pace; their WebSocket handshakes and
//    subscribes complete on the reader threads, in parallel;
//  - reads of up to 64 KB at a time, WebSocket frames walked by their headers only (server frames
//    are unmasked); of each message only what the measure needs is looked at: a text message
//    whole (rare: stream_start, stream_end, subscribed, presence) and the 24-byte media header of
//    a weights message (pts, frame count). Audio payloads are skipped.
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace bench {

class RawSubscribers {
 public:
  /// What subscribers measured in one phase (the ramp, or the show).
  struct Counts {
    std::uint64_t frames = 0, on_time = 0, streams = 0;
    std::uint64_t gaps = 0;       // frames missing between consecutive weights messages
    std::vector<float> lateness;  // seconds, 1 frame in 16
  };
  struct Totals {
    Counts ramp, show;
    int connected = 0;                // 101 received
    int subscribed = 0;               // `subscribed` received
    int failed = 0;                   // connect or handshake failed
    int closed = 0, closed_slow = 0;  // closed by the server; of those with 1008 (slow client)
  };
  /// Starts `threads` reader threads for subscribers of `channel` on `port`; a frame is on time
  /// when it arrives within 50 ms of stream_start arrival + pts - lead.
  RawSubscribers(unsigned short port, std::string channel, int threads, double fps, double lead);
  ~RawSubscribers();
  RawSubscribers(const RawSubscribers&) = delete;
  RawSubscribers& operator=(const RawSubscribers&) = delete;

  /// Opens `n` connections (non-blocking) spread over `ramp` seconds; returns once all were
  /// opened (their handshakes go on in the reader threads). Throws std::runtime_error when a
  /// socket cannot be made.
  void connect(int n, double ramp);
  /// Subscribers that received their `subscribed` answer, and those that failed to connect.
  int subscribed() const noexcept { return subscribed_.load(std::memory_order_relaxed); }
  int failed() const noexcept { return failed_.load(std::memory_order_relaxed); }
  /// From now on frames count in Totals::show instead of Totals::ramp.
  void begin_show() noexcept { phase_.store(1, std::memory_order_relaxed); }
  /// Frames after this count nowhere (the show is over).
  void end_show() noexcept { phase_.store(2, std::memory_order_relaxed); }
  /// Stops the reader threads and adds up what every subscriber measured.
  Totals stop();

 private:
  struct Conn;
  void reader(int epfd);
  void on_readable(int epfd, Conn& c, std::vector<char>& buf);
  void on_writable(int epfd, Conn& c);
  void walk(Conn& c, const char* p, const char* end);
  void on_message(Conn& c);

  unsigned short port_;
  std::string upgrade_, subscribe_;
  double fps_, lead_;
  std::vector<Conn*> conns_;  // appended by connect(), read by stop() after the join
  std::vector<int> epolls_;
  std::vector<std::thread> threads_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> phase_{0}, subscribed_{0}, failed_{0};
};

}  // namespace bench
