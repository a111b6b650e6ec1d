#include "bench_broadcast_raw.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "facecast/server/protocol.hpp"

namespace bench {
namespace {

using Clock = std::chrono::steady_clock;

// A masked client text frame (RFC 6455: client frames must be masked; the zero mask is allowed).
std::string text_frame(const std::string& payload) {
  std::string f;
  f += static_cast<char>(0x81);
  f += static_cast<char>(0x80 | payload.size());  // payloads here are < 126 bytes
  f.append(4, '\0');
  return f + payload;
}

bool write_small(int fd, const std::string& bytes) {  // a few dozen bytes: one write or failure
  return ::write(fd, bytes.data(), bytes.size()) == static_cast<ssize_t>(bytes.size());
}

}  // namespace

// One subscriber: its connection state, the WebSocket frame being walked and what it measured.
// Only its reader thread touches it once it is in that thread's epoll set.
struct RawSubscribers::Conn {
  enum class State { kConnecting, kHandshake, kOpen, kDone } state = State::kConnecting;
  int fd = -1;
  std::string hs;  // the 101 answer as it arrives
  // Frame walk: header bytes gathered, then the payload (only its first 24 bytes are kept).
  std::uint8_t head[14];
  int head_len = 0, head_need = 2;
  std::uint64_t left = 0;  // payload bytes still to come
  bool in_payload = false, text = false, control = false, fin = false;
  int opcode = 0;  // of the frame being walked (control frames sit between a message's frames)
  char prefix[24];
  int prefix_len = 0;
  std::string text_bytes;   // a text message whole, or a control frame's payload
  Clock::time_point now;    // when the bytes being walked were read
  Clock::time_point start;  // arrival of the current stream_start
  double next_pts = -1;     // pts the next weights message should have (-1: none yet)
  bool counted_subscribed = false, closed = false;
  int close_code = 0;
  Counts counts[2];  // ramp, show
};

RawSubscribers::RawSubscribers(unsigned short port, std::string channel, int threads, double fps,
                               double lead)
    : port_(port), fps_(fps), lead_(lead) {
  upgrade_ =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
      "Sec-WebSocket-Protocol: facecast.v1\r\n\r\n";
  subscribe_ = text_frame(R"({"type":"subscribe","channel":")" + channel + "\"}");
  for (int t = 0; t < std::max(1, threads); ++t) {
    const int e = epoll_create1(EPOLL_CLOEXEC);
    if (e < 0)
      throw std::runtime_error("subscribers: epoll_create1: " + std::string(strerror(errno)));
    epolls_.push_back(e);
  }
  for (int e : epolls_) threads_.emplace_back([this, e] { reader(e); });
}

RawSubscribers::~RawSubscribers() {
  if (!threads_.empty()) stop();
  for (auto* c : conns_) {
    if (c->fd >= 0) ::close(c->fd);
    delete c;
  }
  for (int e : epolls_) ::close(e);
}

void RawSubscribers::connect(int n, double ramp) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port_);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error("subscriber: socket: " + std::string(strerror(errno)));
    auto* c = new Conn;
    c->fd = fd;
    conns_.push_back(c);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 &&
        errno != EINPROGRESS) {
      c->state = Conn::State::kDone;
      failed_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    // Writable once connected: the reader thread sends the upgrade request then.
    epoll_event ev{};
    ev.events = EPOLLOUT;
    ev.data.ptr = c;
    epoll_ctl(epolls_[i % epolls_.size()], EPOLL_CTL_ADD, fd, &ev);
    // Spread over `ramp` seconds (a burst overflows the server's listen backlog).
    if (i % 50 == 49)
      std::this_thread::sleep_until(t0 + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(ramp * (i + 1) / n)));
  }
}

RawSubscribers::Totals RawSubscribers::stop() {
  stopping_ = true;
  for (auto& t : threads_) t.join();
  threads_.clear();
  Totals t;
  for (const auto* c : conns_) {
    for (int p = 0; p < 2; ++p) {
      Counts& to = p == 0 ? t.ramp : t.show;
      const Counts& from = c->counts[p];
      to.frames += from.frames;
      to.on_time += from.on_time;
      to.streams += from.streams;
      to.gaps += from.gaps;
      to.lateness.insert(to.lateness.end(), from.lateness.begin(), from.lateness.end());
    }
    t.connected += c->state == Conn::State::kOpen || c->closed;
    t.subscribed += c->counted_subscribed;
    t.closed += c->closed;
    t.closed_slow += c->closed && c->close_code == 1008;
  }
  t.failed = failed_.load();
  return t;
}

void RawSubscribers::reader(int epfd) {
  std::vector<char> buf(64 * 1024);
  epoll_event events[256];
  // Polled every kPoll, never blocked in epoll_wait: a reader asleep in epoll_wait would be woken
  // by the server's every write (sendmsg on loopback wakes the reader and often switches to it on
  // the server's CPU), a cost remote viewers never put on a server. Adds at most kPoll lateness.
  constexpr auto kPoll = std::chrono::milliseconds(2);
  while (!stopping_.load(std::memory_order_relaxed)) {
    const int n = epoll_wait(epfd, events, 256, 0);
    for (int i = 0; i < n; ++i) {
      Conn& c = *static_cast<Conn*>(events[i].data.ptr);
      if (c.state == Conn::State::kConnecting)
        on_writable(epfd, c);
      else
        on_readable(epfd, c, buf);
    }
    if (n < 256) std::this_thread::sleep_for(kPoll);
  }
}

// Connected (or failed to): send the upgrade request and wait for its answer.
void RawSubscribers::on_writable(int epfd, Conn& c) {
  int err = 0;
  socklen_t len = sizeof err;
  getsockopt(c.fd, SOL_SOCKET, SO_ERROR, &err, &len);
  if (err != 0 || !write_small(c.fd, upgrade_)) {
    c.state = Conn::State::kDone;
    epoll_ctl(epfd, EPOLL_CTL_DEL, c.fd, nullptr);
    failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  c.state = Conn::State::kHandshake;
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.ptr = &c;
  epoll_ctl(epfd, EPOLL_CTL_MOD, c.fd, &ev);
}

void RawSubscribers::on_readable(int epfd, Conn& c, std::vector<char>& buf) {
  const ssize_t got = ::read(c.fd, buf.data(), buf.size());
  if (got < 0 && (errno == EAGAIN || errno == EINTR)) return;
  if (got <= 0) {
    if (c.state == Conn::State::kHandshake) failed_.fetch_add(1, std::memory_order_relaxed);
    c.closed = c.state == Conn::State::kOpen;
    c.state = Conn::State::kDone;
    epoll_ctl(epfd, EPOLL_CTL_DEL, c.fd, nullptr);
    return;
  }
  c.now = Clock::now();
  const char* p = buf.data();
  const char* end = p + got;
  if (c.state == Conn::State::kHandshake) {
    c.hs.append(p, end);
    const auto blank = c.hs.find("\r\n\r\n");
    if (blank == std::string::npos) return;
    if (c.hs.compare(0, 13, "HTTP/1.1 101 ") != 0 || !write_small(c.fd, subscribe_)) {
      c.state = Conn::State::kDone;
      epoll_ctl(epfd, EPOLL_CTL_DEL, c.fd, nullptr);
      failed_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    c.state = Conn::State::kOpen;
    p = end - (c.hs.size() - blank - 4);  // frames that came with the answer
    std::string().swap(c.hs);
  }
  walk(c, p, end);
}

// Walks the WebSocket frames in [p, end): headers byte by byte, payloads skipped but for what
// on_message() needs.
void RawSubscribers::walk(Conn& c, const char* p, const char* end) {
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
      // state is reset only by a first frame; control frames sit between and keep their own.
      c.opcode = c.head[0] & 0x0F;
      c.control = c.opcode >= 8;
      c.fin = (c.head[0] & 0x80) != 0;
      if (c.opcode == 1 || c.opcode == 2) {
        c.text = c.opcode == 1;
        c.prefix_len = 0;
        c.text_bytes.clear();
      }
      c.in_payload = true;
      c.head_len = 0;
      c.head_need = 2;
    }
    const std::size_t take = std::min<std::uint64_t>(c.left, end - p);
    if (c.control) {
      if (c.opcode == 8 && c.prefix_len < 2) {  // the close code: the payload's first 2 bytes
        const int keep = std::min<int>(static_cast<int>(take), 2 - c.prefix_len);
        std::memcpy(c.prefix + c.prefix_len, p, keep);
        c.prefix_len += keep;
      }
    } else if (c.text) {
      c.text_bytes.append(p, take);
    } else if (c.prefix_len < 24) {
      const int keep = std::min<int>(static_cast<int>(take), 24 - c.prefix_len);
      std::memcpy(c.prefix + c.prefix_len, p, keep);
      c.prefix_len += keep;
    }
    p += take;
    c.left -= take;
    if (c.left > 0) continue;
    c.in_payload = false;
    if (c.control) {
      // The server pings a quiet connection (ws_idle_timeout) and closes it without an answer.
      if (c.opcode == 9) {
        static const std::string pong = {'\x8A', '\x80', 0, 0, 0, 0};  // masked, empty
        if (!write_small(c.fd, pong)) c.closed = true;
      } else if (c.opcode == 8) {
        c.close_code = c.prefix_len >= 2 ? (static_cast<std::uint8_t>(c.prefix[0]) << 8 |
                                            static_cast<std::uint8_t>(c.prefix[1]))
                                         : 1005;
        c.closed = true;
      }
      c.prefix_len = 0;
      continue;
    }
    if (c.fin) on_message(c);
  }
}

// One whole message: the schedule of its frames, or a stream boundary.
void RawSubscribers::on_message(Conn& c) {
  const int phase = phase_.load(std::memory_order_relaxed);
  if (c.text) {  // keys are sorted: "type" is near the end
    if (c.text_bytes.find(R"("type":"stream_start")") != std::string::npos) {
      c.start = c.now;
      c.next_pts = -1;
    } else if (c.text_bytes.find(R"("type":"stream_end")") != std::string::npos) {
      if (phase < 2) ++c.counts[phase].streams;
    } else if (!c.counted_subscribed &&
               c.text_bytes.find(R"("type":"subscribed")") != std::string::npos) {
      c.counted_subscribed = true;
      subscribed_.fetch_add(1, std::memory_order_relaxed);
    }
    c.text_bytes.clear();
    return;
  }
  if (c.prefix_len < 24 || phase == 2) return;
  const auto h = facecast::server::read_header(std::string_view(c.prefix, 24));
  if (h.kind != facecast::server::MediaKind::kWeights) return;
  Counts& to = c.counts[phase];
  // Frames the server dropped for this subscriber (drop-oldest) show as a gap in pts.
  if (c.next_pts >= 0 && h.pts > c.next_pts + 0.5 / fps_)
    to.gaps += static_cast<std::uint64_t>(std::lround((h.pts - c.next_pts) * fps_));
  c.next_pts = h.pts + h.count / fps_;
  const double since_start = std::chrono::duration<double>(c.now - c.start).count();
  for (std::uint32_t k = 0; k < h.count; ++k) {
    const double late = since_start - std::max(0.0, h.pts + k / fps_ - lead_);
    ++to.frames;
    to.on_time += late <= 0.050;
    if ((to.frames & 15) == 0) to.lateness.push_back(static_cast<float>(late));
  }
}

}  // namespace bench
