// Shutdown with clients connected: in-process stop() and the real `facecast serve` on SIGTERM.
#include <catch2/catch.hpp>

#include "build_paths.hpp"
#include "client.hpp"
#include "serve_process.hpp"
#include "test_data.hpp"

using namespace fctest;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Reads WebSocket messages until the server closes; returns the close code.
int read_until_closed(WsClient& c, double timeout) {
  const auto t0 = Clock::now();
  while (!c.closed() && since(t0) < timeout) (void)c.read(timeout);
  return c.close_code();
}

}  // namespace

TEST_CASE("stop closes every WebSocket with 1001 and returns quickly", "[lifecycle]") {
  TestServer s;
  WsClient a(s.port()), b(s.port());
  CHECK(a.read_json(10)["type"] == "hello");
  CHECK(b.read_json(10)["type"] == "hello");
  a.send(nlohmann::json{{"type", "speak"},
                        {"id", "talking"},
                        {"audio", false},
                        {"text", "I am in the middle of a long sentence when the server stops."}});
  b.send(nlohmann::json{{"type", "speak"},
                        {"id", "frames"},
                        {"audio", false},
                        {"output", "frames"},
                        {"size", {160, 120}},
                        {"text", "And I get frames."}});
  // Both are streaming.
  for (auto* c : {&a, &b}) {
    for (;;) {
      auto m = c->read(20 * slowdown());
      REQUIRE(m);
      if (!m->text) break;
    }
  }
  const auto t0 = Clock::now();
  s.server().stop();
  CHECK(read_until_closed(a, 5) == 1001);
  CHECK(read_until_closed(b, 5) == 1001);
  s.server().wait();
  CHECK(since(t0) < 3.0 * slowdown());
  // Nothing listens any more.
  CHECK_THROWS(http_request(s.port(), http::verb::get, "/healthz", {}, {}, 2));
}

TEST_CASE("facecast serve drains on SIGTERM: the utterance finishes, then 1001", "[lifecycle]") {
  const auto data = facecast::test::scratch_dir() / "serve-data";
  ServeProcess serve(facecast::test::facecast_exe().string(),
                     {"--data", data.string(), "--log-level", "warn"}, 30 * slowdown());
  CHECK(serve.line().starts_with("facecast: listening on http://127.0.0.1:"));
  const auto port = serve.port();
  CHECK(port != 0);
  CHECK(port != 8080);
  // Ready once warmed up.
  CHECK(wait_until_ready(port, 30 * slowdown()));
  CHECK(http_request(port, http::verb::get, "/readyz").json()["status"] == "ready");
  {
    WsClient c(port);
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "speak"},
                          {"id", "s"},
                          {"audio", false},
                          {"text", "Still talking when the signal comes."}});
    nlohmann::json start;
    for (;;) {
      auto msg = c.read(20 * slowdown());
      REQUIRE(msg);
      if (!msg->text) break;
      start = msg->json();
    }
    REQUIRE(start["type"] == "stream_start");
    WsClient idle(port);
    CHECK(idle.read_json(10)["type"] == "hello");
    const auto t1 = Clock::now();
    REQUIRE(kill(serve.pid(), SIGTERM) == 0);
    // Draining: a new utterance is refused, the running one plays to its end, then 1001.
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    idle.send(nlohmann::json{{"type", "speak"}, {"id", "late"}, {"text", "Too late."}});
    CHECK(idle.read_json(5)["code"] == "unavailable");
    const auto r = collect_stream(c, "s", 20 * slowdown(), &start);
    CHECK(r.end["cancelled"] == false);
    CHECK(r.end["frames"].get<int>() + r.end["dropped"].get<int>() == start["frames"].get<int>());
    CHECK(read_until_closed(c, 5) == 1001);
    CHECK(read_until_closed(idle, 5) == 1001);
    const auto status = serve.wait_exit(15 * slowdown() - since(t1));
    if (!status || !WIFEXITED(*status)) FAIL("facecast serve did not exit after draining");
    CHECK(WEXITSTATUS(*status) == 0);
  }
}
