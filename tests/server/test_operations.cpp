// Operations: job records that survive restarts and crashes, retention of rendered videos,
// DELETE of rigs and jobs, X-Forwarded-For in the logs.
#include <signal.h>

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <thread>

#include "build_paths.hpp"
#include "client.hpp"
#include "serve_process.hpp"
#include "test_avatar_file.hpp"
#include "test_data.hpp"

using namespace fctest;
using facecast::server::ServerOptions;
namespace fs = std::filesystem;

namespace {

// POST /api/render of `text` (small and quick) -> the job id.
std::string start_render(unsigned short port, const std::string& text) {
  const nlohmann::json body = {{"text", text}, {"size", {64, 48}}, {"fps", 10}, {"audio", false}};
  const auto r = http_request(port, http::verb::post, "/api/render", body.dump());
  INFO(r.body);
  REQUIRE(r.status == 202);
  return r.json()["job"];
}

// GET /api/jobs/{id} until it has ended.
nlohmann::json ended_job(unsigned short port, const std::string& id, double timeout) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  for (;;) {
    const auto j = http_request(port, http::verb::get, "/api/jobs/" + id).json();
    if (j["state"] == "done" || j["state"] == "failed") return j;
    REQUIRE(std::chrono::steady_clock::now() < deadline);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

int status_of(unsigned short port, http::verb verb, const std::string& target) {
  return http_request(port, verb, target).status;
}

}  // namespace

TEST_CASE("job records and videos survive a restart, and DELETE removes them",
          "[jobs][operations]") {
  TestServer s;
  const std::string id = start_render(s.port(), "Kept.");
  const auto done = ended_job(s.port(), id, 120 * slowdown());
  REQUIRE(done["state"] == "done");
  CHECK(done["created"].get<double>() > 1.7e9);
  const std::string url = done["result"]["url"];
  const std::string video = http_request(s.port(), http::verb::get, url).body;
  REQUIRE(video.substr(4, 4) == "ftyp");
  CHECK(fs::exists(s.options().data / "jobs.sqlite3"));

  s.restart();
  const auto after = http_request(s.port(), http::verb::get, "/api/jobs/" + id);
  REQUIRE(after.status == 200);
  CHECK(after.json() == done);
  CHECK(http_request(s.port(), http::verb::get, url).body == video);
  // Ids are time-ordered and random: a new job never takes an old job's id.
  const std::string next = start_render(s.port(), "New.");
  CHECK(next != id);
  CHECK(next.size() == id.size());
  CHECK(next > id);
  CHECK(ended_job(s.port(), next, 120 * slowdown())["state"] == "done");

  // DELETE: record and video gone, also after a restart; a second DELETE is a 404.
  const fs::path file = s.options().data / "renders" / (id + ".mp4");
  REQUIRE(fs::exists(file));
  const auto del = http_request(s.port(), http::verb::delete_, "/api/jobs/" + id);
  CHECK(del.status == 200);
  CHECK(del.json()["deleted"] == id);
  CHECK(status_of(s.port(), http::verb::get, "/api/jobs/" + id) == 404);
  CHECK(status_of(s.port(), http::verb::get, url) == 404);
  CHECK_FALSE(fs::exists(file));
  CHECK(status_of(s.port(), http::verb::delete_, "/api/jobs/" + id) == 404);
  s.restart();
  CHECK(status_of(s.port(), http::verb::get, "/api/jobs/" + id) == 404);
  CHECK(status_of(s.port(), http::verb::get, "/api/jobs/" + next) == 200);
}

TEST_CASE("ended jobs and their videos are removed after job_retention", "[jobs][operations]") {
  TestServer s([](ServerOptions& o) { o.job_retention = 1; });
  const std::string old = start_render(s.port(), "Soon gone.");
  REQUIRE(ended_job(s.port(), old, 120 * slowdown())["state"] == "done");
  const fs::path file = s.options().data / "renders" / (old + ".mp4");
  REQUIRE(fs::exists(file));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  // The next job (or a restart) sweeps what is older than the retention time.
  const std::string young = start_render(s.port(), "Still here.");
  CHECK(status_of(s.port(), http::verb::get, "/api/jobs/" + old) == 404);
  CHECK_FALSE(fs::exists(file));
  CHECK(status_of(s.port(), http::verb::get, "/api/jobs/" + young) == 200);
}

TEST_CASE("a job cut off by a crash reads as interrupted after the restart", "[jobs][operations]") {
  const auto data = facecast::test::scratch_dir() / "crash-data";
  std::string id;
  {
    ServeProcess serve(facecast::test::facecast_exe().string(),
                       {"--data", data.string(), "--log-level", "warn"}, 30 * slowdown());
    // Long enough to be still queued or running when the process is killed.
    id = start_render(serve.port(), std::string(40, 'a') + " " + std::string(40, 'b') + ".");
    REQUIRE(kill(serve.pid(), SIGKILL) == 0);
    REQUIRE(serve.wait_exit(10));
  }
  ServeProcess serve(facecast::test::facecast_exe().string(),
                     {"--data", data.string(), "--log-level", "warn"}, 30 * slowdown());
  const auto r = http_request(serve.port(), http::verb::get, "/api/jobs/" + id);
  REQUIRE(r.status == 200);
  const auto j = r.json();
  CHECK(j["state"] == "failed");
  CHECK_THAT(j["error"]["message"].get<std::string>(), Catch::Contains("interrupted"));
}

TEST_CASE("DELETE /api/rigs removes a stored rig, built-in and default rigs stay",
          "[rigs][operations]") {
  TestServer s;
  const auto r =
      http_request(s.port(), http::verb::post, "/api/rigs?name=Gone",
                   facecast::test::test_avatar_glb(), {{"Content-Type", "model/gltf-binary"}});
  REQUIRE(r.status == 201);
  const std::string id = r.json()["id"];
  REQUIRE(fs::exists(s.options().data / "rigs" / id));
  // Warm a renderer of it, then delete it.
  {
    WsClient c(s.port());
    c.read_json(10);
    c.send(nlohmann::json{
        {"type", "speak"}, {"id", "u"}, {"rig", id}, {"text", "Hi."}, {"audio", false}});
    REQUIRE_FALSE(collect_stream(c, "u").error);
  }
  const auto del = http_request(s.port(), http::verb::delete_, "/api/rigs/" + id);
  INFO(del.body);
  CHECK(del.status == 200);
  CHECK(del.json()["deleted"] == id);
  CHECK(status_of(s.port(), http::verb::get, "/api/rigs/" + id + ".glb") == 404);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"].size() == 2);
  CHECK_FALSE(fs::exists(s.options().data / "rigs" / id));
  CHECK(status_of(s.port(), http::verb::delete_, "/api/rigs/" + id) == 404);
  const auto builtin = http_request(s.port(), http::verb::delete_, "/api/rigs/default");
  CHECK(builtin.status == 403);
  CHECK_THAT(builtin.body, Catch::Contains("default"));
  {
    WsClient c(s.port());
    c.read_json(10);
    c.send(nlohmann::json{{"type", "speak"}, {"id", "v"}, {"rig", id}, {"text", "Hi."}});
    const auto gone = collect_stream(c, "v");
    REQUIRE(gone.error);
    CHECK((*gone.error)["code"] == "not_found");
  }
  s.restart();
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"].size() == 2);
  for (const auto& e : fs::directory_iterator(s.options().data / "rigs")) FAIL(e.path().string());
}

TEST_CASE("the logs name the client behind a proxy (X-Forwarded-For)", "[operations]") {
  const auto dir = facecast::test::scratch_dir() / "xff";
  fs::create_directories(dir);
  const std::string log = (dir / "serve.log").string();
  {
    ServeProcess serve(facecast::test::facecast_exe().string(),
                       {"--data", (dir / "data").string(), "--log-level", "debug"}, 30 * slowdown(),
                       log);
    http_request(serve.port(), http::verb::get, "/healthz", {},
                 {{"X-Forwarded-For", "203.0.113.7"}});
    WsClient::Options o;
    o.headers = {{"X-Forwarded-For", "198.51.100.9, 10.0.0.2"}};
    WsClient c(serve.port(), o);
    c.read_json(10);
    c.close();
  }
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  const std::string lines = text.str();
  INFO(lines);
  CHECK_THAT(lines,
             Catch::Contains("http_request conn=") && Catch::Contains("forwarded_for=203.0.113.7"));
  CHECK_THAT(lines, Catch::Contains("ws_open conn=") &&
                        Catch::Contains("forwarded_for=\"198.51.100.9, 10.0.0.2\""));
}
