// Hostile clients against a real `facecast serve` on loopback (docs/security.md). Each case runs
// one attack class and asserts: a clear error or close within seconds, the server's RSS bounded,
// /healthz answering within 1 s throughout, and a well-behaved client speaking afterwards with its
// frames on time.

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <thread>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/wav.hpp"
#include "raw_client.hpp"
#include "serve_process.hpp"
#include "test_data.hpp"

using namespace fctest;
using namespace fctest::raw;
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
    serve_.emplace(facecast::test::facecast_exe().string(),
                   std::vector<std::string>{"--config", (dir_ / "server.json").string(), "--data",
                                            (dir_ / "data").string()},
                   30 * slowdown(), (dir_ / "serve.log").string());
    REQUIRE(wait_until_ready(port(), 30 * slowdown()));
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
    // Sanitizers keep shadow memory and quarantines: their RSS grows several times faster.
    CHECK(rss_growth() < max_growth_mb * slowdown());
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
    const auto m = c.read(10 * slowdown());
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
  for (const auto& p : pieces) CHECK(facecast::utf8_length(p) <= 60);
  c.send(json{{"type", "cancel"}, {"id", "u"}});
  json end;
  while (end["type"] != "stream_end") end = c.read_json(10 * slowdown());
  CHECK(end["cancelled"] == true);
  t.check_unharmed();
}

TEST_CASE("hostile: a peer that pings and never reads is closed", "[hostile][ws]") {
  Target t;
  const double closed_after = ping_without_reading("127.0.0.2", t.port(), 20 * slowdown());
  INFO("closed after " << closed_after << " s");
  CHECK(closed_after >= 0);
  CHECK(closed_after < 5 * slowdown());
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
  // (A read that times out leaves the client closed: wait once, for all of the time.)
  while (!c.closed() && since(t0) < 10 * slowdown()) c.read(10 * slowdown() - since(t0));
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
    const auto m = c.read(20 * slowdown() - since(t0));
    if (!m || !m->text) continue;
    const json j = m->json();
    if (j["type"] == "error" && j["code"] == "unavailable") ++unavailable;
  }
  INFO("serve.log:\n" << t.log());
  CHECK(unavailable >= 3);
  c.close();
  t.check_unharmed(300);
}

TEST_CASE("hostile: live audio may not run far ahead of real time", "[hostile][ws][audio]") {
  Target t(json{{"live_audio_ahead", 3}});
  WsClient c(t.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  // 1 s chunks of a 200 Hz tone at 16 kHz, 12 at once: the 4th and later are over 3 s ahead.
  constexpr std::uint32_t kRate = 16000;
  std::vector<std::int16_t> pcm(kRate);
  for (std::size_t i = 0; i < pcm.size(); ++i)
    pcm[i] = static_cast<std::int16_t>(8000 * std::sin(2 * M_PI * 200 * i / kRate));
  for (std::uint32_t k = 0; k < 12; ++k) {
    std::string b(24 + 2 * pcm.size(), '\0');
    b[0] = 4, b[1] = 1;
    const auto put = [&](std::size_t at, std::uint32_t v) {
      for (int i = 0; i < 4; ++i)
        b[at + static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * i));
    };
    put(4, kRate);
    put(8, k * kRate);
    put(12, kRate);
    std::memcpy(b.data() + 24, pcm.data(), 2 * pcm.size());
    c.send_binary(b);
  }
  // The first chunk over the limit is refused naming it; the later ones no longer follow on.
  std::vector<json> errors;
  const auto t0 = Clock::now();
  while (since(t0) < 5 * slowdown()) {
    const auto m = c.read(5 * slowdown() - since(t0));
    if (!m || !m->text) continue;
    const json j = m->json();
    if (j["type"] == "error") errors.push_back(j);
  }
  const int refused = static_cast<int>(errors.size());
  REQUIRE(refused > 0);
  CHECK(errors[0]["code"] == "rate_limited");
  CHECK(errors[0]["message"].get<std::string>().find("live_audio_ahead (3 s)") !=
        std::string::npos);
  CHECK(refused >= 8);
  c.close();
  t.check_unharmed();
}

TEST_CASE("hostile: imports, audio decodes and photo landmarks count against max_jobs",
          "[hostile][http][jobs]") {
  Target t(json{{"max_jobs", 1}, {"job_workers", 1}});
  // One long render job holds the only slot.
  const auto job = http_request(t.port(), http::verb::post, "/api/render",
                                json{{"text", std::string(60, 'a') + " and more words, again."},
                                     {"size", {320, 240}},
                                     {"fps", 30}}
                                    .dump(),
                                {{"Content-Type", "application/json"}});
  REQUIRE(job.status == 202);
  // Work done within a request is refused while it runs, naming what and the limit.
  const std::string wav = facecast::encode_wav(std::vector<std::int16_t>(16000, 0), 16000);
  const auto audio =
      http_request(t.port(), http::verb::post, "/api/audio", wav, {{"Content-Type", "audio/wav"}});
  CHECK(audio.status == 429);
  CHECK(audio.body.find("audio decode") != std::string::npos);
  CHECK(audio.body.find("max_jobs 1") != std::string::npos);
  // Once the job has ended, the decode goes through.
  const auto t0 = Clock::now();
  int status = 0;
  while (since(t0) < 120 * slowdown() && status != 201) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    status =
        http_request(t.port(), http::verb::post, "/api/audio", wav, {{"Content-Type", "audio/wav"}})
            .status;
  }
  CHECK(status == 201);
  t.check_unharmed(300);  // the render job itself: a renderer and an encoder
}
