// Hostile clients against a real `facecast serve` on loopback (docs/security.md). Each case runs
// one attack class and asserts: a clear error or close within seconds, the server's RSS bounded,
// /healthz answering within 1 s throughout, and a well-behaved client speaking afterwards with its
// frames on time.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <fstream>
#include <thread>

#include "client.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "serve_process.hpp"
#include "test_data.hpp"

using namespace fctest;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Resident memory of process `pid` in MB.
double rss_mb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("VmRSS:")) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0;
}

// `facecast serve` with the shipped config and `tweak`s over it, plus a thread that asks
// /healthz every 100 ms and keeps the slowest answer.
class Target {
 public:
  explicit Target(const json& tweak = json::object()) {
    dir_ = facecast::test::scratch_dir() / "hostile";
    std::filesystem::remove_all(dir_);
    json config = facecast::load_json(facecast::config_path("server.json"));
    config["log_level"] = "info";  // the cases look for warnings; the log is shown on failure
    config["http_timeout"] = 3;
    for (const auto& [k, v] : tweak.items()) config[k] = v;
    facecast::write_file_atomic(dir_ / "server.json", config.dump(2));
    serve_.emplace(FACECAST_EXE,
                   std::vector<std::string>{"--config", (dir_ / "server.json").string(), "--data",
                                            (dir_ / "data").string()},
                   30 * slowdown(), (dir_ / "serve.log").string());
    for (int i = 0; i < 200 && http_request(port(), http::verb::get, "/readyz").status != 200; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    rss0_ = rss_mb(serve_->pid());
    watch_ = std::thread([this] {
      while (!stop_) {
        const auto t0 = Clock::now();
        int status = 0;
        try {
          status = http_request(port(), http::verb::get, "/healthz", {}, {}, 5).status;
        } catch (...) {
        }
        const double s = since(t0);
        if (status != 200) ++health_failures_;
        slowest_ = std::max(slowest_.load(), s);
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    });
  }
  ~Target() {
    stop_ = true;
    watch_.join();
  }
  unsigned short port() const { return serve_->port(); }
  pid_t pid() const { return serve_->pid(); }
  double rss_growth() const { return rss_mb(serve_->pid()) - rss0_; }
  double slowest_health() const { return slowest_; }
  int health_failures() const { return health_failures_; }
  std::string log() const { return facecast::read_file(dir_ / "serve.log"); }

  // What every case ends with.
  void check_unharmed(double max_growth_mb = 100) {
    INFO("serve.log:\n" << log());
    CHECK(rss_growth() < max_growth_mb);
    CHECK(health_failures() == 0);
    CHECK(slowest_health() < 1.0 * slowdown());
    speaks_on_time();
  }

  // A well-behaved client: its utterance plays whole and its weights arrive in real time.
  void speaks_on_time() {
    WsClient c(port());
    REQUIRE(c.read_json(10)["type"] == "hello");
    c.send(json{{"type", "speak"}, {"id", "fine"}, {"audio", false}, {"text", "Still here."}});
    const auto r = collect_stream(c, "fine", 30 * slowdown());
    REQUIRE_FALSE(r.error);
    REQUIRE(r.weights.size() > 10);
    CHECK(r.end["cancelled"] == false);
    // On time: stream_start comes `lead` before the stream's zero and each frame `lead` before
    // its pts, so no frame may arrive later than stream_start + pts (+ 50 ms; x slowdown under
    // sanitizers).
    double worst = 0;
    for (const auto& w : r.weights)
      worst =
          std::max(worst, std::chrono::duration<double>(w.at - r.start_at).count() - w.header.pts);
    CHECK(worst < 0.05 + 0.25 * (slowdown() - 1));
  }

 private:
  std::filesystem::path dir_;
  std::optional<ServeProcess> serve_;
  double rss0_ = 0;
  std::thread watch_;
  std::atomic<bool> stop_{false};
  std::atomic<double> slowest_{0};
  std::atomic<int> health_failures_{0};
};

// A TCP connection from `source` (a loopback address of its own, so that per-address limits do
// not count the well-behaved client) with a small receive buffer; -1 when refused.
int connect_from(const char* source, unsigned short port, int receive_buffer = 0) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (receive_buffer > 0)
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  inet_pton(AF_INET, source, &a.sin_addr);
  bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  if (connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

bool send_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) return false;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

// Reads an HTTP answer's head (until the blank line) with a timeout.
std::string read_head(int fd, double timeout) {
  std::string got;
  const auto t0 = Clock::now();
  timeval tv{0, 100000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  while (got.find("\r\n\r\n") == std::string::npos && since(t0) < timeout) {
    char buf[4096];
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n == 0) break;
    if (n > 0) got.append(buf, static_cast<std::size_t>(n));
  }
  return got;
}

// A masked client frame (RFC 6455) with a payload under 126 bytes.
std::string client_frame(std::uint8_t opcode, std::string_view payload) {
  std::string f;
  f += static_cast<char>(0x80 | opcode);
  f += static_cast<char>(0x80 | payload.size());
  const char mask[4] = {0x11, 0x22, 0x33, 0x44};
  f.append(mask, 4);
  for (std::size_t i = 0; i < payload.size(); ++i) f += static_cast<char>(payload[i] ^ mask[i % 4]);
  return f;
}

}  // namespace

TEST_CASE("hostile: timestamps that end at 1e9 s are refused at once", "[hostile][ws]") {
  Target t;
  WsClient c(t.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  const auto t0 = Clock::now();
  c.send(
      json{{"type", "speak"},
           {"id", "long"},
           {"timestamps", {{"format", "polly"}, {"data", R"({"time":0,"type":"viseme","value":"p"}
{"time":1000000000000,"type":"viseme","value":"a"})"}}}});
  const json e = c.read_json(5 * slowdown());
  CHECK(e["type"] == "error");
  CHECK(e["code"] == "limit");
  CHECK(e["message"].get<std::string>().find("max_utterance_seconds") != std::string::npos);
  CHECK(since(t0) < 2 * slowdown());
  t.check_unharmed();
}

TEST_CASE("hostile: append is bounded by max_text per utterance and max_piece per piece",
          "[hostile][ws][incremental]") {
  Target t(json{{"max_text", 300}, {"max_piece", 60}});
  WsClient c(t.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  c.send(json{{"type", "speak"}, {"id", "u"}, {"audio", false}, {"text", "Hello"}, {"more", true}});
  // 250 more characters without a sentence end: accepted, cut into pieces of <= 60.
  std::string words;
  while (words.size() < 250) words += " lorem";
  c.send(json{{"type", "append"}, {"id", "u"}, {"text", words}});
  // Past max_text: refused with a one-line error naming the limit, the utterance still open.
  c.send(json{{"type", "append"}, {"id", "u"}, {"text", std::string(60, 'x')}});
  c.send(json{{"type", "end"}, {"id", "u"}});
  std::optional<json> error;
  std::vector<std::string> pieces;
  const auto t0 = Clock::now();
  while (since(t0) < 30 * slowdown() && (pieces.size() < 3 || !error)) {
    const auto m = c.read(5);
    REQUIRE(m);
    if (!m->text) continue;
    const json j = m->json();
    if (j["type"] == "error") error = j;
    if (j["type"] == "stream_start" || j["type"] == "segment")
      pieces.push_back(j["utterance"]["text"]);
  }
  REQUIRE(error);
  CHECK((*error)["code"] == "limit");
  CHECK((*error)["message"].get<std::string>().find("the limit is 300") != std::string::npos);
  REQUIRE(pieces.size() >= 3);
  for (const auto& p : pieces) CHECK(facecast::server::utf8_length(p) <= 60);
  c.send(json{{"type", "cancel"}, {"id", "u"}});
  json end;
  while (end["type"] != "stream_end") end = c.read_json(10 * slowdown());
  CHECK(end["cancelled"] == true);
  t.check_unharmed();
}

TEST_CASE("hostile: a peer that pings and never reads is closed", "[hostile][ws]") {
  Target t;
  const int fd = connect_from("127.0.0.2", t.port(), 4096);
  REQUIRE(fd >= 0);
  REQUIRE(send_all(fd,
                   "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: "
                   "Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                   "Sec-WebSocket-Version: 13\r\n\r\n"));
  REQUIRE(read_head(fd, 5).starts_with("HTTP/1.1 101"));
  // Pings with the largest control payload, as fast as the socket takes them, never reading.
  const std::string ping = client_frame(0x9, std::string(125, 'p'));
  std::string burst;
  for (int i = 0; i < 64; ++i) burst += ping;
  const auto t0 = Clock::now();
  std::size_t sent = 0;
  timeval tv{0, 200000};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  bool closed = false;
  while (since(t0) < 20 * slowdown()) {
    const ssize_t n = send(fd, burst.data(), burst.size(), MSG_NOSIGNAL);
    if (n < 0 && (errno == EPIPE || errno == ECONNRESET)) {
      closed = true;
      break;
    }
    if (n > 0) sent += static_cast<std::size_t>(n);
  }
  close(fd);
  INFO("sent " << sent << " bytes of pings in " << since(t0) << " s");
  CHECK(closed);
  CHECK(t.log().find("ws_control_overflow") != std::string::npos);
  t.check_unharmed();
}

TEST_CASE("hostile: a message flood is closed with 1008", "[hostile][ws]") {
  Target t(json{{"messages_per_second", 50}, {"message_burst", 100}});
  WsClient c(t.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  for (int i = 0; i < 2000 && !c.closed(); ++i) {
    try {
      c.send(json{{"type", "ping"}, {"t", i}});
    } catch (...) {
      break;
    }
  }
  const auto t0 = Clock::now();
  while (!c.closed() && since(t0) < 10 * slowdown()) c.read(1);
  CHECK(c.closed());
  CHECK(c.close_code() == 1008);
  t.check_unharmed();
}

TEST_CASE("hostile: a burst of idle connections from one address leaves the others their slots",
          "[hostile][http]") {
  Target t(json{{"max_connections_per_address", 50}});
  std::vector<int> held;
  int refused = 0;
  for (int i = 0; i < 300; ++i) {
    const int fd = connect_from("127.0.0.3", t.port());
    if (fd < 0) {
      ++refused;
      continue;
    }
    held.push_back(fd);
  }
  // Past 50, each is answered 503 at once, naming the limit, without sending a byte first.
  const std::string head = read_head(held.back(), 5 * slowdown());
  CHECK(head.starts_with("HTTP/1.1 503"));
  std::string body;
  char buf[512];
  const ssize_t n = recv(held.back(), buf, sizeof buf, 0);
  if (n > 0) body.assign(buf, static_cast<std::size_t>(n));
  CHECK((head + body).find("max_connections_per_address") != std::string::npos);
  t.check_unharmed();
  for (const int fd : held) close(fd);
}

TEST_CASE("hostile: uploads at once are bounded by max_body_memory", "[hostile][http]") {
  Target t(json{{"max_upload", 1 << 20}, {"max_body_memory", 2 << 20}});
  // Two uploads that announce 1 MiB and send it slowly hold the budget; the third is refused.
  std::vector<int> slow;
  for (int i = 0; i < 2; ++i) {
    const int fd = connect_from("127.0.0.4", t.port());
    REQUIRE(fd >= 0);
    REQUIRE(send_all(fd,
                     "POST /api/rigs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
                     "model/gltf-binary\r\nContent-Length: 1048576\r\n\r\nglTF"));
    slow.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int fd = connect_from("127.0.0.4", t.port());
  REQUIRE(fd >= 0);
  REQUIRE(send_all(fd,
                   "POST /api/rigs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
                   "model/gltf-binary\r\nContent-Length: 1048576\r\n\r\nglTF"));
  const std::string head = read_head(fd, 5 * slowdown());
  CHECK(head.starts_with("HTTP/1.1 503"));
  close(fd);
  for (const int s : slow) close(s);
  t.check_unharmed();
}

TEST_CASE("hostile: frames-mode renderers in use are bounded by max_renderers", "[hostile][ws]") {
  Target t(json{{"max_renderers", 2}});
  WsClient c(t.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  // Each size is a renderer of its own; queued streams hold theirs.
  for (int i = 0; i < 6; ++i) {
    c.send(json{{"type", "speak"},
                {"id", "f" + std::to_string(i)},
                {"audio", false},
                {"output", "frames"},
                {"size", {64 + 16 * i, 64}},
                {"text", "One two three four five."}});
  }
  int unavailable = 0;
  const auto t0 = Clock::now();
  while (since(t0) < 20 * slowdown() && unavailable < 4) {
    const auto m = c.read(2);
    if (!m || !m->text) continue;
    const json j = m->json();
    if (j["type"] == "error" && j["code"] == "unavailable") ++unavailable;
  }
  INFO("serve.log:\n" << t.log());
  CHECK(unavailable >= 3);
  c.close();
  t.check_unharmed(300);
}
