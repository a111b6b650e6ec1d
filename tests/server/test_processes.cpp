// Subprocesses that cannot hang or leak, and data that is never half-written: hostile uploads get a
// one-line 4xx within seconds while the server keeps answering, no child can inherit a client's
// connection, a killed server's temporaries are swept at the next start, and job ids do not
// collide between instances that share a data folder.
#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "client.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/wav.hpp"
#include "jobs.hpp"
#include "metrics.hpp"
#include "test_data.hpp"

using namespace fctest;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// An ID3 tag, then 4000 MPEG-1 layer III frame headers each followed by random bytes: the demuxer
// finds frames, the decoder fails on every one (hundreds of KB of error lines on stderr).
std::string corrupt_mp3() {
  std::string b("ID3\x04\x00\x00\x00\x00\x00\x00", 10);
  std::mt19937 rng(7);
  for (int i = 0; i < 4000; ++i) {
    b += "\xff\xfb\x90\x64";
    for (int k = 0; k < 413; ++k) b += static_cast<char>(rng() & 0xff);
  }
  return b;
}

std::string run_out(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  REQUIRE(p);
  char buf[4096];
  for (std::size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  REQUIRE(pclose(p) == 0);
  return out;
}

// Valid audio that decodes to two hours (silence compresses to ~1.3 MB of FLAC).
std::string two_hour_flac() {
  const fs::path f = facecast::test::scratch_dir() / "two-hours.flac";
  if (!fs::exists(f))
    run_out("ffmpeg -nostdin -v error -y -f lavfi -i anullsrc=r=8000:cl=mono -t 7200 -c:a flac '" +
            f.string() + "'");
  return facecast::read_file(f);
}

std::string tone_wav(double seconds) {
  const int rate = 16000;
  std::vector<std::int16_t> pcm(static_cast<std::size_t>(seconds * rate));
  for (std::size_t i = 0; i < pcm.size(); ++i)
    pcm[i] = static_cast<std::int16_t>(8000 * std::sin(2 * 3.14159265 * 220 * i / rate));
  return facecast::encode_wav(pcm, rate);
}

// Inodes of the TCP sockets whose local port is `port` (the listener and its accepted ones).
std::set<std::string> socket_inodes(unsigned short port) {
  std::set<std::string> out;
  for (const char* table : {"/proc/net/tcp", "/proc/net/tcp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::istringstream f(line);
      std::string slot, local, remote, st, queues, timer, retr, uid, timeout, inode;
      f >> slot >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode;
      const auto colon = local.rfind(':');
      if (colon != std::string::npos && std::stoul(local.substr(colon + 1), nullptr, 16) == port)
        out.insert(inode);
    }
  }
  return out;
}

}  // namespace

TEST_CASE("hostile uploads get a one-line 4xx within seconds and the server keeps answering",
          "[audio][processes]") {
  TestServer s;
  const std::string mp3 = corrupt_mp3(), flac = two_hour_flac();
  std::atomic<bool> done{false};
  std::atomic<int> health_failures{0}, health_checks{0};
  std::thread health([&] {
    while (!done) {
      const auto t0 = Clock::now();
      const auto r = http_request(s.port(), http::verb::get, "/healthz", {}, {}, 5);
      if (r.status != 200 || since(t0) > 1.0) ++health_failures;
      ++health_checks;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  const auto refused = [&](const std::string& body, int status, const std::string& words) {
    const auto t0 = Clock::now();
    const auto r = http_request(s.port(), http::verb::post, "/api/audio", body, {}, 20);
    const double took = since(t0);
    INFO(r.body);
    CHECK(took < 5 * slowdown());
    CHECK(r.status == status);
    const std::string message = r.json()["error"]["message"];
    CHECK(message.find('\n') == std::string::npos);
    CHECK(message.find(words) != std::string::npos);
    CHECK(message.find(s.options().data.string()) == std::string::npos);  // no server path
    CHECK(message.find(" @ 0x") == std::string::npos);                    // no child address
    return took;
  };
  // Corrupt MP3: ffmpeg writes ~700 KB of errors to stderr (a pipe read only after stdout would
  // hang both) and fails: 400 with its reason.
  const double corrupt = refused(mp3, 400, "uploaded audio: ffmpeg could not decode the audio: ");
  // Two hours of valid audio: decoding stops at the limit (max_audio_seconds): 413.
  const double long_audio = refused(flac, 413, "longer than the limit of 120 s");
  // Not audio at all.
  refused(std::string(20000, 'x'), 400, "uploaded audio: ffmpeg could not decode the audio");
  // A valid WAV still works.
  const auto ok = http_request(s.port(), http::verb::post, "/api/audio", tone_wav(2));
  INFO(ok.body);
  CHECK(ok.status == 201);
  CHECK(std::abs(ok.json()["seconds"].get<double>() - 2.0) < 0.01);
  done = true;
  health.join();
  CHECK(health_checks > 0);
  CHECK(health_failures == 0);
  WARN("corrupt MP3 refused in " << corrupt << " s, two-hour FLAC in " << long_audio << " s");
}

TEST_CASE("the upload limits come from max_audio_seconds and audio_decode_timeout",
          "[audio][processes][config]") {
  {
    TestServer s([](facecast::server::ServerOptions& o) { o.max_audio_seconds = 2; });
    const auto r = http_request(s.port(), http::verb::post, "/api/audio", tone_wav(3));
    CHECK(r.status == 413);
    CHECK_THAT(r.body, Catch::Contains("max_audio_seconds"));
    CHECK(http_request(s.port(), http::verb::post, "/api/audio", tone_wav(1.5)).status == 201);
  }
  {
    // A limit no decode can meet: ffmpeg is killed at it, the answer names the setting.
    TestServer s([](facecast::server::ServerOptions& o) { o.audio_decode_timeout = 0.001; });
    const auto t0 = Clock::now();
    const auto r = http_request(s.port(), http::verb::post, "/api/audio", tone_wav(1));
    CHECK(since(t0) < 5);
    CHECK(r.status == 413);
    CHECK_THAT(r.body, Catch::Contains("audio_decode_timeout"));
  }
}

TEST_CASE("the listening socket and every accepted connection are close-on-exec", "[processes]") {
  TestServer s;
  // Connections the server holds open: a WebSocket and a keep-alive HTTP client.
  WsClient ws(s.port());
  REQUIRE(ws.read_json(10)["type"] == "hello");
  net::io_context ioc;
  tcp::socket raw(ioc);
  raw.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), s.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // accepted by now
  const std::set<std::string> inodes = socket_inodes(s.port());
  int checked = 0;
  for (const auto& e : fs::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    const std::string target = fs::read_symlink(e.path(), ec).string();
    if (ec || !target.starts_with("socket:[")) continue;
    const std::string inode = target.substr(8, target.size() - 9);
    if (!inodes.contains(inode)) continue;
    const int fd = std::stoi(e.path().filename().string());
    // The test's own client sockets are not the server's: theirs have a remote port of s.port().
    sockaddr_storage local{};
    socklen_t len = sizeof local;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&local), &len) != 0) continue;
    const auto* in4 = reinterpret_cast<const sockaddr_in*>(&local);
    if (local.ss_family != AF_INET || ntohs(in4->sin_port) != s.port()) continue;
    INFO("descriptor " << fd);
    CHECK((fcntl(fd, F_GETFD) & FD_CLOEXEC) != 0);
    ++checked;
  }
  CHECK(checked >= 3);  // the listener and two accepted connections
}

TEST_CASE("temporaries a killed server left are swept at start, nothing else",
          "[processes][durability]") {
  const fs::path root = facecast::test::scratch_dir() / "sweep";
  fs::remove_all(root);
  const fs::path data = root / "data", shared = root / "shared";
  const auto write = [](const fs::path& f, const std::string& text) {
    fs::create_directories(f.parent_path());
    std::ofstream(f) << text;
  };
  // What a SIGKILL leaves: write_file_atomic's temporaries, a half-stored rig folder, a rig
  // delete cut short, a video being encoded, an upload being decoded.
  write(data / "jobs.sqlite3.tmp1a2b3c4d5e6f", "half");
  write(data / "rigs" / "r0123456789abcdef.tmp" / "rig.glb", "half");
  write(data / "rigs" / "r0123456789abcdee.tmp.deleted" / "meta.json", "{}");
  write(data / "renders" / ".tmp-j0195f0a1b2c3d4e5f6a7-0a1b2c3d4e5f.mp4", "half");
  write(data / "tmp" / "upload-0123456789abcdef.tmp", "half");
  // Kept: finished data, and a fresh temporary in the shared folder (another instance's).
  write(data / "renders" / "j0195f0a1b2c3d4e5f6a7.mp4", "video");
  write(data / "notes.txt", "mine");
  write(shared / "rigs" / "r1111111111111111.tmp" / "rig.glb", "being written elsewhere");
  write(shared / "renders" / ".tmp-j1-aa.mp4", "old leftover");
  fs::last_write_time(shared / "renders" / ".tmp-j1-aa.mp4",
                      fs::file_time_type::clock::now() - std::chrono::hours(2));
  {
    TestServer s([&](facecast::server::ServerOptions& o) {
      o.data = data;
      o.shared_dir = shared;
    });
    CHECK(http_request(s.port(), http::verb::get, "/healthz").status == 200);
  }
  CHECK_FALSE(fs::exists(data / "jobs.sqlite3.tmp1a2b3c4d5e6f"));
  CHECK_FALSE(fs::exists(data / "rigs" / "r0123456789abcdef.tmp"));
  CHECK_FALSE(fs::exists(data / "rigs" / "r0123456789abcdee.tmp.deleted"));
  CHECK_FALSE(fs::exists(data / "renders" / ".tmp-j0195f0a1b2c3d4e5f6a7-0a1b2c3d4e5f.mp4"));
  CHECK_FALSE(fs::exists(data / "tmp" / "upload-0123456789abcdef.tmp"));
  CHECK_FALSE(fs::exists(shared / "renders" / ".tmp-j1-aa.mp4"));
  CHECK(fs::exists(data / "renders" / "j0195f0a1b2c3d4e5f6a7.mp4"));
  CHECK(fs::exists(data / "notes.txt"));
  CHECK(fs::exists(data / "jobs.sqlite3"));
  CHECK(fs::exists(shared / "rigs" / "r1111111111111111.tmp" / "rig.glb"));
}

TEST_CASE("two job queues sharing a data folder never hand out the same id", "[jobs][processes]") {
  using namespace facecast::server;
  const fs::path dir = facecast::test::scratch_dir() / "shared-jobs";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Metrics metrics_a, metrics_b;
  JobsOptions o;
  o.max_jobs = 2000;
  o.store = dir / "jobs.sqlite3";
  o.retention = 0;
  std::vector<std::string> a, b;
  {
    Jobs ja(metrics_a, o), jb(metrics_b, o);  // two instances, one folder, no Redis
    const auto work = [](JobContext&) { return nlohmann::json::object(); };
    std::thread ta([&] {
      for (int i = 0; i < 500; ++i) a.push_back(ja.submit("test", work));
    });
    std::thread tb([&] {
      for (int i = 0; i < 500; ++i) b.push_back(jb.submit("test", work));
    });
    ta.join();
    tb.join();
    // Each instance reads the other's records from the shared store: none was overwritten.
    for (std::size_t i = 0; i < a.size(); i += 50) {
      const auto j = jb.get(a[i]);
      REQUIRE(j);
      CHECK((*j)["id"] == a[i]);
    }
  }
  std::set<std::string> all(a.begin(), a.end());
  all.insert(b.begin(), b.end());
  CHECK(all.size() == 1000);
  for (const auto& id : all) {
    CHECK(id.size() == 21);
    CHECK(id[0] == 'j');
  }
  // The job routes take them (this server has no such job: the route's own answer).
  TestServer s;
  const auto r = http_request(s.port(), http::verb::get, "/api/jobs/" + a.front());
  CHECK(r.status == 404);
  CHECK_THAT(r.body, Catch::Contains("job '" + a.front() + "' does not exist"));
  const auto f = http_request(s.port(), http::verb::get, "/api/jobs/" + a.front() + "/video.mp4");
  CHECK(f.status == 404);
}
