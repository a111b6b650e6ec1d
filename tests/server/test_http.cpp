// HTTP: health, metrics, static files (MIME, ETag, traversal), three.js, rigs, limits, auth.
#include <catch2/catch.hpp>
#include <regex>
#include <thread>

#include "client.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/template.hpp"
#include "test_data.hpp"

using namespace fctest;
using facecast::server::ServerOptions;

TEST_CASE("healthz and metrics answer", "[http]") {
  TestServer s;
  auto r = http_request(s.port(), http::verb::get, "/healthz");
  CHECK(r.status == 200);
  CHECK(r.header("content-type") == "application/json");
  CHECK(r.json()["status"] == "ok");
  CHECK(r.json()["uptime"].get<double>() >= 0);

  r = http_request(s.port(), http::verb::get, "/metrics");
  REQUIRE(r.status == 200);
  CHECK_THAT(r.header("content-type"), Catch::StartsWith("text/plain; version=0.0.4"));
  // Every line is a comment or "name{labels} value" (Prometheus text format).
  const std::regex line(
      R"(^(# (HELP|TYPE) .*|[a-z_]+(\{[a-z_]+="[^"]*"(,[a-z_]+="[^"]*")*\})? [-+0-9.eInf]+)$)");
  std::istringstream in(r.body);
  std::string l;
  int samples = 0;
  while (std::getline(in, l)) {
    INFO(l);
    CHECK(std::regex_match(l, line));
    samples += l[0] != '#';
  }
  CHECK(samples > 40);
  for (const char* name :
       {"facecast_websocket_connections", "facecast_active_streams", "facecast_write_queue_depth",
        "facecast_speak_queue_depth", "facecast_frames_sent_total{output=\"weights\"}",
        "facecast_frames_dropped_total{output=\"frames\"}",
        "facecast_time_to_first_frame_seconds_count",
        "facecast_http_request_duration_seconds_count", "facecast_render_duration_seconds_count",
        "facecast_rig_build_duration_seconds_count", "facecast_analysis_duration_seconds_count",
        "facecast_video_render_duration_seconds_count", "facecast_websocket_sent_bytes_total"}) {
    INFO(name);
    CHECK(metric_value(r.body, name) >= 0);
  }
  CHECK(metric_value(r.body, "facecast_http_requests_total") >= 2);
  // Prometheus conventions: start time (Unix seconds), a build_info gauge, status codes.
  const double now =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const double start = metric_value(r.body, "process_start_time_seconds");
  CHECK(start <= now);
  CHECK(start > now - 600);
  CHECK(std::regex_search(r.body,
                          std::regex(R"(\nfacecast_build_info\{version="[0-9.]+",compiler="[^"]+",)"
                                     R"(build_type="[^"]*"\} 1\n)")));
  CHECK(metric_value(r.body, "facecast_http_responses_total{code=\"200\"}") >= 1);
  CHECK(r.body.find("facecast_uptime_seconds") == std::string::npos);
  http_request(s.port(), http::verb::get, "/no-such-file");
  r = http_request(s.port(), http::verb::get, "/metrics");
  CHECK(metric_value(r.body, "facecast_http_responses_total{code=\"404\"}") >= 1);
}

TEST_CASE("static files have MIME types and conditional GET", "[http][static]") {
  TestServer s;
  auto r = http_request(s.port(), http::verb::get, "/");
  REQUIRE(r.status == 200);
  CHECK(r.header("content-type") == "text/html; charset=utf-8");
  CHECK_THAT(r.body, Catch::Contains("facecast test"));
  const std::string etag = r.header("etag");
  CHECK(!etag.empty());
  CHECK(!r.header("last-modified").empty());

  r = http_request(s.port(), http::verb::get, "/app.js");
  CHECK(r.status == 200);
  CHECK(r.header("content-type") == "text/javascript; charset=utf-8");
  r = http_request(s.port(), http::verb::get, "/style/site.css");
  CHECK(r.status == 200);
  CHECK(r.header("content-type") == "text/css; charset=utf-8");
  r = http_request(s.port(), http::verb::head, "/app.js");
  CHECK(r.status == 200);
  CHECK(r.header("content-length") == "26");
  CHECK(r.body.empty());

  r = http_request(s.port(), http::verb::get, "/index.html", {}, {{"If-None-Match", etag}});
  CHECK(r.status == 304);
  CHECK(r.body.empty());
  const std::string lm = http_request(s.port(), http::verb::get, "/").header("last-modified");
  r = http_request(s.port(), http::verb::get, "/", {}, {{"If-Modified-Since", lm}});
  CHECK(r.status == 304);
  r = http_request(s.port(), http::verb::get, "/", {},
                   {{"If-Modified-Since", "Mon, 01 Jan 2001 00:00:00 GMT"}});
  CHECK(r.status == 200);

  CHECK(http_request(s.port(), http::verb::get, "/missing.js").status == 404);
  CHECK(http_request(s.port(), http::verb::post, "/app.js", "x").status == 405);
  const auto nf = http_request(s.port(), http::verb::get, "/nope");
  CHECK(nf.json()["error"]["code"] == "not_found");
}

TEST_CASE("path traversal attempts never leave the web folder", "[http][static]") {
  TestServer s;
  // Through an HTTP library (which keeps the target as given) and as raw bytes.
  for (const char* target :
       {"/../secret.txt", "/%2e%2e/secret.txt", "/%2E%2E%2Fsecret.txt", "/style/../../secret.txt",
        "/style/..%2F..%2Fsecret.txt", "/..%5Csecret.txt", "/.%2e/secret.txt", "//../secret.txt",
        "/link.txt", "/.hidden", "/%00index.html", "/index.html%00", "/%zz",
        "/vendor/three/../../../secret.txt", "/vendor/three/%2e%2e/%2e%2e/package.json"}) {
    INFO(target);
    const auto r = http_request(s.port(), http::verb::get, target);
    CHECK(r.status >= 400);
    CHECK(r.status < 500);
    CHECK(r.body.find("TOP-SECRET") == std::string::npos);
    CHECK(r.body.find("HIDDEN-CONTENT") == std::string::npos);
  }
  const std::string raw = raw_request(
      s.port(), "GET /../../secret.txt HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  CHECK_THAT(raw, Catch::StartsWith("HTTP/1.1 4"));
  CHECK(raw.find("TOP-SECRET") == std::string::npos);
  const std::string garbage = raw_request(s.port(), "NOT HTTP AT ALL\r\n\r\n");
  CHECK_THAT(garbage, Catch::StartsWith("HTTP/1.1 400"));
}

TEST_CASE("three.js is served from the pinned npm package", "[http][static]") {
  TestServer s;
  const auto three =
      facecast::config_dir().parent_path() / "node_modules" / "three" / "build" / "three.module.js";
  if (!std::filesystem::exists(three)) {
    WARN("node_modules/three missing (scripts/install-deps.sh runs npm ci): not checked");
    return;
  }
  const auto r = http_request(s.port(), http::verb::get, "/vendor/three/build/three.module.js");
  CHECK(r.status == 200);
  CHECK(r.header("content-type") == "text/javascript; charset=utf-8");
  CHECK(r.body.size() == std::filesystem::file_size(three));
  CHECK(http_request(s.port(), http::verb::get, "/vendor/three/package.json").json()["name"] ==
        "three");
}

TEST_CASE("rigs are listed and the default avatar downloads as GLB", "[http][rigs]") {
  TestServer s;
  auto r = http_request(s.port(), http::verb::get, "/api/rigs");
  REQUIRE(r.status == 200);
  const auto rigs = r.json()["rigs"];
  REQUIRE(!rigs.empty());
  CHECK(rigs[0]["id"] == "default");
  // The shipped realistic template (rigbuild/template.hpp) beside it when the build packed it from
  // ../shared/data, served from its file.
  if (facecast::test::require_data(facecast::test::ict_dir() / "generic_neutral_mesh.obj")) {
    REQUIRE(rigs.size() == 2);
    CHECK(rigs[1]["id"] == "ict-facekit");
    CHECK(rigs[1]["builtin"] == true);
    CHECK(rigs[1]["shapes"].size() == 74);
    const auto shipped = http_request(s.port(), http::verb::get,
                                      "/api/rigs/" + rigs[1]["id"].get<std::string>() + ".glb");
    REQUIRE(shipped.status == 200);
    CHECK(shipped.body == facecast::read_file(facecast::rigbuild::shipped_template_path()));
    CHECK(http_request(s.port(), http::verb::delete_, "/api/rigs/ict-facekit").status == 403);
  } else {
    CHECK(rigs.size() == 1);
  }
  CHECK(rigs[0]["builtin"] == true);
  CHECK(rigs[0]["shapes"].get<std::vector<std::string>>() ==
        facecast::avatar::avatar_shape_names());
  CHECK(rigs[0]["vertices"] == facecast::avatar::default_avatar().vertex_count());

  r = http_request(s.port(), http::verb::get, "/api/rigs/default.glb");
  REQUIRE(r.status == 200);
  CHECK(r.header("content-type") == "model/gltf-binary");
  const auto rig = facecast::rig::parse_glb(r.body, "download");
  CHECK(rig.vertex_count() == facecast::avatar::default_avatar().vertex_count());
  CHECK(rig.shape_names() == facecast::avatar::avatar_shape_names());
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs/default.glb", {},
                     {{"If-None-Match", r.header("etag")}})
            .status == 304);

  r = http_request(s.port(), http::verb::get, "/api/rigs/nope.glb");
  CHECK(r.status == 404);
  CHECK(r.json()["error"]["message"] == "rig 'nope' does not exist");
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs/default/virtual_edges.json").status ==
        404);
  CHECK(http_request(s.port(), http::verb::get, "/api/jobs/j999").status == 404);
  CHECK(http_request(s.port(), http::verb::delete_, "/api/rigs").status == 405);
  CHECK(http_request(s.port(), http::verb::get, "/ws").status == 426);
}

TEST_CASE("request bodies over the limit are refused", "[http][limits]") {
  TestServer s([](ServerOptions& o) {
    o.max_upload = 4096;
    o.max_body = 1024;
  });
  auto r = http_request(s.port(), http::verb::post, "/api/rigs", std::string(5000, 'x'));
  CHECK(r.status == 413);
  CHECK(r.json()["error"]["code"] == "limit");
  // Chunked bodies have no length up front: the limit applies while reading.
  const std::string chunk(3000, 'y');
  char size[16];
  std::snprintf(size, sizeof size, "%zx", chunk.size());
  const std::string raw = raw_request(
      s.port(),
      "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\n" +
          std::string(size) + "\r\n" + chunk + "\r\n" + size + "\r\n" + chunk + "\r\n0\r\n\r\n");
  CHECK_THAT(raw, Catch::StartsWith("HTTP/1.1 413"));
  // Other requests have the small limit.
  CHECK(http_request(s.port(), http::verb::get, "/healthz", std::string(2000, 'z')).status == 413);
  // Malformed JSON and unknown fields.
  r = http_request(s.port(), http::verb::post, "/api/rigs", "{nope");
  CHECK(r.status == 400);
  CHECK_THAT(r.json()["error"]["message"].get<std::string>(), Catch::Contains("malformed JSON"));
  r = http_request(s.port(), http::verb::post, "/api/render", R"({"text":"hi","colour":1})");
  CHECK(r.status == 400);
  CHECK_THAT(r.json()["error"]["message"].get<std::string>(), Catch::Contains("'colour'"));
  r = http_request(s.port(), http::verb::post, "/api/render", R"({"text":"hi","rig":"zz"})");
  CHECK(r.status == 404);
}

TEST_CASE("a non-loopback bind needs a token on the API and the WebSocket", "[http][auth]") {
  // No token: refused at start-up.
  ServerOptions bad;
  bad.host = "0.0.0.0";
  bad.port = 0;
  CHECK_THROWS_WITH(facecast::server::Server(bad), Catch::Contains("set a token"));

  TestServer s([](ServerOptions& o) {
    o.host = "0.0.0.0";
    o.token = "s3cret-token";
  });
  auto r = http_request(s.port(), http::verb::get, "/api/rigs");
  CHECK(r.status == 401);
  CHECK(r.json()["error"]["code"] == "unauthorized");
  CHECK(r.header("www-authenticate") == "Bearer");
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs", {},
                     {{"Authorization", "Bearer wrong-token!"}})
            .status == 401);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs", {},
                     {{"Authorization", "Bearer s3cret-token"}})
            .status == 200);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs?token=s3cret-token").status == 200);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs?token=s3cret").status == 401);
  // The page itself and health checks stay open (the page reads the token from its URL).
  CHECK(http_request(s.port(), http::verb::get, "/").status == 200);
  CHECK(http_request(s.port(), http::verb::get, "/healthz").status == 200);

  WsClient::Options ws;
  CHECK(WsClient::handshake_status(s.port(), ws) == 401);
  ws.target = "/ws?token=s3cret-token";
  CHECK(WsClient::handshake_status(s.port(), ws) == 101);
  ws.target = "/ws";
  ws.headers = {{"Authorization", "Bearer s3cret-token"}};
  WsClient c(s.port(), ws);
  CHECK(c.read_json(10)["type"] == "hello");
}

TEST_CASE("connections over max_connections get 503", "[http][limits]") {
  TestServer s([](ServerOptions& o) { o.max_connections = 2; });
  WsClient a(s.port()), b(s.port());
  CHECK(a.read_json(10)["type"] == "hello");
  CHECK(b.read_json(10)["type"] == "hello");
  CHECK(WsClient::handshake_status(s.port(), {}) == 503);
  CHECK(http_request(s.port(), http::verb::get, "/healthz").status == 503);
  a.close();
  b.close();
  // Slots come back when connections close. The answer that shows it is the one checked: a
  // request after it may find its predecessor's slot not yet given back (under TSan, a 503).
  int status = 0;
  for (int i = 0; i < 250; ++i) {
    status = http_request(s.port(), http::verb::get, "/healthz").status;
    if (status == 200) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  CHECK(status == 200);
}
