// Load benchmark of `facecast serve` (started as a child process on a free port), with the load
// generator in this process on the same machine:
//  1. weights: N WebSocket clients (default 1000), each speaking utterance after utterance (no
//     audio, 60 fps weights) for S seconds (default 60), starts spread over --ramp seconds.
//     Reports the share of frames that arrive within 50 ms of their schedule (stream_start arrival
//     + pts - lead), the server's RSS (peak), its CPU, and the time from speak to the first frame
//     (p50/p99, measured at the client).
//  2. frames: 2 clients at once in frames mode at 640x480 (JPEG) for --frames-seconds: delivered
//     frames per second each.
// Usage: bench_server [--clients 1000] [--seconds 60] [--ramp 5] [--fps 60] [--min-tick (config)]
//                     [--frames-clients 2] [--frames-seconds 15] [--frames-fps 30]
//                     [--frames-size 640x480] [--client-threads 1] [--exe path/to/facecast]
//                     [--set key=json ...] (server config values, e.g. --set frames_in_flight=3)
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <random>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/server/protocol.hpp"

namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

double secs(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

struct Args {
  int clients = 1000;
  double seconds = 60, ramp = 5, fps = 60, min_tick = -1;  // -1: the config's
  int frames_clients = 2;
  double frames_seconds = 15, frames_fps = 30;
  int width = 640, height = 480;
  int client_threads = 1;
  std::string exe = FACECAST_EXE;
  std::vector<std::pair<std::string, std::string>> set;  // --set key=json (server config)
};

// ---- the server process -------------------------------------------------------------------------

struct ServerProcess {
  pid_t pid = -1;
  unsigned short port = 0;

  ServerProcess(const std::string& exe, const std::filesystem::path& config,
                const std::filesystem::path& data) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe");
    const std::string log = (config.parent_path() / "server.log").string();
    std::vector<std::string> args = {exe,      "serve", "--config", config,
                                     "--port", "0",     "--data",   data.string()};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    // fork + exec (this process has one thread here): the server dies with the benchmark.
    pid = fork();
    if (pid < 0) throw std::runtime_error("fork");
    if (pid == 0) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      dup2(out[1], 1);
      const int err = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (err >= 0) dup2(err, 2);
      close(out[0]);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    close(out[1]);
    std::string line;
    const auto t0 = Clock::now();
    while (line.find('\n') == std::string::npos && secs(Clock::now() - t0) < 60) {
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
    if (!std::regex_search(line, m, std::regex(R"(listening on http://[0-9.]+:([0-9]+))")))
      throw std::runtime_error("server did not start: " + line);
    port = static_cast<unsigned short>(std::stoi(m[1]));
  }
  ~ServerProcess() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      int status = 0;
      waitpid(pid, &status, 0);
    }
  }
  // Resident set size and its peak, MB.
  std::pair<double, double> rss() const {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    double rss = 0, hwm = 0;
    while (std::getline(in, line)) {
      if (line.starts_with("VmRSS:")) rss = std::stod(line.substr(6)) / 1024.0;
      if (line.starts_with("VmHWM:")) hwm = std::stod(line.substr(6)) / 1024.0;
    }
    return {rss, hwm};
  }
  // user + system CPU seconds
  double cpu() const {
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
};

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
    frames += o.frames;
    on_time += o.on_time;
    late_presentation += o.late_presentation;
    dropped += o.dropped;
    streams += o.streams;
    errors += o.errors;
    ttff.insert(ttff.end(), o.ttff.begin(), o.ttff.end());
    lateness.insert(lateness.end(), o.lateness.begin(), o.lateness.end());
    if (error_messages.size() < 5)
      error_messages.insert(error_messages.end(), o.error_messages.begin(), o.error_messages.end());
  }
};

struct ClientResult {
  Stats stats;
  bool failed = false;
  std::uint64_t jpeg_frames = 0, jpeg_bytes = 0;
  Clock::time_point first_stream_at{}, last_frame_at{};
};

class Client : public std::enable_shared_from_this<Client> {
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
      : ws_(net::make_strand(ioc)), timer_(ws_.get_executor()), c_(std::move(c)), rng_(c_.seed) {}

  void start() {
    beast::get_lowest_layer(ws_).async_connect(
        tcp::endpoint(net::ip::make_address("127.0.0.1"), c_.port),
        [self = shared_from_this()](beast::error_code ec) { self->on_connect(ec); });
  }
  Stats stats;
  std::atomic<bool> done{false}, failed{false};
  std::uint64_t jpeg_frames = 0, jpeg_bytes = 0;
  Clock::time_point first_stream_at{}, last_frame_at{};

 private:
  void on_connect(beast::error_code ec) {
    if (ec) return fail("connect: " + ec.message());
    ws_.set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
      req.set(beast::http::field::sec_websocket_protocol, "facecast.v1");
    }));
    ws_.read_message_max(16u << 20);
    ws_.async_handshake(
        "127.0.0.1:" + std::to_string(c_.port), "/ws",
        [self = shared_from_this()](beast::error_code e) { self->on_handshake(e); });
  }
  void on_handshake(beast::error_code ec) {
    if (ec) return fail("handshake: " + ec.message());
    read();
    timer_.expires_at(c_.start_at);
    timer_.async_wait([self = shared_from_this()](beast::error_code e) {
      if (!e) self->speak();
    });
  }
  void speak() {
    if (Clock::now() >= c_.stop_at) {
      done = true;
      ws_.async_close(websocket::close_code::normal,
                      [self = shared_from_this()](beast::error_code) {});
      return;
    }
    ++n_;
    const std::string id = "u" + std::to_string(n_);
    json j = {{"type", "speak"}, {"id", id},      {"text", kSentences[rng_() % kSentences.size()]},
              {"audio", false},  {"fps", c_.fps}, {"output", c_.output}};
    if (c_.output == "frames") j["size"] = {c_.width, c_.height};
    out_ = j.dump();
    sent_at_ = Clock::now();
    got_first_ = false;
    ws_.text(true);
    ws_.async_write(net::buffer(out_),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) {
                      if (ec) self->fail("write: " + ec.message());
                    });
  }
  void read() {
    ws_.async_read(buf_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->on_read(ec);
    });
  }
  void on_read(beast::error_code ec) {
    const auto now = Clock::now();
    if (ec) {
      if (!done) fail("read: " + ec.message());
      return;
    }
    const auto data = buf_.data();
    const std::string_view msg(static_cast<const char*>(data.data()), data.size());
    if (ws_.got_text()) {
      on_text(json::parse(msg), now);
    } else if (msg.size() >= facecast::server::kHeaderSize) {
      const auto h = facecast::server::read_header(msg);
      if (!got_first_) {
        got_first_ = true;
        stats.ttff.push_back(secs(now - sent_at_));
      }
      if (h.kind == facecast::server::MediaKind::kJpeg) {
        ++jpeg_frames;
        jpeg_bytes += msg.size();
        last_frame_at = now;
      }
      for (std::uint32_t k = 0; k < h.count && h.kind != facecast::server::MediaKind::kAudio; ++k) {
        const double pts = h.pts + k / fps_;
        // The schedule: sent at stream start + pts - lead, but not before the stream starts.
        const double late = secs(now - stream_start_) - std::max(0.0, pts - lead_);
        ++stats.frames;
        stats.on_time += late <= 0.050;
        stats.late_presentation += late > lead_;
        stats.lateness.push_back(static_cast<float>(late));
      }
    }
    buf_.consume(buf_.size());
    read();
  }
  void on_text(const json& j, Clock::time_point now) {
    const std::string type = j.value("type", "");
    if (type == "stream_start") {
      stream_start_ = now;
      if (first_stream_at.time_since_epoch().count() == 0) first_stream_at = now;
      fps_ = j["fps"];
      lead_ = j.value("lead", 0.1);
    } else if (type == "stream_end") {
      ++stats.streams;
      stats.dropped += j["dropped"].get<std::uint64_t>();
      speak();
    } else if (type == "error") {
      ++stats.errors;
      if (stats.error_messages.size() < 3) stats.error_messages.push_back(j.dump());
      speak();
    }
  }
  void fail(const std::string& why) {
    if (!failed) stats.error_messages.push_back(why);
    failed = true;
    ++stats.errors;
  }

  websocket::stream<beast::tcp_stream> ws_;
  net::steady_timer timer_;
  Config c_;
  std::mt19937 rng_;
  beast::flat_buffer buf_;
  std::string out_;
  int n_ = 0;
  Clock::time_point sent_at_, stream_start_;
  bool got_first_ = false;
  double fps_ = 60, lead_ = 0.1;
};

std::string http_get(unsigned short port, const std::string& target) {
  net::io_context ioc;
  beast::tcp_stream stream(ioc);
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  beast::http::request<beast::http::empty_body> req{beast::http::verb::get, target, 11};
  req.set(beast::http::field::host, "127.0.0.1");
  beast::http::write(stream, req);
  beast::flat_buffer buf;
  beast::http::response<beast::http::string_body> res;
  beast::http::read(stream, buf, res);
  return res.body();
}

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
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(k + ": missing value");
      return argv[++i];
    };
    if (k == "--clients")
      a.clients = std::stoi(next());
    else if (k == "--seconds")
      a.seconds = std::stod(next());
    else if (k == "--ramp")
      a.ramp = std::stod(next());
    else if (k == "--fps")
      a.fps = std::stod(next());
    else if (k == "--min-tick")
      a.min_tick = std::stod(next());
    else if (k == "--frames-clients")
      a.frames_clients = std::stoi(next());
    else if (k == "--frames-seconds")
      a.frames_seconds = std::stod(next());
    else if (k == "--frames-fps")
      a.frames_fps = std::stod(next());
    else if (k == "--frames-size") {
      const std::string s = next();
      if (std::sscanf(s.c_str(), "%dx%d", &a.width, &a.height) != 2)
        throw std::runtime_error("--frames-size WxH");
    } else if (k == "--client-threads")
      a.client_threads = std::stoi(next());
    else if (k == "--set") {
      const std::string kv = next();
      const auto eq = kv.find('=');
      if (eq == std::string::npos) throw std::runtime_error("--set key=value");
      a.set.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    } else if (k == "--exe")
      a.exe = next();
    else
      throw std::runtime_error("unknown option " + k);
  }
  return a;
}

// Runs `clients` clients until all are done; returns merged stats.
std::vector<ClientResult> run_clients(const Args& a, unsigned short port, int n, double seconds,
                                      double ramp, double fps, const std::string& output,
                                      const std::function<void()>& every_second) {
  net::io_context ioc;
  std::vector<std::shared_ptr<Client>> clients;
  const auto t0 = Clock::now() + std::chrono::seconds(2);  // time to connect everyone
  for (int i = 0; i < n; ++i) {
    Client::Config c;
    c.port = port;
    c.start_at = t0 + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(ramp * i / std::max(1, n)));
    c.stop_at = c.start_at +
                std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    c.fps = fps;
    c.output = output;
    c.width = a.width;
    c.height = a.height;
    c.seed = static_cast<std::uint32_t>(i * 7919 + 17);
    clients.push_back(std::make_shared<Client>(ioc, c));
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
  for (const auto& c : clients)
    out.push_back(
        {c->stats, c->failed, c->jpeg_frames, c->jpeg_bytes, c->first_stream_at, c->last_frame_at});
  return out;  // the clients (and their sockets) go before the io_context
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

  // The shipped config, with room for the load.
  const auto dir =
      std::filesystem::temp_directory_path() / ("bench-server-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  json config = facecast::load_json(facecast::config_path("server.json"));
  config["max_connections"] = std::max(config["max_connections"].get<int>(), a.clients + 100);
  config["log_level"] = "warn";
  if (a.min_tick >= 0) config["min_tick"] = a.min_tick;
  for (const auto& [key, value] : a.set) config[key] = json::parse(value);
  a.min_tick = config["min_tick"];
  facecast::write_file_atomic(dir / "server.json", config.dump(2));

  std::printf(
      "bench_server: %d clients x %.0f s of %.0f fps weights (ramp %.0f s, min_tick %g), "
      "then %d clients in frames mode at %dx%d %.0f fps for %.0f s; %u CPUs\n",
      a.clients, a.seconds, a.fps, a.ramp, a.min_tick, a.frames_clients, a.width, a.height,
      a.frames_fps, a.frames_seconds, std::thread::hardware_concurrency());
  std::fflush(stdout);
  int rc = 0;
  try {
    ServerProcess server(a.exe, dir / "server.json", dir / "data");
    const auto rss0 = server.rss();
    std::printf("server pid %d on port %u, RSS at start %.0f MB\n", server.pid, server.port,
                rss0.first);

    // ---- 1. weights -----------------------------------------------------------------------------
    double peak_rss = 0;
    const double cpu0 = server.cpu();
    const auto self_cpu = [] {
      rusage ru{};
      getrusage(RUSAGE_SELF, &ru);
      return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec +
             1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    };
    const double client_cpu0 = self_cpu();
    const auto t0 = Clock::now();
    int second = 0;
    auto clients = run_clients(a, server.port, a.clients, a.seconds, a.ramp, a.fps, "weights", [&] {
      const auto r = server.rss();
      peak_rss = std::max(peak_rss, r.first);
      if (++second % 10 == 0) {
        std::printf("  t=%3d s  server RSS %.0f MB\n", second, r.first);
        std::fflush(stdout);
      }
    });
    const double wall = secs(Clock::now() - t0);
    const double cpu = server.cpu() - cpu0;
    const double client_cpu = self_cpu() - client_cpu0;
    Stats s;
    int failed = 0;
    for (auto& c : clients) {
      s.merge(c.stats);
      failed += c.failed;
    }
    std::vector<double> late(s.lateness.begin(), s.lateness.end());
    const auto hwm = server.rss().second;
    std::printf(
        "\nweights: %d clients, %.1f s wall, %llu streams, %llu frames received, %llu dropped, "
        "%llu errors, %d clients failed\n",
        a.clients, wall, static_cast<unsigned long long>(s.streams),
        static_cast<unsigned long long>(s.frames), static_cast<unsigned long long>(s.dropped),
        static_cast<unsigned long long>(s.errors), failed);
    for (const auto& m : s.error_messages) std::printf("  error: %s\n", m.c_str());
    std::printf(
        "  frames within 50 ms of schedule: %.3f %%  (after their presentation time: %.3f %%)\n",
        100.0 * s.on_time / std::max<std::uint64_t>(1, s.frames),
        100.0 * s.late_presentation / std::max<std::uint64_t>(1, s.frames));
    std::printf("  lateness vs schedule: p50 %.1f ms, p99 %.1f ms, p99.9 %.1f ms, max %.1f ms\n",
                1e3 * percentile(late, 50), 1e3 * percentile(late, 99),
                1e3 * percentile(late, 99.9), 1e3 * percentile(late, 100));
    std::printf(
        "  time to first frame after speak (no audio): p50 %.1f ms, p99 %.1f ms, max %.1f ms "
        "(n=%zu)\n",
        1e3 * percentile(s.ttff, 50), 1e3 * percentile(s.ttff, 99), 1e3 * percentile(s.ttff, 100),
        s.ttff.size());
    std::printf(
        "  server RSS: peak %.0f MB sampled, VmHWM %.0f MB; server CPU %.1f s (%.0f %% of one "
        "core); load generator CPU %.0f %% of one core\n",
        peak_rss, hwm, cpu, 100.0 * cpu / wall, 100.0 * client_cpu / wall);
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) == 3)
      std::printf("  machine load average (1 min) at the end: %.2f\n", load[0]);
    {
      const std::string m = http_get(server.port, "/metrics");
      const auto ttff = histogram(m, "facecast_time_to_first_frame_seconds", 0.99);
      const auto analysis = histogram(m, "facecast_analysis_seconds", 0.99);
      std::printf(
          "  server side: time to first frame mean %.1f ms, p99 <= %.0f ms; analysis mean %.1f ms, "
          "p99 <= %.0f ms\n",
          1e3 * ttff.first, 1e3 * ttff.second, 1e3 * analysis.first, 1e3 * analysis.second);
    }
    std::fflush(stdout);

    // ---- 2. frames ------------------------------------------------------------------------------
    if (a.frames_clients > 0) {
      auto fc = run_clients(a, server.port, a.frames_clients, a.frames_seconds, 0, a.frames_fps,
                            "frames", [] {});
      std::printf("\nframes: %d clients at %dx%d, %.0f fps requested, %.0f s\n", a.frames_clients,
                  a.width, a.height, a.frames_fps, a.frames_seconds);
      for (std::size_t i = 0; i < fc.size(); ++i) {
        const auto& c = fc[i];
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
      const auto render =
          histogram(http_get(server.port, "/metrics"), "facecast_render_seconds", 0.5);
      std::printf("  render + JPEG per frame on the server: mean %.1f ms (median <= %.0f ms)\n",
                  1e3 * render.first, 1e3 * render.second);
    }
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
