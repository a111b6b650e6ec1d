#pragma once
// The server's life and its live connections: whether it is ready or stopping, the ids it hands
// out, and the sessions it can ask to close at shutdown (Beast chat-multi's session list).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>

namespace facecast::server {

/// A live connection the server can ask to close (from any thread).
class Closable {
 public:
  virtual ~Closable() = default;
  /// WebSockets: close with 1001 (going away); HTTP: close the socket.
  virtual void shut_down() = 0;
};

class Sessions {
 public:
  std::atomic<bool> stopping{false};  // draining or shutting down: /readyz answers 503
  std::atomic<bool> ready{false};     // warmed up: /readyz answers 200
  std::atomic<long> connections{0};   // accepted sockets open now

  /// Ids of connections and channel members ("c12"), and of streams (stream_start).
  std::uint64_t new_connection_id() noexcept { return next_connection_.fetch_add(1); }
  std::uint32_t new_stream_id() noexcept { return next_stream_.fetch_add(1); }
  /// The next stream id, not taken (seeds and default utterance ids).
  std::uint32_t peek_stream_id() const noexcept { return next_stream_.load(); }

  /// Seconds since the server started.
  double uptime() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }

  void add(std::uint64_t id, std::weak_ptr<Closable> session);
  void remove(std::uint64_t id);
  /// Asks every live session to close.
  void shut_down_all();

 private:
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::atomic<std::uint64_t> next_connection_{1};
  std::atomic<std::uint32_t> next_stream_{1};
  std::mutex mutex_;
  std::unordered_map<std::uint64_t, std::weak_ptr<Closable>> sessions_;
};

}  // namespace facecast::server
