#include "bench_broadcast_raw.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "facecast/server/protocol.hpp"

namespace bench {
namespace {

using Clock = std::chrono::steady_clock;

void write_all(int fd, const std::string& bytes) {
  std::size_t at = 0;
  while (at < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + at, bytes.size() - at);
    if (n <= 0) throw std::runtime_error("subscriber: write failed");
    at += static_cast<std::size_t>(n);
  }
}

// A masked client text frame (RFC 6455: client frames must be masked; the zero mask is allowed).
std::string text_frame(const std::string& payload) {
  std::string f;
  f += static_cast<char>(0x81);
  f += static_cast<char>(0x80 | payload.size());  // payloads here are < 126 bytes
  f.append(4, '\0');
  return f + payload;
}

}  // namespace

// One subscriber: the WebSocket frame being walked and what it measured.
struct RawSubscribers::Conn {
  int fd = -1;
  // Frame walk: header bytes gathered, then the payload (only its first 24 bytes are kept).
  std::uint8_t head[14];
  int head_len = 0, head_need = 2;
  std::uint64_t left = 0;  // payload bytes still to come
  bool in_payload = false, text = false;
  bool control = false, fin = false;
  int head_op = 0;  // a ping/pong/close frame; the last frame of a message
  char prefix[24];
  int prefix_len = 0;
  std::string text_bytes;  // a text message whole (rare: stream_start, stream_end, presence)
  Clock::time_point start;
  std::uint64_t frames = 0, on_time = 0, streams = 0;
  std::vector<float> lateness;
  bool closed = false;
};

RawSubscribers::RawSubscribers(unsigned short port, const std::string& channel, int n, double ramp,
                               int threads, double fps, double lead)
    : fps_(fps), lead_(lead) {
  const std::string upgrade =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
      "Sec-WebSocket-Protocol: facecast.v1\r\n\r\n";
  const std::string subscribe = text_frame(R"({"type":"subscribe","channel":")" + channel + "\"}");
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) throw std::runtime_error("subscriber: socket: " + std::string(strerror(errno)));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw std::runtime_error("subscriber " + std::to_string(i) + ": connect: " + strerror(errno));
    write_all(fd, upgrade);
    // The 101 answer: read byte by byte up to its blank line, so no frame is consumed here.
    std::string answer;
    char c;
    while (answer.size() < 4 || answer.compare(answer.size() - 4, 4, "\r\n\r\n") != 0) {
      if (::read(fd, &c, 1) != 1) throw std::runtime_error("subscriber: handshake closed");
      answer += c;
    }
    if (answer.find(" 101 ") == std::string::npos)
      throw std::runtime_error("subscriber: handshake refused: " + answer.substr(0, 40));
    write_all(fd, subscribe);
    auto* conn = new Conn;
    conn->fd = fd;
    conns_.push_back(conn);
    // Spread over `ramp` seconds (a burst overflows the server's listen backlog).
    const auto due = t0 + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(ramp * (i + 1) / n));
    if (i % 100 == 99) std::this_thread::sleep_until(due);
  }
  for (int t = 0; t < std::max(1, threads); ++t) epolls_.push_back(epoll_create1(0));
  for (std::size_t i = 0; i < conns_.size(); ++i) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.ptr = conns_[i];
    epoll_ctl(epolls_[i % epolls_.size()], EPOLL_CTL_ADD, conns_[i]->fd, &ev);
  }
}

RawSubscribers::~RawSubscribers() {
  if (!threads_.empty()) stop();
  for (auto* c : conns_) {
    ::close(c->fd);
    delete c;
  }
  for (int e : epolls_) ::close(e);
}

void RawSubscribers::start() {
  for (int e : epolls_) threads_.emplace_back([this, e] { reader(e); });
}

RawSubscribers::Totals RawSubscribers::stop() {
  stopping_ = true;
  for (auto& t : threads_) t.join();
  threads_.clear();
  Totals t;
  for (const auto* c : conns_) {
    t.frames += c->frames;
    t.on_time += c->on_time;
    t.streams += c->streams;
    t.closed += c->closed;
    t.lateness.insert(t.lateness.end(), c->lateness.begin(), c->lateness.end());
  }
  return t;
}

void RawSubscribers::reader(int epfd) {
  std::vector<char> buf(256 * 1024);
  epoll_event events[256];
  while (!stopping_) {
    const int n = epoll_wait(epfd, events, 256, 100);
    for (int i = 0; i < n; ++i) {
      Conn& c = *static_cast<Conn*>(events[i].data.ptr);
      const ssize_t got = ::read(c.fd, buf.data(), buf.size());
      if (got <= 0) {
        c.closed = true;
        epoll_ctl(epfd, EPOLL_CTL_DEL, c.fd, nullptr);
        continue;
      }
      const auto now = Clock::now();
      const char* p = buf.data();
      const char* end = p + got;
      while (p < end) {
        if (!c.in_payload) {  // gather the frame header: 2 bytes, then its length bytes
          c.head[c.head_len++] = static_cast<std::uint8_t>(*p++);
          if (c.head_len == 2) {
            const int len7 = c.head[1] & 0x7F;
            c.head_need = 2 + (len7 == 126 ? 2 : len7 == 127 ? 8 : 0);
          }
          if (c.head_len < c.head_need) continue;
          const int len7 = c.head[1] & 0x7F;
          c.left = len7;
          if (len7 >= 126) {
            c.left = 0;
            for (int k = 2; k < c.head_need; ++k) c.left = c.left << 8 | c.head[k];
          }
          // Messages may come in several frames (opcode 0 continues the message): the message
          // state is reset only by a first frame; control frames sit between and are skipped.
          const int opcode = c.head[0] & 0x0F;
          c.control = opcode >= 8;
          c.head_op = opcode;
          c.fin = (c.head[0] & 0x80) != 0;
          if (opcode == 1 || opcode == 2) {
            c.text = opcode == 1;
            c.prefix_len = 0;
            c.text_bytes.clear();
          }
          c.in_payload = true;
          c.head_len = 0;
          c.head_need = 2;
        }
        const std::size_t take = std::min<std::uint64_t>(c.left, end - p);
        if (c.control) {
        } else if (c.text) {
          c.text_bytes.append(p, take);
        } else {
          const int keep = std::min<int>(static_cast<int>(take), 24 - c.prefix_len);
          std::memcpy(c.prefix + c.prefix_len, p, keep);
          c.prefix_len += keep;
        }
        p += take;
        c.left -= take;
        if (c.left > 0) continue;
        c.in_payload = false;
        // The server pings a quiet connection (ws_idle_timeout) and closes it without an answer.
        if (c.control && (c.head_op == 9)) {
          static const char pong[] = {'\x8A', '\x80', 0, 0, 0, 0};  // masked, empty
          if (::write(c.fd, pong, sizeof pong) < 0) c.closed = true;
        }
        if (c.control || !c.fin) continue;
        const std::string_view m(c.prefix, c.prefix_len);
        if (c.text) {  // keys are sorted: "type" is near the end
          if (c.text_bytes.find(R"("type":"stream_start")") != std::string::npos) c.start = now;
          if (c.text_bytes.find(R"("type":"stream_end")") != std::string::npos) ++c.streams;
          c.text_bytes.clear();
        } else if (c.prefix_len == 24) {
          const auto h = facecast::server::read_header(m);
          if (h.kind != facecast::server::MediaKind::kWeights) continue;
          for (std::uint32_t k = 0; k < h.count; ++k) {
            const double late = std::chrono::duration<double>(now - c.start).count() -
                                std::max(0.0, h.pts + k / fps_ - lead_);
            ++c.frames;
            c.on_time += late <= 0.050;
            if ((c.frames & 15) == 0) c.lateness.push_back(static_cast<float>(late));
          }
        }
      }
    }
  }
}

}  // namespace bench
