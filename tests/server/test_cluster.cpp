// Many instances on loopback: redis-server, nginx (the shipped deploy/nginx.conf with two
// upstreams) and two `facecast serve` processes A and B sharing a rig folder. A producer on A
// reaches subscribers that nginx placed on both instances, every frame of the utterance; a rig job
// posted to A is fetched from B; SIGKILL of B loses no job (A takes over B's in-flight job when
// B's heartbeat expires) and B's subscribers reconnect through nginx to A.
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <catch2/catch.hpp>
#include <fstream>
#include <regex>
#include <thread>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/server/server.hpp"
#include "serve_process.hpp"
#include "test_data.hpp"

using namespace fctest;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

bool accepts(unsigned short port) {
  net::io_context io;
  tcp::socket s(io);
  boost::system::error_code ec;
  s.connect({net::ip::make_address("127.0.0.1"), port}, ec);
  return !ec;
}

// A child process that dies with the test (SIGKILL when the thread that started it ends), ready
// when `port` accepts connections.
class Child {
 public:
  Child(std::vector<std::string> args, unsigned short port, const fs::path& log) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        dup2(fd, 1);
        dup2(fd, 2);
      }
      execv(argv[0], argv.data());
      _exit(127);
    }
    for (int i = 0; i < 200 && !accepts(port); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!accepts(port))
      FAIL(args[0] << " did not listen on " << port << ": " << facecast::read_file(log));
  }
  ~Child() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }

 private:
  pid_t pid_ = -1;
};

// deploy/nginx.conf with the test's two instances as upstreams, on a free port, every path in
// `dir` (no root needed).
std::unique_ptr<Child> start_nginx(const fs::path& dir, unsigned short port, unsigned short a,
                                   unsigned short b) {
  std::string site =
      facecast::read_file(facecast::config_dir().parent_path() / "deploy/nginx.conf");
  const std::string upstream = "server 127.0.0.1:8080 max_fails=2 fail_timeout=5s;";
  REQUIRE(site.find(upstream) != std::string::npos);
  REQUIRE(site.find("listen 80;") != std::string::npos);
  site.replace(site.find(upstream), upstream.size(),
               "server 127.0.0.1:" + std::to_string(a) + " max_fails=2 fail_timeout=5s;\n  " +
                   "server 127.0.0.1:" + std::to_string(b) + " max_fails=2 fail_timeout=5s;");
  site.replace(site.find("listen 80;"), 10, "listen 127.0.0.1:" + std::to_string(port) + ";");
  std::ofstream(dir / "site.conf") << site;
  const std::string d = dir.string();
  std::ofstream(dir / "nginx.conf")
      << "daemon off;\nmaster_process off;\nworker_processes 1;\npid " << d << "/nginx.pid;\n"
      << "error_log " << d << "/error.log info;\nevents { worker_connections 256; }\nhttp {\n"
      << "  access_log " << d << "/access.log;\n  client_body_temp_path " << d << "/body;\n"
      << "  proxy_temp_path " << d << "/proxy;\n  fastcgi_temp_path " << d << "/fastcgi;\n"
      << "  uwsgi_temp_path " << d << "/uwsgi;\n  scgi_temp_path " << d << "/scgi;\n"
      << "  include " << d << "/site.conf;\n}\n";
  return std::make_unique<Child>(
      std::vector<std::string>{"/usr/sbin/nginx", "-p", d, "-e", d + "/early.log", "-c",
                               d + "/nginx.conf"},
      port, dir / "nginx.out");
}

nlohmann::json wait_for(WsClient& c, const std::string& type, double timeout = 20) {
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(timeout));
  while (Clock::now() < deadline) {
    const auto m = c.read(std::chrono::duration<double>(deadline - Clock::now()).count());
    if (!m) break;
    if (m->text && m->json()["type"] == type) return m->json();
  }
  throw std::runtime_error("no '" + type + "' message");
}

std::unique_ptr<WsClient> subscriber(unsigned short port) {
  auto c = std::make_unique<WsClient>(port);
  REQUIRE(c->read_json(10)["type"] == "hello");
  c->send(nlohmann::json{{"type", "subscribe"}, {"channel", "show"}});
  CHECK(wait_for(*c, "subscribed")["channel"] == "show");
  return c;
}

long local_subscribers(unsigned short port) {
  const auto r = http_request(port, http::verb::get, "/api/channels/show");
  REQUIRE(r.status == 200);
  return r.json()["local_subscribers"].get<long>();
}

// Waits until `ok(json)` holds for GET `target` on `port`.
nlohmann::json poll(unsigned short port, const std::string& target,
                    const std::function<bool(const nlohmann::json&)>& ok, double timeout) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout * slowdown());
  for (;;) {
    const auto r = http_request(port, http::verb::get, target);
    INFO(target << ": " << r.status << " " << r.body);
    REQUIRE(r.status == 200);
    if (ok(r.json())) return r.json();
    REQUIRE(Clock::now() < deadline);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
}

// The last lines of each instance's log, for a failure's message.
std::string log_tails(const fs::path& dir) {
  std::string out;
  for (const char* name : {"a.log", "b.log"}) {
    const std::string log = facecast::read_file(dir / name);
    out += std::string("--- ") + name + " ---\n" +
           log.substr(log.size() > 4000 ? log.size() - 4000 : 0);
  }
  return out;
}

// Speaks utterance `id` on A and checks that every subscriber gets every frame, once, in order.
void every_frame_everywhere(WsClient& producer, std::vector<std::unique_ptr<WsClient>>& subs,
                            const std::string& id, const fs::path& dir) {
  producer.send(nlohmann::json{{"type", "speak"},
                               {"id", id},
                               {"channel", "show"},
                               {"text", "Good evening from every instance. The show goes on."}});
  for (std::size_t i = 0; i < subs.size(); ++i) {
    StreamResult r;
    try {
      r = collect_stream(*subs[i], id, 60 * slowdown());
    } catch (const std::exception& e) {
      FAIL("subscriber " << i << ": " << e.what() << "\n" << log_tails(dir));
    }
    REQUIRE_FALSE(r.error);
    std::uint32_t next = 0;
    for (const auto& w : r.weights) {
      REQUIRE(w.header.first == next);
      next += w.header.count;
    }
    CHECK(next == r.start["frames"].get<std::uint32_t>());
    CHECK(next > 20);
    CHECK(r.end["cancelled"] == false);
  }
}

std::string rig_body(int variant) {
  const auto avatar = facecast::avatar::make_avatar(facecast::avatar::avatar_variant(variant));
  const fs::path obj =
      facecast::test::scratch_dir() / ("cluster" + std::to_string(variant) + ".obj");
  facecast::rig::write_obj(obj, avatar);
  return nlohmann::json{{"name", "V" + std::to_string(variant)},
                        {"mesh", {{"format", "obj"}, {"data", facecast::read_file(obj)}}},
                        {"options", {{"virtual_edges", "off"}}}}
      .dump();
}

std::string post_rig(unsigned short port, int variant) {
  const auto r = http_request(port, http::verb::post, "/api/rigs", rig_body(variant));
  INFO(r.body);
  REQUIRE(r.status == 202);
  return r.json()["job"];
}

}  // namespace

TEST_CASE("two instances behind nginx share channels and jobs through Redis", "[slow][cluster]") {
  const fs::path dir = facecast::test::scratch_dir() / "cluster";
  fs::remove_all(dir);
  fs::create_directories(dir / "nginx");
  const unsigned short redis_port = free_port();
  Child redis({"/usr/bin/redis-server", "--port", std::to_string(redis_port), "--bind", "127.0.0.1",
               "--save", "", "--appendonly", "no", "--dir", dir.string()},
              redis_port, dir / "redis.log");

  const nlohmann::json config = {
      {"redis", {{"url", "redis://127.0.0.1:" + std::to_string(redis_port)}, {"heartbeat", 0.5}}},
      {"shared_dir", (dir / "shared").string()},
      {"channels", {{"show", {{"producer_token", kProducerToken}}}}},
      {"channel_idle", 0},
      {"presence_interval", 0.2},
      {"job_workers", 1},
      // The subscribers are not read while the rig jobs run (two minutes under ThreadSanitizer);
      // an idle peer that answers no ping is closed after ws_idle_timeout.
      {"ws_idle_timeout", 60 * slowdown()}};
  facecast::write_file_atomic(dir / "server.json", config.dump(2));
  auto serve = [&](const std::string& name) {
    return std::make_unique<ServeProcess>(
        facecast::test::facecast_exe().string(),
        std::vector<std::string>{"--config", (dir / "server.json").string(), "--data",
                                 (dir / name).string()},
        60 * slowdown(), (dir / (name + ".log")).string());
  };
  auto a = serve("a");
  auto b = serve("b");
  const unsigned short front = free_port();
  auto nginx = start_nginx(dir / "nginx", front, a->port(), b->port());

  // Subscribers through nginx: round robin places them on both instances.
  std::vector<std::unique_ptr<WsClient>> subs;
  std::vector<bool> on_b;
  for (int i = 0; i < 4; ++i) {
    const long before = local_subscribers(a->port());
    subs.push_back(subscriber(front));
    on_b.push_back(local_subscribers(a->port()) == before);
  }
  CHECK(local_subscribers(a->port()) == 2);
  CHECK(local_subscribers(b->port()) == 2);
  // Presence is summed over the instances (heartbeats every 0.5 s).
  poll(
      b->port(), "/api/channels/show", [](const auto& j) { return j["subscribers"] == 4; }, 10);

  auto producer = std::make_unique<WsClient>(a->port());
  REQUIRE(producer->read_json(10)["type"] == "hello");
  producer->send(
      nlohmann::json{{"type", "produce"}, {"channel", "show"}, {"token", kProducerToken}});
  CHECK(wait_for(*producer, "producing")["channel"] == "show");
  every_frame_everywhere(*producer, subs, "u1", dir);

  // A rig job posted to A finishes and is read from B, and B serves the rig (shared folder).
  const std::string j0 = post_rig(a->port(), 3);
  const auto done = poll(
      b->port(), "/api/jobs/" + j0,
      [](const auto& j) { return j["state"] == "done" || j["state"] == "failed"; }, 600);
  INFO(done.dump());
  REQUIRE(done["state"] == "done");
  const std::string rig = done["result"]["rig"];
  CHECK(http_request(b->port(), http::verb::get, "/api/rigs/" + rig + ".glb").status == 200);
  CHECK(http_request(a->port(), http::verb::get, "/api/rigs/" + rig + ".glb").status == 200);

  // Two more jobs: each instance's one job worker takes one. SIGKILL B while both run.
  const std::string j1 = post_rig(a->port(), 5);
  const std::string j2 = post_rig(a->port(), 6);
  for (const auto& j : {j1, j2})
    poll(
        a->port(), "/api/jobs/" + j, [](const auto& r) { return r["state"] == "running"; }, 60);
  kill(b->pid(), SIGKILL);
  REQUIRE(b->wait_exit(10));
  // No job is lost: A finishes its own and then B's (requeued when B's heartbeat expired).
  for (const auto& j : {j1, j2}) {
    const auto r = poll(
        a->port(), "/api/jobs/" + j,
        [](const auto& x) { return x["state"] == "done" || x["state"] == "failed"; }, 900);
    INFO(r.dump());
    CHECK(r["state"] == "done");
  }
  // ...because A took over the job B held when it died.
  CHECK(facecast::read_file(dir / "a.log").find("jobs_requeued") != std::string::npos);

  // B's subscribers were disconnected; they reconnect through nginx, which now reaches only A.
  for (std::size_t i = 0; i < subs.size(); ++i) {
    if (!on_b[i]) continue;
    while (subs[i]->read(10 * slowdown())) {
    }  // what is left of the first show, then the close
    CHECK(subs[i]->error() != "timeout");
    subs[i] = subscriber(front);
  }
  CHECK(local_subscribers(a->port()) == 4);
  every_frame_everywhere(*producer, subs, "u2", dir);
}

TEST_CASE("a server whose Redis does not answer stops with one line naming it", "[cluster]") {
  const unsigned short port = free_port();  // nothing listens there
  facecast::server::ServerOptions o;
  o.port = 0;
  o.data = facecast::test::scratch_dir() / "no-redis";
  o.redis.url = "redis://127.0.0.1:" + std::to_string(port);
  try {
    facecast::server::Server s(o);
    FAIL("the server started without its Redis");
  } catch (const facecast::Error& e) {
    const std::string what = e.what();
    CHECK_THAT(what, Catch::Contains("redis 127.0.0.1:" + std::to_string(port)));
    CHECK(what.find('\n') == std::string::npos);
  }
  o.redis.url = "redis://127.0.0.1:99999";
  CHECK_THROWS_WITH(facecast::server::Server(o), Catch::Contains("redis.url: port 99999"));
}
