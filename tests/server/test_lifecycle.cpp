// Shutdown with clients connected: in-process stop() and the real `facecast serve` on SIGTERM.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <catch2/catch.hpp>
#include <regex>
#include <thread>

#include "client.hpp"
#include "test_data.hpp"

extern char** environ;

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

TEST_CASE("facecast serve prints its port and exits on SIGTERM with clients connected",
          "[lifecycle]") {
  const auto data = facecast::test::scratch_dir() / "serve-data";
  int out[2];
  REQUIRE(pipe(out) == 0);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  const std::string exe = FACECAST_EXE;
  const std::string data_arg = data.string();
  std::vector<std::string> args = {exe,      "serve",  "--port",      "0",
                                   "--data", data_arg, "--log-level", "warn"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  REQUIRE(posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ) == 0);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  // "facecast: listening on http://127.0.0.1:PORT"
  std::string line;
  const auto t0 = Clock::now();
  while (line.find('\n') == std::string::npos && since(t0) < 30 * slowdown()) {
    pollfd p{out[0], POLLIN, 0};
    if (poll(&p, 1, 200) > 0) {
      char buf[256];
      const ssize_t n = read(out[0], buf, sizeof buf);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
    }
  }
  close(out[0]);
  std::smatch m;
  const bool matched = std::regex_search(
      line, m, std::regex(R"(facecast: listening on http://127\.0\.0\.1:([0-9]+))"));
  if (!matched) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    FAIL("no port line: '" << line << "'");
  }
  const auto port = static_cast<unsigned short>(std::stoi(m[1]));
  CHECK(port != 0);
  CHECK(port != 8080);
  {
    WsClient c(port);
    CHECK(c.read_json(10)["type"] == "hello");
    c.send(nlohmann::json{{"type", "speak"},
                          {"id", "s"},
                          {"audio", false},
                          {"text", "Still talking when the signal comes."}});
    for (;;) {
      auto msg = c.read(20 * slowdown());
      REQUIRE(msg);
      if (!msg->text) break;
    }
    WsClient idle(port);
    CHECK(idle.read_json(10)["type"] == "hello");
    const auto t1 = Clock::now();
    REQUIRE(kill(pid, SIGTERM) == 0);
    CHECK(read_until_closed(c, 5) == 1001);
    CHECK(read_until_closed(idle, 5) == 1001);
    int status = -1;
    while (since(t1) < 5 * slowdown()) {
      if (waitpid(pid, &status, WNOHANG) == pid) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const double took = since(t1);
    if (!(WIFEXITED(status))) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      FAIL("facecast serve did not exit within 5 s of SIGTERM");
    }
    CHECK(WEXITSTATUS(status) == 0);
    CHECK(took < 3.5 * slowdown());
  }
}
