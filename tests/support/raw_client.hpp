#pragma once
// Raw TCP clients for hostile-client tests and benchmarks: what a well-behaved library would not
// send (pings never followed by a read, idle connections, bodies that never come), from a loopback
// address of the caller's choice so that per-address limits can be told apart. Blocking sockets.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

namespace fctest::raw {

/// A TCP connection from `source` (e.g. "127.0.0.2") to 127.0.0.1:`port`, with SO_RCVBUF set
/// when `receive_buffer` > 0; -1 when refused.
inline int connect_from(const char* source, unsigned short port, int receive_buffer = 0) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (receive_buffer > 0)
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  inet_pton(AF_INET, source, &from.sin_addr);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  if (bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0 ||
      connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

inline bool send_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) return false;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

/// Reads until the blank line that ends an HTTP head (or `timeout` seconds, or the peer closes).
inline std::string read_head(int fd, double timeout) {
  std::string got;
  const auto t0 = std::chrono::steady_clock::now();
  timeval tv{0, 100000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  while (got.find("\r\n\r\n") == std::string::npos &&
         std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(timeout)) {
    char buf[4096];
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n == 0) break;
    if (n > 0) got.append(buf, static_cast<std::size_t>(n));
  }
  return got;
}

/// The WebSocket upgrade request for /ws (no subprotocol, no Origin: not a browser).
inline std::string upgrade_request() {
  return "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
         "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
}

/// A masked client frame (RFC 6455) with a payload under 64 KiB.
inline std::string client_frame(std::uint8_t opcode, std::string_view payload) {
  std::string f;
  f += static_cast<char>(0x80 | opcode);
  if (payload.size() < 126) {
    f += static_cast<char>(0x80 | payload.size());
  } else {
    f += static_cast<char>(0x80 | 126);
    f += static_cast<char>((payload.size() >> 8) & 0xFF);
    f += static_cast<char>(payload.size() & 0xFF);
  }
  const char mask[4] = {0x11, 0x22, 0x33, 0x44};
  f.append(mask, 4);
  for (std::size_t i = 0; i < payload.size(); ++i) f += static_cast<char>(payload[i] ^ mask[i % 4]);
  return f;
}

/// A WebSocket connection from `source` after the upgrade; -1 when refused.
inline int open_websocket(const char* source, unsigned short port, int receive_buffer = 0) {
  const int fd = connect_from(source, port, receive_buffer);
  if (fd < 0) return -1;
  if (!send_all(fd, upgrade_request()) || read_head(fd, 5).rfind("HTTP/1.1 101", 0) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

/// Sends `frame` over and over, never reading, until the server closes the connection (the
/// seconds that took) or `timeout` passes (-1).
inline double flood_until_closed(int fd, const std::string& frame, double timeout) {
  std::string burst;
  while (burst.size() < 8192) burst += frame;
  timeval tv{0, 200000};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  while (elapsed() < timeout) {
    const ssize_t n = send(fd, burst.data(), burst.size(), MSG_NOSIGNAL);
    if (n < 0 && (errno == EPIPE || errno == ECONNRESET)) return elapsed();
    if (n == 0) return elapsed();
  }
  return -1;
}

/// Connects from `source`, upgrades to a WebSocket and sends pings of the largest control payload
/// as fast as the socket takes them, never reading. Returns the seconds until the server closed
/// the connection, or a negative number when it did not within `timeout`.
inline double ping_without_reading(const char* source, unsigned short port, double timeout) {
  const int fd = open_websocket(source, port, 4096);
  if (fd < 0) return -1;
  const double closed_after =
      flood_until_closed(fd, client_frame(0x9, std::string(125, 'p')), timeout);
  close(fd);
  return closed_after;
}

}  // namespace fctest::raw
