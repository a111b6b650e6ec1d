#pragma once
// What one peer may hold at once (docs/security.md).
//
// Connections per client address (docs/security.md): one address may hold at most
// max_connections_per_address connections at once, so a burst from one client cannot take the
// slots (max_connections) of everyone else. Behind a proxy the peer is the proxy: when the peer
// is one of trusted_proxies, the client is the last address of X-Forwarded-For that is not a
// trusted proxy itself, counted from the request (HTTP) or the upgrade (WebSocket) on; every
// other peer is the client, and its X-Forwarded-For is ignored. Thread-safe.
#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "beast.hpp"

namespace facecast::server {

class ClientAddresses {
 public:
  ClientAddresses(int max_per_address, const std::vector<std::string>& trusted_proxies);

  /// A counted connection of one address; the count drops when the last copy goes.
  using Hold = std::shared_ptr<void>;

  bool trusted(const net::ip::address& peer) const;
  /// The client behind `peer`: the peer itself, or (from a trusted proxy) the last untrusted
  /// address of `forwarded_for` ("" when the header is missing or malformed: the proxy itself).
  std::string client(const net::ip::address& peer, std::string_view forwarded_for) const;
  /// Counts one connection of `address`; null when it already holds max_per_address.
  Hold hold(const std::string& address);
  /// Connections counted for `address` now.
  int count(const std::string& address);

 private:
  int max_;
  std::vector<net::ip::address> trusted_;
  std::mutex mutex_;
  std::unordered_map<std::string, int> open_;
};

/// Request bodies held in memory at once, all connections together: an upload reserves its
/// Content-Length (a chunked one, its route's limit) before it is read, so that many clients
/// uploading at once cannot make the server hold more than max_body_memory. Thread-safe.
class BodyMemory {
 public:
  explicit BodyMemory(std::size_t budget) : budget_(budget) {}
  /// The reservation lasts while the returned handle (or a copy) lives; null when `bytes` do not
  /// fit now.
  std::shared_ptr<void> reserve(std::size_t bytes);
  std::size_t held() const noexcept { return held_.load(); }

 private:
  std::size_t budget_;
  std::atomic<std::size_t> held_{0};
};

}  // namespace facecast::server
