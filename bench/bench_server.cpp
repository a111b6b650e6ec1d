// Load benchmark of `facecast serve` (started as a child process on a free port), with the load
// generator in this process on the same machine:
//  1. weights: N WebSocket clients (default 1000), each speaking utterance after utterance (no
//     audio, 60 fps weights) for S seconds (default 60), starts spread over --ramp seconds.
//     Reports the share of frames that arrive within 50 ms of their schedule (stream_start arrival
//     + pts - lead), the server's RSS (peak), its CPU, and the time from speak to the first frame
//     (p50/p99, measured at the client).
//  2. frames: 2 clients at once in frames mode at 640x480 (JPEG) for --frames-seconds: delivered
//     frames per second each.
//  3. broadcast (bench_broadcast.cpp): one channel, --broadcast subscribers (10000), a producer
//     speaking 60 fps weights with audio for --broadcast-seconds (60).
// Usage: bench_server [--clients 1000] [--seconds 60] [--ramp 5] [--fps 60] [--min-tick (config)]
//                     [--frames-clients 2] [--frames-seconds 15] [--frames-fps 30]
//                     [--frames-size 640x480] [--client-threads 1] [--exe path/to/facecast]
//                     [--set key=json ...] (server config values, e.g. --set frames_in_flight=3)
//                     [--broadcast 10000] [--broadcast-seconds 60] [--broadcast-ramp 10]
//                     (--clients 0, --frames-clients 0, --broadcast 0 skip a case)
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_broadcast.hpp"
#include "bench_hostile.hpp"
#include "build_paths.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/server/protocol.hpp"
#include "serve_process.hpp"
#include "ws_client.hpp"

namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

double secs(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

Clock::duration from_secs(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

struct Args {
  int clients = 1000;
  double seconds = 60, ramp = 5, fps = 60, min_tick = -1;  // -1: the config's
  int frames_clients = 2;
  double frames_seconds = 15, frames_fps = 30;
  int width = 640, height = 480;
  int client_threads = 1;
  std::string exe = facecast::test::facecast_exe().string();
  std::vector<std::pair<std::string, std::string>> set;  // --set key=json (server config)
  bench::BroadcastArgs broadcast;
  int hostile = 0;
};

// ---- the server process -------------------------------------------------------------------------

// Resident set size and its peak (VmHWM) of process `pid`, MB.
std::pair<double, double> rss(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  double rss = 0, hwm = 0;
  while (std::getline(in, line)) {
    if (line.starts_with("VmRSS:")) rss = std::stod(line.substr(6)) / 1024.0;
    if (line.starts_with("VmHWM:")) hwm = std::stod(line.substr(6)) / 1024.0;
  }
  return {rss, hwm};
}

// User + system CPU seconds of process `pid`.
double cpu(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(in)), {});
  const auto close = s.rfind(')');
  std::istringstream rest(s.substr(close + 2));
  std::string field;
  std::vector<std::string> f;
  while (rest >> field) f.push_back(field);
  // fields after ")": state(0) ... utime(11) stime(12)
  return (std::stod(f[11]) + std::stod(f[12])) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// CPU seconds of this process (the load generator).
double self_cpu() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec +
         1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

// ---- the load generator -------------------------------------------------------------------------

const std::vector<std::string> kSentences = {
    "Hello everyone, and welcome to the show.",
    "Today we talk about speech driven faces.",
    "大家好，欢迎来到今天的直播。",
    "The weather is lovely this afternoon, isn't it?",
    "我们今天介绍一个新的产品。",
    "Please remember to subscribe and share.",
    "(joy, 40, 0.5)That is wonderful news!",
    "谢谢大家的支持，我们下次再见。",
    "Numbers like 42 and 2024 are read out too.",
    "Facecast streams blendshape weights in real time.",
};

struct Stats {
  std::uint64_t frames = 0, on_time = 0, late_presentation = 0, dropped = 0, streams = 0,
                errors = 0;
  std::vector<double> ttff;     // seconds
  std::vector<float> lateness;  // seconds, sampled (every frame)
  std::vector<std::string> error_messages;
  void merge(const Stats& o) {
    for (auto count : {&Stats::frames, &Stats::on_time, &Stats::late_presentation, &Stats::dropped,
                       &Stats::streams, &Stats::errors})
      this->*count += o.*count;
    ttff.insert(ttff.end(), o.ttff.begin(), o.ttff.end());
    lateness.insert(lateness.end(), o.lateness.begin(), o.lateness.end());
    if (error_messages.size() < 5)
      error_messages.insert(error_messages.end(), o.error_messages.begin(), o.error_messages.end());
  }
};

struct ClientResult {
  Stats stats;
  std::uint64_t jpeg_frames = 0, jpeg_bytes = 0;
  Clock::time_point first_stream_at{}, last_frame_at{};
  bool failed = false;
};

// One client: speaks utterance after utterance from start_at until stop_at, then closes.
class Client : public fctest::AsyncWsClient {
 public:
  struct Config {
    unsigned short port;
    Clock::time_point start_at, stop_at;
    double fps;
    std::string output = "weights";
    int width = 640, height = 480;
    std::uint32_t seed;
  };
  Client(net::io_context& ioc, Config c)
      : AsyncWsClient(ioc, {.port = c.port}), timer_(executor()), c_(std::move(c)), rng_(c_.seed) {}

  ClientResult result;
  std::atomic<bool> done{false}, failed{false};

 private:
  void on_open() override {
    timer_.expires_at(c_.start_at);
    timer_.async_wait([this, self = shared_from_this()](beast::error_code e) {
      if (!e) speak();
    });
  }
  void speak() {
    if (Clock::now() >= c_.stop_at) {
      done = true;
      close();
      return;
    }
    ++n_;
    const std::string id = "u" + std::to_string(n_);
    json j = {{"type", "speak"}, {"id", id},      {"text", kSentences[rng_() % kSentences.size()]},
              {"audio", false},  {"fps", c_.fps}, {"output", c_.output}};
    if (c_.output == "frames") j["size"] = {c_.width, c_.height};
    sent_at_ = Clock::now();
    got_first_ = false;
    send(j.dump());
  }
  void on_message(const Message& m) override {
    if (m.text) return on_text(json::parse(m.data), m.at);
    if (m.data.size() < facecast::server::kHeaderSize) return;
    const auto h = facecast::server::read_header(m.data);
    if (!got_first_) {
      got_first_ = true;
      result.stats.ttff.push_back(secs(m.at - sent_at_));
    }
    if (h.kind == facecast::server::MediaKind::kJpeg) {
      ++result.jpeg_frames;
      result.jpeg_bytes += m.data.size();
      result.last_frame_at = m.at;
    }
    for (std::uint32_t k = 0; k < h.count && h.kind != facecast::server::MediaKind::kAudio; ++k) {
      const double pts = h.pts + k / fps_;
      // The schedule: sent at stream start + pts - lead, but not before the stream starts.
      const double late = secs(m.at - stream_start_) - std::max(0.0, pts - lead_);
      ++result.stats.frames;
      result.stats.on_time += late <= 0.050;
      result.stats.late_presentation += late > lead_;
      result.stats.lateness.push_back(static_cast<float>(late));
    }
  }
  void on_text(const json& j, Clock::time_point now) {
    const std::string type = j.value("type", "");
    if (type == "stream_start") {
      stream_start_ = now;
      if (result.first_stream_at.time_since_epoch().count() == 0) result.first_stream_at = now;
      fps_ = j["fps"];
      lead_ = j.value("lead", 0.1);
    } else if (type == "stream_end") {
      ++result.stats.streams;
      result.stats.dropped += j["dropped"].get<std::uint64_t>();
      speak();
    } else if (type == "error") {
      ++result.stats.errors;
      if (result.stats.error_messages.size() < 3) result.stats.error_messages.push_back(j.dump());
      speak();
    }
  }
  void on_error(const std::string& what) override {
    if (!failed) result.stats.error_messages.push_back(what);
    failed = true;
    ++result.stats.errors;
  }

  net::steady_timer timer_;
  Config c_;
  std::mt19937 rng_;
  int n_ = 0;
  Clock::time_point sent_at_, stream_start_;
  bool got_first_ = false;
  double fps_ = 60, lead_ = 0.1;
};

// Mean of a Prometheus histogram (sum / count), and the smallest bucket bound holding `q` of it.
std::pair<double, double> histogram(const std::string& metrics, const std::string& name, double q) {
  const auto value = [&](const std::string& key) {
    const auto p = metrics.find("\n" + key + " ");
    return p == std::string::npos ? NAN : std::stod(metrics.substr(p + key.size() + 2));
  };
  const double count = value(name + "_count"), sum = value(name + "_sum");
  double bound = NAN;
  std::size_t pos = 0;
  const std::string prefix = name + "_bucket{le=\"";
  while ((pos = metrics.find(prefix, pos)) != std::string::npos) {
    const auto end = metrics.find('"', pos + prefix.size());
    const std::string le = metrics.substr(pos + prefix.size(), end - pos - prefix.size());
    const double n = std::stod(metrics.substr(metrics.find(' ', end) + 1));
    if (n >= q * count) {
      bound = le == "+Inf" ? INFINITY : std::stod(le);
      break;
    }
    pos = end;
  }
  return {count > 0 ? sum / count : NAN, bound};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p / 100.0 * v.size()))];
}

Args parse_args(int argc, char** argv) {
  Args a;
  const std::map<std::string, int*> ints = {{"--clients", &a.clients},
                                            {"--frames-clients", &a.frames_clients},
                                            {"--client-threads", &a.client_threads},
                                            {"--broadcast", &a.broadcast.subscribers},
                                            {"--hostile", &a.hostile}};
  const std::map<std::string, double*> reals = {{"--seconds", &a.seconds},
                                                {"--ramp", &a.ramp},
                                                {"--fps", &a.fps},
                                                {"--min-tick", &a.min_tick},
                                                {"--frames-seconds", &a.frames_seconds},
                                                {"--frames-fps", &a.frames_fps},
                                                {"--broadcast-seconds", &a.broadcast.seconds},
                                                {"--broadcast-ramp", &a.broadcast.ramp}};
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) throw std::runtime_error(k + ": missing value");
    const std::string v = argv[++i];
    if (ints.count(k)) {
      *ints.at(k) = std::stoi(v);
    } else if (reals.count(k)) {
      *reals.at(k) = std::stod(v);
    } else if (k == "--frames-size") {
      if (std::sscanf(v.c_str(), "%dx%d", &a.width, &a.height) != 2)
        throw std::runtime_error("--frames-size WxH");
    } else if (k == "--set") {
      const auto eq = v.find('=');
      if (eq == std::string::npos) throw std::runtime_error("--set key=value");
      a.set.emplace_back(v.substr(0, eq), v.substr(eq + 1));
    } else if (k == "--exe") {
      a.exe = v;
    } else {
      throw std::runtime_error("unknown option " + k);
    }
  }
  return a;
}

// One part of the benchmark: `clients` clients speaking for `seconds` each in `output` mode, their
// starts spread over `ramp` seconds.
struct Phase {
  int clients;
  double seconds, ramp, fps;
  std::string output;
};

// Runs the clients of `phase` until all are done.
std::vector<ClientResult> run_clients(const Args& a, unsigned short port, const Phase& phase,
                                      const std::function<void()>& every_second) {
  net::io_context ioc;
  std::vector<std::shared_ptr<Client>> clients;
  const auto t0 = Clock::now() + std::chrono::seconds(2);  // time to connect everyone
  for (int i = 0; i < phase.clients; ++i) {
    const auto start_at = t0 + from_secs(phase.ramp * i / std::max(1, phase.clients));
    clients.push_back(std::make_shared<Client>(
        ioc,
        Client::Config{port, start_at, start_at + from_secs(phase.seconds), phase.fps, phase.output,
                       a.width, a.height, static_cast<std::uint32_t>(i * 7919 + 17)}));
  }
  for (auto& c : clients) c->start();
  net::steady_timer tick(ioc);
  std::function<void()> arm = [&] {
    tick.expires_after(std::chrono::seconds(1));
    tick.async_wait([&](beast::error_code ec) {
      if (ec) return;
      every_second();
      bool all = true;
      for (auto& c : clients) all = all && (c->done || c->failed);
      if (!all) arm();
    });
  };
  arm();
  std::vector<std::thread> threads;
  for (int i = 1; i < a.client_threads; ++i) threads.emplace_back([&] { ioc.run(); });
  ioc.run();
  for (auto& t : threads) t.join();
  std::vector<ClientResult> out;
  for (const auto& c : clients) {
    out.push_back(c->result);
    out.back().failed = c->failed;
  }
  return out;  // the clients (and their sockets) go before the io_context
}

// 1. Weights: on-time frames, time to first frame, the server's RSS and CPU.
void run_weights(const Args& a, const fctest::ServeProcess& server) {
  std::optional<bench::Hostile> hostile;
  if (a.hostile > 0) hostile.emplace(a.hostile, server.port());
  double peak_rss = 0;
  const double cpu0 = cpu(server.pid());
  const double client_cpu0 = self_cpu();
  const auto t0 = Clock::now();
  int second = 0;
  const Phase phase{a.clients, a.seconds, a.ramp, a.fps, "weights"};
  const auto clients = run_clients(a, server.port(), phase, [&] {
    const auto r = rss(server.pid());
    peak_rss = std::max(peak_rss, r.first);
    if (++second % 10 == 0) {
      std::printf("  t=%3d s  server RSS %.0f MB\n", second, r.first);
      std::fflush(stdout);
    }
  });
  const double wall = secs(Clock::now() - t0);
  const double server_cpu = cpu(server.pid()) - cpu0;
  long attacks = 0, ended = 0;
  if (hostile) {
    hostile->stop = true;
    attacks = hostile->attacks, ended = hostile->ended;
    hostile.reset();
  }
  const double client_cpu = self_cpu() - client_cpu0;
  Stats s;
  int failed = 0;
  for (const auto& c : clients) {
    s.merge(c.stats);
    failed += c.failed;
  }
  std::vector<double> late(s.lateness.begin(), s.lateness.end());
  std::printf(
      "\nweights: %d clients, %.1f s wall, %llu streams, %llu frames received, %llu dropped, "
      "%llu errors, %d clients failed\n",
      a.clients, wall, static_cast<unsigned long long>(s.streams),
      static_cast<unsigned long long>(s.frames), static_cast<unsigned long long>(s.dropped),
      static_cast<unsigned long long>(s.errors), failed);
  for (const auto& m : s.error_messages) std::printf("  error: %s\n", m.c_str());
  if (a.hostile > 0)
    std::printf("  beside %d hostile clients: %ld attacks, %ld ended by the server within 10 s\n",
                a.hostile, attacks, ended);
  std::printf(
      "  frames within 50 ms of schedule: %.3f %%  (after their presentation time: %.3f %%)\n",
      100.0 * s.on_time / std::max<std::uint64_t>(1, s.frames),
      100.0 * s.late_presentation / std::max<std::uint64_t>(1, s.frames));
  std::printf("  lateness vs schedule: p50 %.1f ms, p99 %.1f ms, p99.9 %.1f ms, max %.1f ms\n",
              1e3 * percentile(late, 50), 1e3 * percentile(late, 99), 1e3 * percentile(late, 99.9),
              1e3 * percentile(late, 100));
  std::printf(
      "  time to first frame after speak (no audio): p50 %.1f ms, p99 %.1f ms, max %.1f ms "
      "(n=%zu)\n",
      1e3 * percentile(s.ttff, 50), 1e3 * percentile(s.ttff, 99), 1e3 * percentile(s.ttff, 100),
      s.ttff.size());
  std::printf(
      "  server RSS: peak %.0f MB sampled, VmHWM %.0f MB; server CPU %.1f s (%.0f %% of one "
      "core); load generator CPU %.0f %% of one core\n",
      peak_rss, rss(server.pid()).second, server_cpu, 100.0 * server_cpu / wall,
      100.0 * client_cpu / wall);
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) == 3)
    std::printf("  machine load average (1 min) at the end: %.2f\n", load[0]);
  const std::string m = bench::http_get(server.port(), "/metrics");
  const auto ttff = histogram(m, "facecast_time_to_first_frame_seconds", 0.99);
  const auto analysis = histogram(m, "facecast_analysis_duration_seconds", 0.99);
  std::printf(
      "  server side: time to first frame mean %.1f ms, p99 <= %.0f ms; analysis mean %.1f ms, "
      "p99 <= %.0f ms\n",
      1e3 * ttff.first, 1e3 * ttff.second, 1e3 * analysis.first, 1e3 * analysis.second);
  std::fflush(stdout);
}

// 2. Frames: JPEG frames delivered per second to each client.
void run_frames(const Args& a, const fctest::ServeProcess& server) {
  const Phase phase{a.frames_clients, a.frames_seconds, 0, a.frames_fps, "frames"};
  const auto clients = run_clients(a, server.port(), phase, [] {});
  std::printf("\nframes: %d clients at %dx%d, %.0f fps requested, %.0f s\n", a.frames_clients,
              a.width, a.height, a.frames_fps, a.frames_seconds);
  for (std::size_t i = 0; i < clients.size(); ++i) {
    const auto& c = clients[i];
    const double span = secs(c.last_frame_at - c.first_stream_at);
    std::printf(
        "  client %zu: %llu frames in %.1f s = %.1f fps delivered, %llu dropped, %.1f "
        "KB/frame, %llu errors\n",
        i, static_cast<unsigned long long>(c.jpeg_frames), span,
        c.jpeg_frames / std::max(1e-9, span), static_cast<unsigned long long>(c.stats.dropped),
        c.jpeg_bytes / 1024.0 / std::max<std::uint64_t>(1, c.jpeg_frames),
        static_cast<unsigned long long>(c.stats.errors));
    for (const auto& m : c.stats.error_messages) std::printf("    error: %s\n", m.c_str());
  }
  const auto render = histogram(bench::http_get(server.port(), "/metrics"),
                                "facecast_render_duration_seconds", 0.5);
  std::printf("  render + JPEG per frame on the server: mean %.1f ms (median <= %.0f ms)\n",
              1e3 * render.first, 1e3 * render.second);
}

// The shipped config with room for the load and the --set values, written to `dir`.
void write_config(Args& a, const std::filesystem::path& dir) {
  json config = facecast::load_json(facecast::config_path("server.json"));
  config["max_connections"] =
      std::max(config["max_connections"].get<int>(),
               std::max(a.clients, a.broadcast.subscribers) + 100 + 300 * a.hostile);
  // The normal clients all come from 127.0.0.1; the hostile ones each from an address of its own.
  config["max_connections_per_address"] =
      std::max(config["max_connections_per_address"].get<int>(),
               std::max(a.clients, a.broadcast.subscribers) + 100);
  config["channels"] = {{a.broadcast.channel, {{"producer_token", a.broadcast.token}}}};
  config["log_level"] = "warn";
  if (a.min_tick >= 0) config["min_tick"] = a.min_tick;
  for (const auto& [key, value] : a.set) config[key] = json::parse(value);
  a.min_tick = config["min_tick"];
  facecast::write_file_atomic(dir / "server.json", config.dump(2));
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse_args(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_server: %s\n", e.what());
    return 2;
  }
  rlimit rl{};
  getrlimit(RLIMIT_NOFILE, &rl);
  rl.rlim_cur = rl.rlim_max;
  setrlimit(RLIMIT_NOFILE, &rl);

  const auto dir =
      std::filesystem::temp_directory_path() / ("bench-server-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  write_config(a, dir);
  std::printf(
      "bench_server: %d clients x %.0f s of %.0f fps weights (ramp %.0f s, min_tick %g), "
      "then %d clients in frames mode at %dx%d %.0f fps for %.0f s; %u CPUs\n",
      a.clients, a.seconds, a.fps, a.ramp, a.min_tick, a.frames_clients, a.width, a.height,
      a.frames_fps, a.frames_seconds, std::thread::hardware_concurrency());
  std::fflush(stdout);
  int rc = 0;
  try {
    const fctest::ServeProcess server(
        a.exe, {"--config", (dir / "server.json").string(), "--data", (dir / "data").string()}, 60,
        (dir / "server.log").string());
    std::printf("server pid %d on port %u, RSS at start %.0f MB\n", server.pid(), server.port(),
                rss(server.pid()).first);
    if (a.clients > 0) run_weights(a, server);
    if (a.frames_clients > 0) run_frames(a, server);
    a.broadcast.client_threads = a.client_threads;
    if (a.broadcast.subscribers > 0) bench::run_broadcast(a.broadcast, server.port(), server.pid());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_server: %s\n", e.what());
    rc = 3;
  }
  std::error_code ec;
  if (const char* keep = std::getenv("BENCH_SERVER_LOG"))  // keep the server's log there
    std::filesystem::copy_file(dir / "server.log", keep,
                               std::filesystem::copy_options::overwrite_existing, ec);
  std::filesystem::remove_all(dir, ec);
  return rc;
}
