// The browser as attacker: the Host allow-list against DNS rebinding, Origin on state changes and
// the WebSocket, JSON-only bodies against form/text CSRF, CORS off unless configured.
#include <catch2/catch.hpp>

#include "client.hpp"

using namespace fctest;
using facecast::server::ServerOptions;

TEST_CASE("the browser as attacker: Host, Origin, Content-Type and CORS", "[auth][browser]") {
  TestServer s([](ServerOptions& o) { o.allowed_hosts = {"facecast.example"}; });
  const auto port = s.port();
  const std::string self = "http://127.0.0.1:" + std::to_string(port);

  // DNS rebinding: a name that is not ours gets 421, on every request and the upgrade.
  for (const std::string& host : std::vector<std::string>{
           "evil.example", "evil.example:" + std::to_string(port), "localhost.evil.example"}) {
    INFO(host);
    CHECK(http_request(port, http::verb::get, "/", {}, {{"Host", host}}).status == 421);
    CHECK(http_request(port, http::verb::get, "/api/rigs", {}, {{"Host", host}}).status == 421);
    WsClient::Options o;
    o.headers = {{"Host", host}};
    CHECK(WsClient::handshake_status(port, o) == 421);
  }
  for (const std::string host : {"localhost:8080", "LOCALHOST", "127.0.0.1", "[::1]:8080",
                                 "10.1.2.3:80", "facecast.example", "facecast.example:443"}) {
    INFO(host);
    CHECK(http_request(port, http::verb::get, "/api/rigs", {}, {{"Host", host}}).status == 200);
  }

  // Another site's page: no state change, no WebSocket.
  const auto evil = [](Headers h = {}) { return with(h, "Origin", "http://evil.example"); };
  CHECK(http_request(port, http::verb::post, "/api/render", R"({"text":"hi"})", evil()).status ==
        403);
  CHECK(http_request(port, http::verb::delete_, "/api/jobs/j1", {}, evil()).status == 403);
  CHECK(
      http_request(port, http::verb::post, "/api/render", R"({"text":"hi"})", {{"Origin", "null"}})
          .status == 403);
  {
    WsClient::Options o;
    o.headers = evil();
    CHECK(WsClient::handshake_status(port, o) == 403);
  }
  // Reading is not changing (CORS keeps the answer from the page).
  CHECK(http_request(port, http::verb::get, "/api/rigs", {}, evil()).status == 200);
  // The page's own origin may.
  CHECK(http_request(port, http::verb::post, "/api/render", R"({"text":"hi","size":[161,120]})",
                     {{"Origin", self}, {"Content-Type", "application/json"}})
            .status == 400);

  // Bodies a form or a "simple" fetch can send: 415 before anything reads them.
  for (const std::string type : {"text/plain", "text/plain;charset=UTF-8",
                                 "application/x-www-form-urlencoded", "multipart/form-data; b=x"}) {
    INFO(type);
    CHECK(http_request(port, http::verb::post, "/api/render", R"({"text":"hi"})",
                       {{"Content-Type", type}})
              .status == 415);
    CHECK(
        http_request(port, http::verb::post, "/api/rigs", "{}", {{"Content-Type", type}}).status ==
        415);
    CHECK(
        http_request(port, http::verb::post, "/api/audio", "x", {{"Content-Type", type}}).status ==
        415);
    CHECK(http_request(port, http::verb::post, "/api/tokens", "{}", {{"Content-Type", type}})
              .status == 415);
  }
  CHECK(http_request(port, http::verb::post, "/api/render", R"({"size":[160,120]})",
                     {{"Content-Type", "application/json; charset=utf-8"}})
            .status == 400);
  CHECK(http_request(port, http::verb::post, "/api/audio", "not audio",
                     {{"Content-Type", "audio/wav"}})
            .status == 400);

  // CORS is off: a preflight gets no Access-Control-Allow-Origin, nor does an answer.
  const Headers preflight = {{"Origin", "https://app.example"},
                             {"Access-Control-Request-Method", "POST"},
                             {"Access-Control-Request-Headers", "authorization, content-type"}};
  auto r = http_request(port, http::verb::options, "/api/render", {}, preflight);
  CHECK(r.status == 403);
  CHECK(r.header("access-control-allow-origin").empty());
  r = http_request(port, http::verb::get, "/api/rigs", {}, {{"Origin", "https://app.example"}});
  CHECK(r.header("access-control-allow-origin").empty());
}

TEST_CASE("CORS answers the configured origins only", "[auth][browser]") {
  TestServer s([](ServerOptions& o) { o.cors_origins = {"https://app.example"}; });
  const auto port = s.port();
  auto r = http_request(port, http::verb::options, "/api/render", {},
                        {{"Origin", "https://app.example"},
                         {"Access-Control-Request-Method", "POST"},
                         {"Access-Control-Request-Headers", "authorization, content-type"}});
  CHECK(r.status == 204);
  CHECK(r.header("access-control-allow-origin") == "https://app.example");
  CHECK_THAT(r.header("access-control-allow-headers"), Catch::Contains("Authorization"));
  CHECK_THAT(r.header("access-control-allow-methods"), Catch::Contains("POST"));
  r = http_request(port, http::verb::options, "/api/render", {},
                   {{"Origin", "https://evil.example"}, {"Access-Control-Request-Method", "POST"}});
  CHECK(r.status == 403);
  CHECK(r.header("access-control-allow-origin").empty());
  r = http_request(port, http::verb::get, "/api/rigs", {}, {{"Origin", "https://app.example"}});
  CHECK(r.status == 200);
  CHECK(r.header("access-control-allow-origin") == "https://app.example");
  CHECK(r.header("vary") == "Origin");
  r = http_request(port, http::verb::get, "/api/rigs", {}, {{"Origin", "https://evil.example"}});
  CHECK(r.header("access-control-allow-origin").empty());
  // A listed origin may change state; errors carry the header too (the page reads them).
  r = http_request(port, http::verb::post, "/api/render", R"({"size":[160,120]})",
                   {{"Origin", "https://app.example"}, {"Content-Type", "application/json"}});
  CHECK(r.status == 400);
  CHECK(r.header("access-control-allow-origin") == "https://app.example");
}
