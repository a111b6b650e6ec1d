// The facecast.v1 WebSocket's limits against the real server: bad and oversized messages, rate
// limits, the Origin check, and slow readers next to a healthy client.
#include <algorithm>
#include <catch2/catch.hpp>
#include <thread>

#include "client.hpp"

using namespace fctest;
using facecast::server::ServerOptions;

TEST_CASE("bad messages get an error and the connection stays usable", "[ws][errors]") {
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  struct Case {
    std::string message, code, contains;
    nlohmann::json id;
  };
  const std::vector<Case> cases = {
      {"this is not json", "invalid_input", "malformed JSON", nullptr},
      {R"({"type":"speak","id":"a1"})", "invalid_input", "exactly one of text", "a1"},
      {R"({"type":"speak","id":"a2","text":42})", "invalid_input", "text: expected a string", "a2"},
      {R"({"type":"speak","id":"a3","text":"hi","fps":"fast"})", "invalid_input", "fps", "a3"},
      {R"({"type":"speak","id":"a4","text":"hi","rig":"nobody"})", "not_found", "rig 'nobody'",
       "a4"},
      {R"({"type":"speak","id":"a5","text":"(happy, 40, 0.5)hi","audio":false})", "invalid_input",
       "happy", "a5"},
      {R"({"type":"jump"})", "invalid_input", "unknown message type", nullptr},
      {R"({"type":"speak","id":"a6","text":"hi","voice":"xx-nonexistent"})", "invalid_input", "",
       "a6"},
  };
  for (const auto& k : cases) {
    INFO(k.message);
    c.send(k.message);
    const auto e = c.read_json(20 * slowdown());
    CHECK(e["type"] == "error");
    CHECK(e["id"] == k.id);
    if (k.code != "invalid_input" || k.id != "a6") CHECK(e["code"] == k.code);
    CHECK_THAT(e["message"].get<std::string>(), Catch::Contains(k.contains));
  }
  // Binary messages are not part of the protocol.
  // (sent through the same client: a text ping proves the connection is still fine)
  c.send(nlohmann::json{{"type", "ping"}, {"t", 12.5}});
  const auto pong = c.read_json(10);
  CHECK(pong["type"] == "pong");
  CHECK(pong["t"] == 12.5);
  CHECK(pong["server_time"].get<double>() > 0);
  c.send(
      nlohmann::json{{"type", "speak"}, {"id", "good"}, {"text", "Still here."}, {"audio", false}});
  const auto r = collect_stream(c, "good");
  CHECK_FALSE(r.error);
  CHECK(r.end["frames"] == r.start["frames"]);
  // The same id twice while it is queued or playing is refused.
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "dup"}, {"text", "one two three four five"}, {"audio", false}});
  c.send(nlohmann::json{{"type", "speak"}, {"id", "dup"}, {"text", "again"}, {"audio", false}});
  bool refused = false;
  for (;;) {
    const auto j = c.read_json(20 * slowdown());
    if (j["type"] == "error") {
      CHECK(j["id"] == "dup");
      CHECK_THAT(j["message"].get<std::string>(), Catch::Contains("already playing or queued"));
      refused = true;
    }
    if (j["type"] == "stream_end") break;
  }
  CHECK(refused);
}

TEST_CASE("text over the limit is an error, a message over the limit closes with 1009",
          "[ws][limits]") {
  TestServer s([](ServerOptions& o) {
    o.max_text = 50;
    o.max_message = 4096;
  });
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  c.send(nlohmann::json{{"type", "speak"}, {"id", "big"}, {"text", std::string(51, 'a')}});
  auto e = c.read_json(10);
  CHECK(e["type"] == "error");
  CHECK(e["id"] == "big");
  CHECK(e["code"] == "limit");
  c.send(nlohmann::json{{"type", "ping"}});
  CHECK(c.read_json(10)["type"] == "pong");
  // 5000 bytes > max_message: the server closes with 1009 (message too big).
  c.send(nlohmann::json{{"type", "speak"}, {"id", "huge"}, {"text", std::string(5000, 'a')}});
  for (int i = 0; i < 10 && !c.closed(); ++i) (void)c.read(10);
  CHECK(c.closed());
  CHECK(c.close_code() == 1009);
  // The server is fine.
  WsClient d(s.port());
  REQUIRE(d.read_json(10)["type"] == "hello");
  d.send(nlohmann::json{{"type", "ping"}});
  CHECK(d.read_json(10)["type"] == "pong");
}

TEST_CASE("speak is rate limited per connection", "[ws][limits]") {
  TestServer s([](ServerOptions& o) {
    o.speak_per_minute = 6;
    o.speak_burst = 3;
  });
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  for (int i = 0; i < 4; ++i)
    c.send(nlohmann::json{
        {"type", "speak"}, {"id", "r" + std::to_string(i)}, {"text", "a"}, {"audio", false}});
  std::vector<std::string> ended;
  nlohmann::json limited;
  while (ended.size() < 3 || limited.is_null()) {
    const auto j = c.read_json(20 * slowdown());
    if (j["type"] == "stream_end") ended.push_back(j["id"]);
    if (j["type"] == "error") limited = j;
  }
  CHECK(limited["id"] == "r3");
  CHECK(limited["code"] == "rate_limited");
  // Another connection has its own budget.
  WsClient d(s.port());
  REQUIRE(d.read_json(10)["type"] == "hello");
  d.send(nlohmann::json{{"type", "speak"}, {"id", "x"}, {"text", "a"}, {"audio", false}});
  CHECK_FALSE(collect_stream(d, "x").error);
}

TEST_CASE("browser origins are checked", "[ws][auth]") {
  TestServer s([](ServerOptions& o) { o.allowed_origins = {"https://studio.example"}; });
  WsClient::Options o;
  o.headers = {{"Origin", "http://evil.example"}};
  CHECK(WsClient::handshake_status(s.port(), o) == 403);
  o.headers = {{"Origin", "http://127.0.0.1:" + std::to_string(s.port())}};
  CHECK(WsClient::handshake_status(s.port(), o) == 101);
  o.headers = {{"Origin", "https://studio.example"}};
  CHECK(WsClient::handshake_status(s.port(), o) == 101);
  // A client offering only other subprotocols is refused; offering none is accepted.
  WsClient::Options p;
  p.subprotocol = "chat.v2";
  CHECK(WsClient::handshake_status(s.port(), p) == 400);
  p.subprotocol = "";
  WsClient c(s.port(), p);
  CHECK(c.subprotocol().empty());
  CHECK(c.read_json(10)["type"] == "hello");
  p.target = "/elsewhere";
  CHECK(WsClient::handshake_status(s.port(), p) == 404);
}

TEST_CASE("a slow reader is dropped and closed with 1008 while others keep streaming",
          "[ws][slow-reader]") {
  TestServer s([](ServerOptions& o) {
    o.write_queue = 8;
    o.slow_client_grace = 0.5;
    o.close_timeout = 10;
    o.send_buffer = 4096;
  });
  // The slow client: a tiny receive buffer, frames mode (large messages), and it stops reading.
  WsClient::Options small;
  small.receive_buffer = 2048;
  WsClient slow(s.port(), small);
  REQUIRE(slow.read_json(10)["type"] == "hello");
  slow.send(nlohmann::json{{"type", "speak"},
                           {"id", "slow"},
                           {"output", "frames"},
                           {"size", {320, 240}},
                           {"fps", 30},
                           {"audio", false},
                           {"text",
                            "A long utterance that the slow client will never read, "
                            "because it stopped reading its socket altogether. It goes on, "
                            "sentence after sentence, so that its frames fill the queue "
                            "even when rendering starts late."}});
  // Meanwhile a healthy client gets its whole stream on time.
  WsClient good(s.port());
  REQUIRE(good.read_json(10)["type"] == "hello");
  good.send(nlohmann::json{
      {"type", "speak"}, {"id", "good"}, {"text", "I am reading everything."}, {"audio", false}});
  const auto r = collect_stream(good, "good");
  CHECK(r.end["dropped"] == 0);
  CHECK(r.end["frames"] == r.start["frames"]);
  std::vector<double> late;
  for (const auto& w : r.weights)
    late.push_back(std::chrono::duration<double>(w.at - r.start_at).count() -
                   std::max(0.0, w.header.pts - 0.1));
  std::sort(late.begin(), late.end());
  CHECK(late[late.size() * 95 / 100] < 0.1 * slowdown());
  // The slow client is closed once its queue has stayed full for the grace period (sooner than
  // this in a Release build; a sanitizer build renders its first frames late). Wait for that
  // without reading it, then read what arrived and the 1008 close.
  const auto closed = [&] {
    return metric_value(http_request(s.port(), http::verb::get, "/metrics").body,
                        "facecast_slow_clients_closed_total") >= 1;
  };
  for (int i = 0; i < 300 && !closed(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  int frames = 0;
  for (;;) {
    auto m = slow.read(15);
    if (!m) break;
    if (!m->text) ++frames;
  }
  const auto metrics = http_request(s.port(), http::verb::get, "/metrics").body;
  INFO("frames the slow client got: " << frames << "; metrics:\n" << metrics);
  CHECK(slow.close_code() == 1008);
  CHECK(metric_value(metrics, "facecast_slow_clients_closed_total") == 1);
  CHECK(metric_value(metrics, "facecast_frames_dropped_total{output=\"frames\"}") > 0);
}

TEST_CASE("a slow weights reader loses the oldest frames first", "[ws][slow-reader]") {
  TestServer s([](ServerOptions& o) {
    o.write_queue = 4;
    o.slow_client_grace = 30;  // never closed in this test
    o.send_buffer = 4096;
  });
  WsClient::Options small;
  small.receive_buffer = 2048;
  WsClient c(s.port(), small);
  REQUIRE(c.read_json(10)["type"] == "hello");
  c.send(
      nlohmann::json{{"type", "speak"},
                     {"id", "w"},
                     {"audio", false},
                     {"fps", 120},
                     {"text", "Weights pile up when nobody reads them, and the oldest go first."}});
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(2500 * slowdown())));
  const auto r = collect_stream(c, "w");
  const int total = r.start["frames"];
  const int dropped = r.end["dropped"];
  int received = 0;
  for (const auto& w : r.weights) received += static_cast<int>(w.header.count);
  CHECK(dropped > 0);
  CHECK(received == r.end["frames"].get<int>());
  CHECK(received + dropped == total);
  // What arrives is in order, and the end of the utterance always arrives (oldest dropped first).
  for (std::size_t i = 1; i < r.weights.size(); ++i)
    CHECK(r.weights[i].header.first > r.weights[i - 1].header.first);
  const auto& last = r.weights.back();
  CHECK(last.header.first + last.header.count == static_cast<std::uint32_t>(total));
}

TEST_CASE("a client that sends requests but never reads the answers is closed",
          "[ws][slow-reader]") {
  TestServer s([](ServerOptions& o) {
    o.write_queue = 4;  // 64 unread control messages at most
    o.slow_client_grace = 30;
    o.close_timeout = 10;
    o.send_buffer = 4096;
    // Only the unread answers close this client: a fast sender would otherwise race the
    // message-rate limit (a sanitizer's slow server met 200 per second first).
    o.messages_per_second = 1e6;
    o.message_burst = 4000;
  });
  WsClient::Options small;
  small.receive_buffer = 2048;
  WsClient c(s.port(), small);
  REQUIRE(c.read_json(10)["type"] == "hello");
  for (int i = 0; i < 2000 && !c.closed(); ++i) c.send(nlohmann::json{{"type", "ping"}, {"t", i}});
  int pongs = 0;
  for (;;) {
    auto m = c.read(15);
    if (!m) break;
    pongs += m->json()["type"] == "pong";
  }
  CHECK(c.close_code() == 1008);
  CHECK(pongs < 2000);
  const auto metrics = http_request(s.port(), http::verb::get, "/metrics").body;
  CHECK(metric_value(metrics, "facecast_slow_clients_closed_total") == 1);
}
