// The broadcast case of bench_server: one channel, N subscribers (default 10,000) on one server,
// a producer speaking utterance after utterance (60 fps weights, 2 frames a message, with audio).
// Every subscriber measures each frame against its schedule: the arrival of its stream_start +
// pts - lead (frames sent earlier than lead count as on time).
#include "bench_broadcast.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_broadcast_raw.hpp"
#include "facecast/server/protocol.hpp"
#include "ws_client.hpp"

namespace bench {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

double secs(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

double rss_mb(pid_t pid, const char* key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key, 0) == 0) return std::stod(line.substr(std::string(key).size())) / 1024.0;
  return 0;
}

double cpu_s(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(in)), {});
  std::istringstream f(s.substr(s.rfind(')') + 2));
  std::string x;
  double ut = 0, st = 0;
  for (int i = 3; i <= 15; ++i) {
    f >> x;
    if (i == 14) ut = std::stod(x);
    if (i == 15) st = std::stod(x);
  }
  return (ut + st) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

const char* kLines[] = {
    "Good evening and welcome to the live show, it is great to have you all here tonight.",
    "大家好，欢迎来到今天的直播，我们马上开始。",
    "Today we look at how a face can follow speech in real time for thousands of viewers.",
    "Thank you for watching, and remember to share the stream with your friends.",
};

// The producer: a subscriber of the channel (it measures its own frames as the others do) that
// speaks the next utterance after each stream_end until stop_at.
class Producer : public fctest::AsyncWsClient {
 public:
  Producer(net::io_context& ioc, const BroadcastArgs& a, unsigned short port)
      : AsyncWsClient(ioc, {.port = port}), a_(a) {}
  void speak_now(Clock::time_point stop_at) {
    net::post(executor(), [this, self = shared_from_this(), stop_at] {
      stop_at_ = stop_at;
      speak();
    });
  }
  std::atomic<bool> subscribed{false}, failed{false};
  std::uint64_t frames = 0, on_time = 0, streams = 0;
  std::vector<float> lateness;
  std::string error;
  std::atomic<bool> finished{false};

 private:
  void on_open() override {
    send(json{{"type", "subscribe"}, {"channel", a_.channel}}.dump());
    send(json{{"type", "produce"}, {"channel", a_.channel}, {"token", a_.token}}.dump());
  }
  void speak() {
    if (Clock::now() >= stop_at_) {
      finished = true;
      return;
    }
    send(json{{"type", "speak"},
              {"id", "b" + std::to_string(++n_)},
              {"channel", a_.channel},
              {"fps", a_.fps},
              {"audio", true},
              {"text", kLines[n_ % 4]}}
             .dump());
  }
  void on_message(const Message& m) override {
    if (m.text) {
      // The type without parsing: a stream_start carries the whole utterance timeline, and 10,000
      // parses of it would make the load generator, not the server, late.
      const auto at = m.data.find("\"type\":\"");
      const std::string_view type = at == std::string_view::npos
                                        ? ""
                                        : m.data.substr(at + 8, m.data.find('"', at + 8) - at - 8);
      if (type == "subscribed") subscribed = true;
      if (type == "stream_start") start_ = m.at;  // lead: the server's default, 0.1 s
      if (type == "stream_end") {
        ++streams;
        // The next utterance once the run started; idle-life streams (between utterances, and
        // while the subscribers connect) are not the producer's.
        if (stop_at_ != Clock::time_point{} &&
            m.data.find(R"("id":"~idle")") == std::string_view::npos)
          speak();
      }
      if (type == "error" && error.empty()) error = std::string(m.data);
      return;
    }
    const auto h = facecast::server::read_header(m.data);
    if (h.kind != facecast::server::MediaKind::kWeights) return;
    for (std::uint32_t k = 0; k < h.count; ++k) {
      const double late = secs(m.at - start_) - std::max(0.0, h.pts + k / a_.fps - lead_);
      ++frames;
      on_time += late <= 0.050;
      if ((frames & 15) == 0) lateness.push_back(static_cast<float>(late));  // 1 in 16 kept
    }
  }
  void on_error(const std::string& what) override {
    if (!failed.exchange(true)) error = what;
  }

  const BroadcastArgs& a_;
  Clock::time_point start_, stop_at_;
  double lead_ = 0.1;
  int n_ = 0;
};

double percentile(std::vector<float> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p / 100.0 * (v.size() - 1))];
}

}  // namespace

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

namespace {

// The value of Prometheus sample `name` (with its labels, if any), NaN when absent.
double metric(const std::string& metrics, const std::string& name) {
  const auto p = metrics.find("\n" + name + " ");
  return p == std::string::npos ? NAN : std::stod(metrics.substr(p + name.size() + 2));
}

double self_cpu_s() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec +
         1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

double load1() {
  double load[3] = {0, 0, 0};
  return getloadavg(load, 3) < 0 ? -1 : load[0];
}

void print_counts(const char* what, const RawSubscribers::Counts& c) {
  std::printf(
      "  %s: %llu frames, %.3f %% within 50 ms of schedule, %llu streams seen, %llu "
      "frames missing (dropped by the server)\n",
      what, static_cast<unsigned long long>(c.frames),
      100.0 * c.on_time / std::max<std::uint64_t>(1, c.frames),
      static_cast<unsigned long long>(c.streams), static_cast<unsigned long long>(c.gaps));
  std::printf("    lateness: p50 %.1f ms, p99 %.1f ms, p99.9 %.1f ms, max %.1f ms\n",
              1e3 * percentile(c.lateness, 50), 1e3 * percentile(c.lateness, 99),
              1e3 * percentile(c.lateness, 99.9), 1e3 * percentile(c.lateness, 100));
}

}  // namespace

void run_broadcast(const BroadcastArgs& a, unsigned short port, pid_t pid) {
  const double lead = 0.1;  // the server's default
  // The subscribers' reader threads run from the first connection on (bench_broadcast_raw.hpp).
  RawSubscribers subs(port, a.channel, std::max(1, a.client_threads), a.fps, lead);
  net::io_context ioc;
  auto producer = std::make_shared<Producer>(ioc, a, port);
  auto work = net::make_work_guard(ioc);
  std::thread producer_thread([&] { ioc.run(); });
  net::post(ioc, [producer] { producer->start(); });
  const auto t_connect = Clock::now();
  double peak = 0;
  const auto sample_rss = [&] { peak = std::max(peak, rss_mb(pid, "VmRSS:")); };
  subs.connect(a.subscribers - 1, a.ramp);
  // The last handshakes and subscribe answers: until all are in, or 10 s without progress (a
  // starved server accepts slowly; a connection whose SYN was dropped retries after 1, 3, 7 s).
  for (auto [done, since] = std::pair{-1, Clock::now()};
       subs.subscribed() + subs.failed() < a.subscribers - 1 &&
       Clock::now() - since < std::chrono::seconds(10);) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    sample_rss();
    if (const int now = subs.subscribed() + subs.failed(); now != done) {
      done = now;
      since = Clock::now();
    }
  }
  while (!producer->subscribed && !producer->failed)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  sample_rss();
  std::printf(
      "\nbroadcast: %d of %d subscribed in %.1f s (%d failed to connect), server RSS "
      "%.0f MB\n",
      subs.subscribed() + (producer->subscribed ? 1 : 0), a.subscribers,
      secs(Clock::now() - t_connect), subs.failed(), rss_mb(pid, "VmRSS:"));
  std::fflush(stdout);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double load_before = load1();
  const double cpu0 = cpu_s(pid), self0 = self_cpu_s();
  const auto t0 = Clock::now();
  subs.begin_show();
  producer->speak_now(
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(a.seconds)));
  while (!producer->finished && !producer->failed) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    sample_rss();
  }
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the last frames
  subs.end_show();
  const double wall = secs(Clock::now() - t0);
  const double cpu = cpu_s(pid) - cpu0, self = self_cpu_s() - self0;
  const double load_after = load1();
  RawSubscribers::Totals t = subs.stop();
  work.reset();
  ioc.stop();
  producer_thread.join();
  t.show.frames += producer->frames;
  t.show.on_time += producer->on_time;
  t.show.streams += producer->streams;
  t.show.lateness.insert(t.show.lateness.end(), producer->lateness.begin(),
                         producer->lateness.end());
  const std::string m = http_get(port, "/metrics");
  std::printf("  %d subscribers x %.0f s of %.0f fps weights + audio (%d client threads)%s%s\n",
              a.subscribers, wall, a.fps, std::max(1, a.client_threads),
              producer->error.empty() ? "" : "; producer: ", producer->error.c_str());
  print_counts("while connecting (idle life)", t.ramp);
  print_counts("show", t.show);
  std::printf(
      "  subscribers: %d connected, %d failed to connect, %d closed by the server (%d as "
      "slow clients, 1008); server counters: %.0f slow clients closed, %.0f frames "
      "dropped\n",
      t.connected + 1, t.failed, t.closed, t.closed_slow,
      metric(m, "facecast_slow_clients_closed_total"),
      metric(m, "facecast_frames_dropped_total{output=\"weights\"}"));
  std::printf(
      "  server: RSS peak %.0f MB (VmHWM %.0f MB), CPU %.1f s = %.0f %% of one core, "
      "%.2f us per frame delivered\n",
      peak, rss_mb(pid, "VmHWM:"), cpu, 100.0 * cpu / wall,
      1e6 * cpu / std::max<std::uint64_t>(1, t.show.frames));
  std::printf("  load generator CPU %.0f %% of one core; load average %.1f before, %.1f after\n",
              100.0 * self / wall, load_before, load_after);
  std::fflush(stdout);
}

}  // namespace bench
