// Live audio-only lip-sync through `facecast serve` (docs/protocol.md, "Live audio in"): N clients
// (default 50) each stream espeak-ng speech as 20 ms PCM16 chunks in real time over the WebSocket
// and read the weights back. With --aligned the streams are aligned to their text (flag 2, the
// text of each repetition of the speech sent in an audio_text message as it starts, as a streaming
// TTS sends it; English speech; with --text-ahead one repetition ahead, as a client that knows what
// it asked the TTS to say can send it), otherwise the analysis is from the audio alone. Latency of
// a frame = its arrival - the sending of the chunk that holds the audio of its time (pts): the
// end-to-end delay from an audio chunk to its weights. Prints the p50 / p99 / max over all frames,
// the server's CPU time per chunk and the machine's load average (the figure means little on a busy
// machine). Usage: bench_live_audio [clients] [seconds] [--aligned | --text-ahead]
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>

#include "build_paths.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/audio.hpp"
#include "serve_process.hpp"
#include "ws_client.hpp"

namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
using Clock = std::chrono::steady_clock;
constexpr int kRate = 16000, kChunk = 320;  // 20 ms

struct Shared {
  std::vector<std::int16_t> pcm;  // the speech every client loops
  std::string text;               // its text (aligned streams)
  bool text_ahead = false;        // each repetition's text sent as the one before starts
  std::mutex mutex;
  std::vector<double> latency;
  std::atomic<int> errors{0}, ended{0};
};

// One client: streams `chunks` chunks of the speech from `offset` on, one every 20 ms (the next
// once the previous is written), and closes at stream_end.
class Client : public fctest::AsyncWsClient {
 public:
  Client(net::io_context& ioc, unsigned short port, Shared& s, std::size_t offset, int chunks,
         std::chrono::milliseconds start_delay)
      // A live audio client sends small messages: no Nagle delay (browsers do the same).
      : AsyncWsClient(ioc, {.port = port, .no_delay = true}),
        timer_(executor()),
        s_(s),
        offset_(offset),
        chunks_(chunks),
        start_delay_(start_delay) {}

 private:
  void on_open() override {
    next_ = Clock::now() + start_delay_;
    send_chunk();
  }
  void on_sent() override {
    writing_ = false;
    send_chunk();
  }
  void send_chunk() {
    if (sent_ == chunks_ || writing_) return;
    const auto now = Clock::now();
    if (now < next_) {
      timer_.expires_at(next_);
      timer_.async_wait([this, self = shared_from_this()](beast::error_code ec) {
        if (!ec) send_chunk();
      });
      return;
    }
    const bool last = sent_ + 1 == chunks_;
    std::string out(24 + 2 * kChunk, '\0');
    out[0] = 4, out[1] = 1, out[2] = static_cast<char>((last ? 1 : 0) | (aligned() ? 2 : 0));
    const auto put = [&](std::size_t at, std::uint32_t v) {
      for (int k = 0; k < 4; ++k)
        out[at + static_cast<std::size_t>(k)] = static_cast<char>(v >> (8 * k));
    };
    put(4, kRate);
    put(8, static_cast<std::uint32_t>(sent_ * kChunk));
    put(12, kChunk);
    for (int i = 0; i < kChunk; ++i) {
      const auto v = static_cast<std::uint16_t>(
          s_.pcm[(offset_ + static_cast<std::size_t>(sent_ * kChunk + i)) % s_.pcm.size()]);
      out[24 + 2 * static_cast<std::size_t>(i)] = static_cast<char>(v & 0xff);
      out[25 + 2 * static_cast<std::size_t>(i)] = static_cast<char>(v >> 8);
    }
    sent_at_.push_back(now);
    ++sent_;
    next_ += std::chrono::milliseconds(20);
    writing_ = true;
    const std::size_t at =
        (offset_ + static_cast<std::size_t>((sent_ - 1) * kChunk)) % s_.pcm.size();
    send(std::move(out), false);
    // Aligned: each repetition's text as its audio starts (after the chunk that opens the stream),
    // or as the one before it starts.
    if (!s_.text.empty() && at < static_cast<std::size_t>(kChunk))
      for (int k = 0; k < (s_.text_ahead && sent_ == 1 ? 2 : 1); ++k)
        send(nlohmann::json{{"type", "audio_text"}, {"text", s_.text + " "}}.dump());
  }
  bool aligned() const { return !s_.text.empty() && sent_ == 0; }
  void on_message(const Message& m) override {
    if (m.text) {
      if (m.data.find("\"stream_end\"") != std::string_view::npos) {
        ++s_.ended;
        close();
      } else if (m.data.find("\"error\"") != std::string_view::npos) {
        on_error(std::string(m.data));
      }
      return;
    }
    const auto h = facecast::server::read_header(m.data);
    std::lock_guard lock(s_.mutex);
    for (std::uint32_t k = 0; k < h.count; ++k) {
      const double pts = h.pts + k / 60.0;
      const auto chunk = static_cast<std::size_t>(pts * kRate / kChunk);
      if (chunk < sent_at_.size())
        s_.latency.push_back(std::chrono::duration<double>(m.at - sent_at_[chunk]).count());
    }
  }
  void on_error(const std::string& what) override {
    if (s_.errors++ < 3) std::fprintf(stderr, "client: %s\n", what.c_str());
  }

  net::steady_timer timer_;
  Shared& s_;
  std::size_t offset_;
  int chunks_, sent_ = 0;
  std::chrono::milliseconds start_delay_;
  bool writing_ = false;
  Clock::time_point next_;
  std::vector<Clock::time_point> sent_at_;  // written and read on the client's strand
};

// CPU seconds (user + system) a process has used so far, from /proc/<pid>/stat.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream fields(stat.substr(stat.rfind(')') + 2));
  std::string f;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i)
    if (i >= 14) ticks += std::stod(f);  // fields 14 utime, 15 stime
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  const bool text_ahead = std::erase(args, "--text-ahead") > 0;
  const bool aligned = std::erase(args, "--aligned") > 0 || text_ahead;
  const int clients = args.size() > 0 ? std::atoi(args[0].c_str()) : 50;
  const double seconds = args.size() > 1 ? std::atof(args[1].c_str()) : 20;
  Shared s;
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const std::string text =
      aligned ? "Hello everyone, thanks for joining the stream today. We will look at the new "
                "features together."
              : "Hello everyone, thanks for joining the stream today. 今天我们聊一聊新的功能。";
  if (aligned) s.text = text;
  s.text_ahead = text_ahead;
  const auto u = facecast::viseme::analyze(text, o);
  s.pcm = facecast::viseme::to_pcm16(
      facecast::viseme::audio_from_pcm16(u.pcm, u.sample_rate, {kRate}).samples);
  const auto dir =
      std::filesystem::temp_directory_path() / ("bench-live-audio-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const fctest::ServeProcess server(facecast::test::facecast_exe().string(),
                                    {"--data", (dir / "data").string()}, 60,
                                    (dir / "server.log").string());
  const std::string load_before = load_average();
  const double cpu0 = cpu_seconds(server.pid());
  net::io_context ioc;
  const int chunks = static_cast<int>(seconds * kRate / kChunk);
  std::vector<std::shared_ptr<Client>> all;
  for (int c = 0; c < clients; ++c) {
    // Aligned streams start at the speech's start (their text is the speech's), one every 20 ms;
    // the others together, at different points of it.
    all.push_back(std::make_shared<Client>(
        ioc, server.port(), s, aligned ? 0 : static_cast<std::size_t>(c) * 7919 % s.pcm.size(),
        chunks, std::chrono::milliseconds(aligned ? 20 * c : 0)));
    all.back()->start();
  }
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) threads.emplace_back([&] { ioc.run(); });
  for (auto& t : threads) t.join();
  const double cpu = cpu_seconds(server.pid()) - cpu0;
  std::sort(s.latency.begin(), s.latency.end());
  const auto at = [&](double p) {
    return s.latency.empty()
               ? 0.0
               : s.latency[std::min(
                     s.latency.size() - 1,
                     static_cast<std::size_t>(p * static_cast<double>(s.latency.size())))];
  };
  std::printf(
      "live audio lip-sync (%s): %d clients x %.0f s of 20 ms chunks; %zu frames, %d streams "
      "ended, %d errors\n",
      text_ahead ? "aligned, text a repetition ahead"
      : aligned  ? "aligned to its text"
                 : "audio alone",
      clients, seconds, s.latency.size(), s.ended.load(), s.errors.load());
  std::printf("chunk -> weights latency: p50 %.1f ms, p99 %.1f ms, max %.1f ms\n", at(0.5) * 1000,
              at(0.99) * 1000, at(1.0) * 1000);
  std::printf("server CPU: %.2f s, %.0f us per chunk; load average before %s, after %s\n", cpu,
              1e6 * cpu / (static_cast<double>(clients) * chunks), load_before.c_str(),
              load_average().c_str());
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return s.errors > 0 ? 1 : 0;
}
