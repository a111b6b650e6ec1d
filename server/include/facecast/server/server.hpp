#pragma once
// The Facecast server: HTTP (web client, REST API for rigs and jobs, health, metrics) and the
// facecast.v1 WebSocket stream, with Boost.Beast. See docs/protocol.md.
//
//   Server server(options);          // validates, opens the data folder, binds the port
//   server.start();                  // I/O threads in the background (or run() to block)
//   ... server.port() ...
//   server.stop(); server.wait();    // closes every WebSocket with 1001, cancels jobs
//
// Threads: `io_threads` run the network (one strand per connection), `workers` run speech analysis
// and rendering, `job_workers` run rig builds and video renders.
#include <memory>
#include <string>

#include "facecast/server/options.hpp"

namespace facecast::server {

class Server {
 public:
  /// Throws facecast::Error for invalid options, a port that cannot be bound, or an unusable data
  /// folder.
  explicit Server(ServerOptions options);
  ~Server();  // stops and waits
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// The bound port (the chosen one for port 0).
  unsigned short port() const;
  /// http://host:port
  std::string url() const;

  /// SIGINT and SIGTERM call stop(). Call before start()/run().
  void handle_signals();
  /// Starts the I/O threads and returns.
  void start();
  /// start() + wait().
  void run();
  /// Thread-safe and idempotent: stop accepting, close WebSockets with 1001 (going away), close
  /// HTTP connections, cancel jobs; everything is down within shutdown_timeout.
  void stop();
  /// Blocks until the server has stopped (after stop() or a signal).
  void wait();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecast::server
