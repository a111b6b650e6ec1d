// Nobody gets in where they do not belong: API keys (`facecast keys`, stored hashed), scopes,
// tenants kept apart, viewer tokens (JWT) limited to one channel or one rig, a server off loopback
// (or the shipped deploy config) that refuses to start without keys. The browser as attacker:
// test_browser.cpp.
#include <sys/stat.h>
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <fstream>
#include <regex>
#include <thread>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/wav.hpp"
#include "facecast/server/keys.hpp"
#include "facecast/viseme/analyze.hpp"
#include "serve_process.hpp"
#include "test_avatar_file.hpp"
#include "test_data.hpp"

using namespace fctest;
using facecast::server::KeyStore;
using facecast::server::parse_scopes;
using facecast::server::ServerOptions;
using facecast::test::test_avatar_glb;
namespace fs = std::filesystem;

namespace {

std::string quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct Cli {
  int status = -1;
  std::string out, err;
};

// `facecast <args>` to its end (at most 60 s): exit status, stdout, stderr.
Cli facecast_cli(const std::vector<std::string>& args) {
  static int n = 0;
  const fs::path err = facecast::test::scratch_dir() / ("cli-" + std::to_string(++n) + ".err");
  std::string cmd = "timeout 60 " + quote(facecast::test::facecast_exe().string());
  for (const auto& a : args) cmd += " " + quote(a);
  cmd += " 2>" + quote(err.string());
  Cli r;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  char buf[4096];
  for (std::size_t k; (k = fread(buf, 1, sizeof buf, p)) > 0;) r.out.append(buf, k);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = facecast::test::scratch_dir() / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// A data folder with a key store: an admin key, tenant A with every scope but admin, tenant A
// read-only, tenant B with every scope but admin.
struct Keyed {
  fs::path data;
  std::string admin, a, a_read, b, metrics;
  explicit Keyed(const std::string& name) : data(fresh_dir(name)) {
    KeyStore store(data / "keys.sqlite3", true);
    const auto all =
        parse_scopes("speak,render,rigs:read,rigs:write,channels:produce,channels:subscribe");
    admin = store.create("ops", parse_scopes("admin")).key;
    a = store.create("acme", all).key;
    a_read = store.create("acme", parse_scopes("rigs:read")).key;
    b = store.create("globex", all).key;
    metrics = store.create("ops", parse_scopes("metrics")).key;
  }
};

const char* kProducer = "producer-secret-1";

void keyed_options(ServerOptions& o, const Keyed& k) {
  o.data = k.data;
  o.channels.push_back({"show", kProducer, "acme"});
  o.channels.push_back({"backstage", kProducer, "acme"});
  o.channels.push_back({"bshow", kProducer, "globex"});
  o.channel_idle = 0;
}

WsClient::Options ws_with_key(const std::string& key) {
  WsClient::Options o;
  o.subprotocol = "facecast.v1, facecast.token." + key;
  return o;
}

nlohmann::json wait_type(WsClient& c, const std::string& type, double timeout = 15) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(timeout));
  while (std::chrono::steady_clock::now() < deadline) {
    const auto m =
        c.read(std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count());
    if (!m) break;
    if (!m->text) continue;
    const auto j = m->json();
    if (j["type"] == type || j["type"] == "error") return j;
  }
  return {{"type", "timeout"}};
}

nlohmann::json wait_job(unsigned short port, const std::string& id, const Headers& h,
                        double timeout) {
  const auto t0 = std::chrono::steady_clock::now();
  nlohmann::json j;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(timeout)) {
    const auto r = http_request(port, http::verb::get, "/api/jobs/" + id, {}, h);
    REQUIRE(r.status == 200);
    j = r.json();
    if (j["state"] == "done" || j["state"] == "failed") return j;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return j;
}

bool lists_rig(const HttpResponse& r, const std::string& id) {
  const auto j = r.json();
  for (const auto& rig : j["rigs"])
    if (rig["id"] == id) return true;
  return false;
}

std::string speech_wav() {
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const auto u = facecast::viseme::analyze("Hello there.", o);
  return facecast::encode_wav(u.pcm, u.sample_rate);
}

std::string base64url(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  std::string out;
  unsigned v = 0;
  int bits = 0;
  for (const unsigned char c : in) {
    v = (v << 8) | c;
    bits += 8;
    while (bits >= 6) out += t[(v >> (bits -= 6)) & 63];
  }
  if (bits) out += t[(v << (6 - bits)) & 63];
  return out;
}

}  // namespace

TEST_CASE("facecast keys creates, lists and revokes keys; the store holds no secret",
          "[auth][keys][cli]") {
  const fs::path data = fresh_dir("keys-cli");
  const Cli made = facecast_cli({"keys", "create", "--tenant", "acme", "--scopes",
                                 "speak,rigs:read", "--data", data.string()});
  INFO(made.err);
  REQUIRE(made.status == 0);
  std::smatch m;
  const std::string out = made.out;
  REQUIRE(std::regex_search(out, m, std::regex("^(fc_([0-9a-f]{12})_([0-9a-f]{64}))\n$")));
  const std::string key = m[1], id = m[2], secret = m[3];
  CHECK_THAT(made.err, Catch::Contains("only time"));

  // Hashed at rest, owner-only: neither the key nor its secret is anywhere in the files.
  const fs::path store = data / "keys.sqlite3";
  REQUIRE(fs::exists(store));
  struct stat st {};
  REQUIRE(stat(store.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);
  for (const auto& f : fs::directory_iterator(data)) {
    const std::string bytes = facecast::read_file(f.path());
    INFO(f.path());
    CHECK(bytes.find(secret) == std::string::npos);
    CHECK(bytes.find(secret.substr(0, 16)) == std::string::npos);
  }

  // Bad input: one line, non-zero.
  CHECK(facecast_cli({"keys", "create", "--tenant", "acme", "--scopes", "speak,fly", "--data",
                      data.string()})
            .status != 0);
  CHECK(facecast_cli(
            {"keys", "create", "--tenant", "a b", "--scopes", "speak", "--data", data.string()})
            .status != 0);

  // list: id, tenant, scopes, created, last used; never the secret.
  const Cli listed = facecast_cli({"keys", "list", "--data", data.string()});
  REQUIRE(listed.status == 0);
  CHECK_THAT(listed.out, Catch::Contains(id));
  CHECK_THAT(listed.out, Catch::Contains("acme"));
  CHECK_THAT(listed.out, Catch::Contains("speak,rigs:read"));
  CHECK_THAT(listed.out, Catch::Contains("active"));
  CHECK(listed.out.find(secret) == std::string::npos);
  const auto as_json =
      nlohmann::json::parse(facecast_cli({"keys", "list", "--json", "--data", data.string()}).out);
  REQUIRE(as_json.size() == 1);
  CHECK(as_json[0]["id"] == id);
  CHECK(as_json[0]["last_used"] == 0);

  // The server takes the key; revoked, it gets 401 at once (the running server too).
  TestServer s([&](ServerOptions& o) { o.data = data; });
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs").status == 401);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(key)).status == 200);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(key + "0")).status == 401);
  std::string wrong = key;
  wrong.back() = wrong.back() == '0' ? '1' : '0';
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(wrong)).status == 401);
  const auto used =
      nlohmann::json::parse(facecast_cli({"keys", "list", "--json", "--data", data.string()}).out);
  CHECK(used[0]["last_used"].get<double>() > 0);

  const Cli revoked = facecast_cli({"keys", "revoke", id, "--data", data.string()});
  INFO(revoked.err);
  REQUIRE(revoked.status == 0);
  const auto after = http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(key));
  CHECK(after.status == 401);
  CHECK(after.header("www-authenticate") == "Bearer");
  CHECK(WsClient::handshake_status(s.port(), ws_with_key(key)) == 401);
  CHECK_THAT(facecast_cli({"keys", "list", "--data", data.string()}).out,
             Catch::Contains("revoked"));
  CHECK(facecast_cli({"keys", "revoke", id, "--data", data.string()}).status != 0);
}

TEST_CASE("with a key store every API path and /ws needs a key with the route's scope",
          "[auth][keys]") {
  const Keyed k("keys-scopes");
  TestServer s([&](ServerOptions& o) { keyed_options(o, k); });
  const auto port = s.port();

  // No key: 401 on every API path, the WebSocket and the metrics; the page and health stay open.
  for (const auto& [verb, target] : std::vector<std::pair<http::verb, std::string>>{
           {http::verb::get, "/api/rigs"},
           {http::verb::post, "/api/render"},
           {http::verb::post, "/api/rigs"},
           {http::verb::post, "/api/audio"},
           {http::verb::post, "/api/tokens"},
           {http::verb::get, "/api/jobs/j1"},
           {http::verb::delete_, "/api/jobs/j1"},
           {http::verb::get, "/api/jobs/j1/video.mp4"},
           {http::verb::delete_, "/api/rigs/r0123456789abcdef"},
           {http::verb::get, "/api/rigs/r0123456789abcdef.glb"},
           {http::verb::get, "/api/channels/show"},
           {http::verb::post, "/api/channels/show/speak"},
           {http::verb::get, "/api/nothing"},
           {http::verb::get, "/metrics"}}) {
    INFO(target);
    const auto r = http_request(port, verb, target, verb == http::verb::post ? "{}" : "");
    CHECK(r.status == 401);
    CHECK(r.header("www-authenticate") == "Bearer");
  }
  CHECK(WsClient::handshake_status(port, {}) == 401);
  CHECK(WsClient::handshake_status(port, ws_with_key("fc_000000000000_" + std::string(64, '0'))) ==
        401);
  CHECK(http_request(port, http::verb::get, "/").status == 200);
  CHECK(http_request(port, http::verb::get, "/healthz").status == 200);
  CHECK(http_request(port, http::verb::get, "/api/rigs", {}, bearer("not-a-key")).status == 401);

  // The right scope: 200; another scope: 403.
  CHECK(http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.a_read)).status == 200);
  CHECK(http_request(port, http::verb::post, "/api/render", R"({"text":"hi"})", bearer(k.a_read))
            .status == 403);
  CHECK(http_request(port, http::verb::post, "/api/rigs", "{}", bearer(k.a_read)).status == 403);
  CHECK(http_request(port, http::verb::post, "/api/audio", "x", bearer(k.a_read)).status == 403);
  CHECK(http_request(port, http::verb::get, "/api/channels/show", {}, bearer(k.a_read)).status ==
        403);
  CHECK(WsClient::handshake_status(port, ws_with_key(k.a_read)) == 403);
  // /metrics: the metrics (or admin) scope.
  CHECK(http_request(port, http::verb::get, "/metrics", {}, bearer(k.a)).status == 403);
  CHECK(http_request(port, http::verb::get, "/metrics", {}, bearer(k.metrics)).status == 200);
  CHECK(http_request(port, http::verb::get, "/metrics", {}, bearer(k.admin)).status == 200);
  CHECK(http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.metrics)).status == 403);
  // ?token= still works (docs: proxies log it).
  CHECK(http_request(port, http::verb::get, "/api/rigs?token=" + k.a_read).status == 200);

  // The WebSocket: a key in the subprotocol list; the server answers facecast.v1 alone.
  {
    WsClient c(port, ws_with_key(k.a));
    CHECK(c.subprotocol() == "facecast.v1");
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"text", "hi."}, {"audio", false}});
    const auto r = collect_stream(c, "u1", 60);
    CHECK(!r.error);
  }
  {
    WsClient::Options o;
    o.headers = bearer(k.a);
    WsClient c(port, o);
    CHECK(c.read_json(10)["type"] == "hello");
  }
  // ...or in the first message, when the client offers "facecast.token".
  {
    WsClient::Options o;
    o.subprotocol = "facecast.v1, facecast.token";
    WsClient c(port, o);
    CHECK(c.subprotocol() == "facecast.v1");
    c.send(nlohmann::json{{"type", "auth"}, {"token", k.a}});
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "ping"}, {"t", 1}});
    CHECK(c.read_json(10)["type"] == "pong");
  }
  {
    WsClient::Options o;
    o.subprotocol = "facecast.v1, facecast.token";
    WsClient c(port, o);
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"text", "hi."}});
    const auto e = c.read_json(10);
    CHECK(e["type"] == "error");
    CHECK(e["code"] == "unauthorized");
    CHECK(!c.read(10));
    CHECK(c.close_code() == 1008);
  }
}

TEST_CASE("tenants see only their own rigs, jobs, videos and uploads; admins see all",
          "[auth][tenants]") {
  const Keyed k("keys-tenants");
  TestServer s([&](ServerOptions& o) { keyed_options(o, k); });
  const auto port = s.port();
  const auto glb = with(bearer(k.a), "Content-Type", "model/gltf-binary");

  // A rig of tenant acme.
  auto up = http_request(port, http::verb::post, "/api/rigs?name=Mine", test_avatar_glb(), glb);
  REQUIRE(up.status == 201);
  const std::string rig = up.json()["id"];
  CHECK(up.json()["tenant"] == "acme");
  CHECK(up.json()["public"] == false);
  const std::string glb_url = "/api/rigs/" + rig + ".glb";

  // Listed to acme and the admin, not to globex.
  CHECK(lists_rig(http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.a)), rig));
  CHECK(lists_rig(http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.admin)), rig));
  const auto b_list = http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.b));
  CHECK(!lists_rig(b_list, rig));
  CHECK(lists_rig(b_list, "default"));  // built-in rigs: everyone's
  // Read and delete: 404 to globex, as if it did not exist; no key: 401.
  CHECK(http_request(port, http::verb::get, glb_url, {}, bearer(k.a)).status == 200);
  CHECK(http_request(port, http::verb::get, glb_url, {}, bearer(k.admin)).status == 200);
  CHECK(http_request(port, http::verb::get, glb_url, {}, bearer(k.b)).status == 404);
  CHECK(http_request(port, http::verb::get, glb_url).status == 401);
  CHECK(http_request(port, http::verb::delete_, "/api/rigs/" + rig, {}, bearer(k.b)).status == 404);
  CHECK(http_request(port, http::verb::patch, "/api/rigs/" + rig, R"({"public":true})", bearer(k.b))
            .status == 404);
  // globex cannot speak with it or render it either.
  {
    WsClient c(port, ws_with_key(k.b));
    const auto hello = c.read_json(10);
    CHECK(std::find(hello["rigs"].begin(), hello["rigs"].end(), rig) == hello["rigs"].end());
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"text", "hi."}, {"rig", rig}});
    const auto e = c.read_json(10);
    CHECK(e["type"] == "error");
    CHECK(e["code"] == "not_found");
  }
  CHECK(http_request(port, http::verb::post, "/api/render",
                     nlohmann::json{{"text", "hi"}, {"rig", rig}}.dump(), bearer(k.b))
            .status == 404);

  // The built-in avatar and a public rig load without a key (viewers' browsers).
  CHECK(http_request(port, http::verb::get, "/api/rigs/default.glb").status == 200);
  const auto pub =
      http_request(port, http::verb::patch, "/api/rigs/" + rig, R"({"public":true})", bearer(k.a));
  REQUIRE(pub.status == 200);
  CHECK(pub.json()["public"] == true);
  const auto open_glb = http_request(port, http::verb::get, glb_url);
  CHECK(open_glb.status == 200);
  CHECK(open_glb.body == test_avatar_glb());
  CHECK(!lists_rig(http_request(port, http::verb::get, "/api/rigs", {}, bearer(k.b)), rig));
  auto up2 = http_request(port, http::verb::post, "/api/rigs?public=1", test_avatar_glb(), glb);
  REQUIRE(up2.status == 201);
  CHECK(http_request(port, http::verb::get,
                     "/api/rigs/" + up2.json()["id"].get<std::string>() + ".glb")
            .status == 200);
  // Ownership lives with the rig (meta.json): a restart keeps it.
  s.restart();
  CHECK(http_request(s.port(), http::verb::get, glb_url).status == 200);
  CHECK(!lists_rig(http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(k.b)), rig));
  CHECK(lists_rig(http_request(s.port(), http::verb::get, "/api/rigs", {}, bearer(k.a)), rig));
  const auto p2 = s.port();

  // A render job and its video: acme's.
  const auto job = http_request(
      p2, http::verb::post, "/api/render",
      nlohmann::json{{"text", "Hi."}, {"size", {64, 48}}, {"fps", 10}, {"audio", false}}.dump(),
      with(bearer(k.a), "Content-Type", "application/json"));
  REQUIRE(job.status == 202);
  const std::string jid = job.json()["job"];
  CHECK(http_request(p2, http::verb::get, "/api/jobs/" + jid, {}, bearer(k.b)).status == 404);
  CHECK(http_request(p2, http::verb::delete_, "/api/jobs/" + jid, {}, bearer(k.b)).status == 404);
  CHECK(http_request(p2, http::verb::get, "/api/jobs/" + jid, {}, bearer(k.admin)).status == 200);
  CHECK(http_request(p2, http::verb::get, "/api/jobs/" + jid, {}, bearer(k.a_read)).status == 403);
  const auto done = wait_job(p2, jid, bearer(k.a), 120 * slowdown());
  INFO(done.dump());
  REQUIRE(done["state"] == "done");
  const std::string video = done["result"]["url"];
  CHECK(http_request(p2, http::verb::get, video, {}, bearer(k.a)).status == 200);
  CHECK(http_request(p2, http::verb::get, video, {}, bearer(k.admin)).status == 200);
  CHECK(http_request(p2, http::verb::get, video, {}, bearer(k.b)).status == 404);
  CHECK(http_request(p2, http::verb::get, video).status == 401);
  // Ownership is stored with the job record: a restart keeps it.
  s.restart();
  CHECK(http_request(s.port(), http::verb::get, "/api/jobs/" + jid, {}, bearer(k.b)).status == 404);
  CHECK(http_request(s.port(), http::verb::get, "/api/jobs/" + jid, {}, bearer(k.a)).status == 200);
  CHECK(
      http_request(s.port(), http::verb::delete_, "/api/jobs/" + jid, {}, bearer(k.admin)).status ==
      200);
  const auto p3 = s.port();

  // Uploaded audio: only its tenant speaks with it.
  const auto audio = http_request(p3, http::verb::post, "/api/audio", speech_wav(),
                                  with(bearer(k.a), "Content-Type", "audio/wav"));
  REQUIRE(audio.status == 201);
  const std::string audio_id = audio.json()["audio_id"];
  {
    WsClient c(p3, ws_with_key(k.b));
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"audio_id", audio_id}});
    const auto e = c.read_json(10);
    CHECK(e["type"] == "error");
    CHECK(e["code"] == "not_found");
  }
  {
    WsClient c(p3, ws_with_key(k.a));
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"audio_id", audio_id}});
    const auto r = collect_stream(c, "u1", 60);
    CHECK(!r.error);
  }
  // globex deletes its own things only; the admin deletes anyone's.
  CHECK(http_request(p3, http::verb::delete_, "/api/rigs/" + rig, {}, bearer(k.b)).status == 404);
  CHECK(http_request(p3, http::verb::delete_, "/api/rigs/" + rig, {}, bearer(k.admin)).status ==
        200);
}

TEST_CASE("a viewer token subscribes to its channel or speaks with its rig, and nothing else",
          "[auth][tokens]") {
  const Keyed k("keys-tokens");
  TestServer s([&](ServerOptions& o) { keyed_options(o, k); });
  const auto port = s.port();
  const auto mint = [&](const std::string& key, const nlohmann::json& body) {
    return http_request(port, http::verb::post, "/api/tokens", body.dump(),
                        with(bearer(key), "Content-Type", "application/json"));
  };

  const auto minted = mint(k.a, {{"scope", "channels:subscribe"}, {"channel", "show"}});
  REQUIRE(minted.status == 201);
  const std::string token = minted.json()["token"];
  CHECK(minted.json()["expires_in"].get<double>() <= 3600);
  // Only a key that may itself subscribe, to its own tenant's channel.
  CHECK(mint(k.a, {{"scope", "channels:subscribe"}, {"channel", "bshow"}}).status == 404);
  CHECK(mint(k.a_read, {{"scope", "channels:subscribe"}, {"channel", "show"}}).status == 403);
  CHECK(mint(k.a, {{"scope", "admin"}}).status == 400);
  CHECK(mint(k.a, {{"scope", "speak"}, {"ttl", 100000}}).status == 400);
  CHECK(mint(token, {{"scope", "channels:subscribe"}, {"channel", "show"}}).status == 403);

  // It subscribes to its channel (in the subprotocol list, or as ?token=)...
  {
    WsClient c(port, ws_with_key(token));
    CHECK(c.subprotocol() == "facecast.v1");
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "subscribe"}, {"channel", "show"}});
    CHECK(wait_type(c, "subscribed")["channel"] == "show");
    // ...and nothing else: another channel, speaking, producing.
    c.send(nlohmann::json{{"type", "subscribe"}, {"channel", "backstage"}});
    auto e = wait_type(c, "subscribed");
    CHECK(e["type"] == "error");
    CHECK(e["code"] == "forbidden");
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"text", "hi."}});
    e = wait_type(c, "stream_start");
    CHECK(e["code"] == "forbidden");
    c.send(nlohmann::json{{"type", "produce"}, {"channel", "show"}, {"token", kProducer}});
    e = wait_type(c, "producing");
    CHECK(e["code"] == "forbidden");
  }
  {
    WsClient::Options o;
    o.target = "/ws?token=" + token;
    WsClient c(port, o);
    CHECK(c.read_json(10)["type"] == "hello");
  }
  // No /api/* at all.
  for (const std::string target : {"/api/rigs", "/api/channels/show", "/api/jobs/j1"})
    CHECK(http_request(port, http::verb::get, target, {}, bearer(token)).status == 403);
  CHECK(http_request(port, http::verb::post, "/api/render", R"({"text":"hi"})", bearer(token))
            .status == 403);
  CHECK(http_request(port, http::verb::get, "/metrics", {}, bearer(token)).status == 403);

  // Tampered (payload or signature), unsigned ("alg": "none") and expired tokens: 401.
  {
    std::string bad_sig = token;
    bad_sig[bad_sig.size() - 3] = bad_sig[bad_sig.size() - 3] == 'A' ? 'B' : 'A';
    CHECK(WsClient::handshake_status(port, ws_with_key(bad_sig)) == 401);
    const auto dot1 = token.find('.'), dot2 = token.rfind('.');
    const std::string forged_claims = base64url(nlohmann::json{
        {"iss", "facecast"},
        {"tenant", "globex"},
        {"scope", "channels:subscribe"},
        {"channel", "bshow"},
        {"exp", 4102444800}}.dump());
    const std::string forged = token.substr(0, dot1 + 1) + forged_claims + token.substr(dot2);
    CHECK(WsClient::handshake_status(port, ws_with_key(forged)) == 401);
    const std::string none = base64url(R"({"alg":"none","typ":"JWT"})") + "." + forged_claims + ".";
    CHECK(WsClient::handshake_status(port, ws_with_key(none)) == 401);
    CHECK(http_request(port, http::verb::get, "/api/rigs", {}, bearer(none)).status == 401);
  }
  const auto short_lived =
      mint(k.a, {{"scope", "channels:subscribe"}, {"channel", "show"}, {"ttl", 1}});
  REQUIRE(short_lived.status == 201);
  std::this_thread::sleep_for(std::chrono::milliseconds(2100));
  CHECK(WsClient::handshake_status(port, ws_with_key(short_lived.json()["token"])) == 401);

  // A speak token: speaks with its rig only, subscribes to nothing.
  const auto speak = mint(k.a, {{"scope", "speak"}});
  REQUIRE(speak.status == 201);
  CHECK(speak.json()["rig"] == "default");
  {
    WsClient c(port, ws_with_key(speak.json()["token"]));
    const auto hello = c.read_json(10);
    CHECK(hello["rigs"] == nlohmann::json::array({"default"}));
    c.send(nlohmann::json{{"type", "speak"}, {"id", "u1"}, {"text", "hi."}, {"audio", false}});
    CHECK(!collect_stream(c, "u1", 60).error);
    c.send(nlohmann::json{{"type", "subscribe"}, {"channel", "show"}});
    CHECK(wait_type(c, "subscribed")["code"] == "forbidden");
  }
  // The key that made a token takes it along when revoked.
  const auto owner = mint(k.b, {{"scope", "channels:subscribe"}, {"channel", "bshow"}});
  REQUIRE(owner.status == 201);
  CHECK(WsClient::handshake_status(port, ws_with_key(owner.json()["token"])) == 101);
  {
    KeyStore store(k.data / "keys.sqlite3");
    const std::string id = k.b.substr(3, 12);
    REQUIRE(store.revoke(id));
  }
  CHECK(WsClient::handshake_status(port, ws_with_key(owner.json()["token"])) == 401);

  // Channels are their tenant's: HTTP producers with a key of that tenant, or the producer token.
  int said = 0;
  const auto say = [&](const std::string& channel, const Headers& h) {
    const nlohmann::json body = {{"text", "hello"}, {"id", "say" + std::to_string(++said)}};
    return http_request(port, http::verb::post, "/api/channels/" + channel + "/speak", body.dump(),
                        with(h, "Content-Type", "application/json"))
        .status;
  };
  CHECK(say("show", bearer(k.a)) == 202);
  CHECK(say("bshow", bearer(k.a)) == 404);
  CHECK(say("show", bearer(kProducer)) == 202);
  CHECK(say("show", bearer(k.a_read)) == 403);
  CHECK(http_request(port, http::verb::get, "/api/channels/bshow", {}, bearer(k.a)).status == 404);
  CHECK(http_request(port, http::verb::get, "/api/channels/show", {}, bearer(k.a)).status == 200);
}

TEST_CASE("off loopback, and with the shipped deploy config, serve refuses to start without keys",
          "[auth][cli]") {
  const fs::path deploy = facecast::config_dir().parent_path() / "deploy" / "server.json";
  REQUIRE(fs::exists(deploy));
  const fs::path data = fresh_dir("deploy-data");
  const Cli refused =
      facecast_cli({"serve", "--config", deploy.string(), "--data", data.string(), "--port", "0"});
  CHECK(refused.status != 0);
  CHECK(refused.out.find("listening") == std::string::npos);
  INFO(refused.err);
  CHECK(std::count(refused.err.begin(), refused.err.end(), '\n') == 1);
  CHECK_THAT(refused.err, Catch::Contains("facecast keys create"));

  const fs::path open_data = fresh_dir("any-host-data");
  const Cli any_host =
      facecast_cli({"serve", "--host", "0.0.0.0", "--data", open_data.string(), "--port", "0"});
  CHECK(any_host.status != 0);
  CHECK(std::count(any_host.err.begin(), any_host.err.end(), '\n') == 1);
  CHECK_THAT(any_host.err, Catch::Contains("facecast keys create"));

  // With a key store both start, and want the key.
  for (const auto& [dir, args] : std::vector<std::pair<fs::path, std::vector<std::string>>>{
           {data, {"--config", deploy.string(), "--data", data.string()}},
           {open_data, {"--host", "0.0.0.0", "--data", open_data.string()}}}) {
    const Cli made = facecast_cli(
        {"keys", "create", "--tenant", "ops", "--scopes", "admin", "--data", dir.string()});
    REQUIRE(made.status == 0);
    const std::string key = made.out.substr(0, made.out.find('\n'));
    ServeProcess p(facecast::test::facecast_exe().string(), args, 60 * slowdown(),
                   (dir / "serve.log").string());
    CHECK(http_request(p.port(), http::verb::get, "/api/rigs").status == 401);
    CHECK(http_request(p.port(), http::verb::get, "/api/rigs", {}, bearer(key)).status == 200);
  }
}
