// A channel published as RTMP (H.264 + AAC) to Debian's nginx with libnginx-mod-rtmp on loopback,
// recorded to FLV and read back with ffprobe/ffmpeg: codecs, length, and the audio/video offset
// measured by cross-correlating the recorded pictures' motion with the motion of the weights the
// channel sent and the recorded sound's envelope with the PCM it sent
// (docs/algorithms.md#rtmp-out). The same nginx also cuts the stream into HLS (as
// deploy/nginx-rtmp.conf does): the playlist and its H.264 + AAC segments appear.
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <thread>

#include "client.hpp"
#include "test_data.hpp"

using namespace fctest;
using facecast::server::ServerOptions;
namespace fs = std::filesystem;

namespace {

constexpr double kFps = 25;

// nginx with the RTMP module, recording every stream of application "live" into `dir`/rec and
// cutting it into HLS segments in `dir`/hls (kept after the stream ends: hls_cleanup off).
class Nginx {
 public:
  Nginx(const fs::path& dir, unsigned short port) {
    fs::create_directories(dir / "rec");
    fs::remove_all(dir / "hls");  // no playlist of an earlier run
    fs::create_directories(dir / "hls");
    std::ofstream(dir / "nginx.conf")
        << "load_module /usr/lib/nginx/modules/ngx_rtmp_module.so;\n"
           "daemon off;\nmaster_process off;\nworker_processes 1;\n"
        << "pid " << (dir / "nginx.pid").string() << ";\nerror_log " << (dir / "error.log").string()
        << " info;\nevents { worker_connections 64; }\n"
        << "rtmp { server { listen 127.0.0.1:" << port
        << "; application live { live on; record all; record_unique off; record_path "
        << (dir / "rec").string() << "; hls on; hls_fragment 2s; hls_cleanup off; hls_path "
        << (dir / "hls").string() << "; } } }\n";
    std::vector<std::string> args = {"/usr/sbin/nginx",
                                     "-p",
                                     dir.string(),
                                     "-e",
                                     (dir / "early.log").string(),
                                     "-c",
                                     (dir / "nginx.conf").string()};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      execv(argv[0], argv.data());
      _exit(127);
    }
    // Ready when the port accepts.
    for (int i = 0; i < 100; ++i) {
      boost::asio::io_context io;
      boost::asio::ip::tcp::socket s(io);
      boost::system::error_code ec;
      s.connect({boost::asio::ip::make_address("127.0.0.1"), port}, ec);
      if (!ec) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    FAIL("nginx did not listen on " << port);
  }
  ~Nginx() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }

 private:
  pid_t pid_ = -1;
};

std::string run(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  REQUIRE(p);
  char buf[65536];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  REQUIRE(pclose(p) == 0);
  return out;
}

// What the channel sent for one utterance: weights per frame and the PCM.
struct Sent {
  double fps = 0, duration = 0;
  int rate = 0;
  std::size_t per_frame = 0;
  std::vector<std::vector<float>> frames;
  std::vector<std::int16_t> pcm;
};

Sent collect(WsClient& c, const std::string& id) {
  using facecast::server::MediaKind;
  Sent s;
  std::uint32_t stream = 0;
  for (;;) {
    auto m = c.read(60 * slowdown());
    REQUIRE(m);
    if (m->text) {
      const auto j = m->json();
      if (j["type"] == "stream_start" && j["id"] == id) {
        stream = j["stream"];
        s.fps = j["fps"];
        s.duration = j["duration"];
        s.rate = j["audio"]["sample_rate"];
        s.per_frame = j["names"].size() + j["extra"].size();
      }
      if (j["type"] == "stream_end" && j["id"] == id) return s;
      continue;
    }
    const auto h = facecast::server::read_header(m->data);
    if (h.stream != stream || !stream) continue;
    const std::string_view payload = std::string_view(m->data).substr(24);
    if (h.kind == MediaKind::kWeights) {
      const auto v = facecast::server::read_floats(payload);
      for (std::uint32_t i = 0; i < h.count; ++i) {
        if (s.frames.size() < h.first + i + 1) s.frames.resize(h.first + i + 1);
        s.frames[h.first + i].assign(v.begin() + i * s.per_frame,
                                     v.begin() + (i + 1) * s.per_frame);
      }
    } else if (h.kind == MediaKind::kAudio) {
      if (s.pcm.size() < h.first + h.count) s.pcm.resize(h.first + h.count);
      std::memcpy(s.pcm.data() + h.first, payload.data(), 2 * h.count);
    }
  }
}

// The lag (in samples of `a`) at which b best matches a: a[i + lag] ~ b[i] (Pearson).
// `min_r`: the correlation the match must reach (pictures follow the weights less closely than the
// recorded sound follows the PCM).
int best_lag(const std::vector<double>& a, const std::vector<double>& b, int lo, int hi,
             double min_r) {
  int best = lo;
  double best_r = -2;
  for (int lag = lo; lag <= hi; ++lag) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int n = 0;
    for (std::size_t i = 0; i < b.size(); ++i) {
      const long j = static_cast<long>(i) + lag;
      if (j < 0 || j >= static_cast<long>(a.size())) continue;
      const double x = a[static_cast<std::size_t>(j)], y = b[i];
      sa += x, sb += y, saa += x * x, sbb += y * y, sab += x * y, ++n;
    }
    if (n < static_cast<int>(b.size())) continue;  // b lies wholly inside a
    const double cov = sab - sa * sb / n;
    const double r = cov / std::sqrt((saa - sa * sa / n) * (sbb - sb * sb / n) + 1e-12);
    if (r > best_r) best_r = r, best = lag;
  }
  INFO("correlation " << best_r);
  CHECK(best_r > min_r);
  return best;
}

// RMS of consecutive blocks of `block` seconds (block i: samples [round(i b r), round((i+1) b r))).
std::vector<double> envelope(const std::vector<std::int16_t>& pcm, int rate, double block) {
  std::vector<double> out;
  for (std::size_t i = 0;; ++i) {
    const auto lo = static_cast<std::size_t>(std::lround(static_cast<double>(i) * block * rate));
    const auto hi =
        static_cast<std::size_t>(std::lround(static_cast<double>(i + 1) * block * rate));
    if (hi > pcm.size()) return out;
    double e = 0;
    for (std::size_t k = lo; k < hi; ++k) e += double(pcm[k]) * pcm[k];
    out.push_back(std::sqrt(e / static_cast<double>(hi - lo)));
  }
}

double stream_start_time(const fs::path& flv, const char* stream) {
  return std::stod(run("ffprobe -v error -select_streams " + std::string(stream) +
                       " -show_entries stream=start_time -of csv=p=0 '" + flv.string() + "'"));
}

}  // namespace

TEST_CASE("a channel publishes RTMP (H.264 + AAC) with the mouth in sync with the sound",
          "[rtmp][slow]") {
  const fs::path dir = facecast::test::scratch_dir() / "rtmp";
  const unsigned short port = free_port();
  Nginx nginx(dir, port);
  Sent sent;
  const auto t_start = std::chrono::steady_clock::now();
  const auto since_start = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  };
  {
    TestServer s([&](ServerOptions& o) {
      o.channels.push_back({"show", kProducerToken});
      o.channel_idle = 0;  // the face rests between utterances
      ServerOptions::Rtmp r;
      r.url = "rtmp://127.0.0.1:" + std::to_string(port) + "/live/show";
      r.width = 320;
      r.height = 240;
      r.fps = kFps;
      o.rtmp["show"] = r;
    });
    WsClient c(s.port());
    c.read_json(10);
    c.send(nlohmann::json{{"type", "subscribe"}, {"channel", "show"}});
    std::this_thread::sleep_for(std::chrono::seconds(1));  // a second of rest first
    const nlohmann::json body = {
        {"id", "ten"},
        {"fps", kFps},
        {"text",
         "Good evening, and welcome to the late news. Tonight the river rose over the old bridge, "
         "the market stayed open until midnight, and the weather will be calm tomorrow."}};
    const auto posted =
        http_request(s.port(), http::verb::post, "/api/channels/show/speak", body.dump(),
                     {{"Authorization", std::string("Bearer ") + kProducerToken}});
    REQUIRE(posted.status == 202);
    sent = collect(c, "ten");
    std::this_thread::sleep_for(std::chrono::seconds(2));  // the delay and a little rest after
  }  // the server stops: ffmpeg ends the stream, nginx closes the recording
  const double published = since_start();
  const fs::path flv = dir / "rec" / "show.flv";
  REQUIRE(fs::exists(flv));
  // Kept for people to look at: the recording and the PCM the channel sent.
  const fs::path keep = facecast::test::artifacts_dir("rtmp");
  fs::copy_file(flv, keep / "show.flv", fs::copy_options::overwrite_existing);
  std::ofstream(keep / "sent.s16le", std::ios::binary)
      .write(reinterpret_cast<const char*>(sent.pcm.data()),
             static_cast<std::streamsize>(2 * sent.pcm.size()));
  INFO("utterance " << sent.duration << " s, " << sent.frames.size() << " frames");
  CHECK(sent.duration > 8);
  CHECK(sent.fps == kFps);

  // ffprobe: H.264 video and AAC audio, as long as what was published (rest + utterance + rest).
  const std::string codecs =
      run("ffprobe -v error -show_entries stream=codec_name -of csv=p=0 '" + flv.string() + "'");
  CHECK_THAT(codecs, Catch::Contains("h264") && Catch::Contains("aac"));
  const double duration = std::stod(
      run("ffprobe -v error -show_entries format=duration -of csv=p=0 '" + flv.string() + "'"));
  // As long as the rest, the utterance and the rest: only where the encoder keeps up with real
  // time (under ThreadSanitizer it falls behind and the recording ends short; seen at 8.3 of 10.8
  // s).
  if (real_time()) CHECK(duration > sent.duration + 1.5);
  CHECK(duration > 0);
  CHECK(duration < published);

  // HLS: a playlist naming MPEG-TS segments that hold H.264 and AAC.
  std::ifstream playlist(dir / "hls" / "show.m3u8");
  REQUIRE(playlist);
  std::string line, first_segment;
  int segments = 0;
  while (std::getline(playlist, line)) {
    if (line.ends_with(".ts")) {
      if (first_segment.empty()) first_segment = line;
      ++segments;
    }
  }
  // Two 2-second fragments at least where the encoder keeps up; under ThreadSanitizer the stream
  // can end before nginx cuts the second one (seen: one segment for an 8 s utterance).
  INFO("recording " << duration << " s, " << segments << " HLS segments");
  CHECK(segments >= (real_time() ? 2 : 1));
  REQUIRE_FALSE(first_segment.empty());
  CHECK_THAT(run("ffprobe -v error -show_entries stream=codec_name -of csv=p=0 '" +
                 (dir / "hls" / first_segment).string() + "'"),
             Catch::Contains("h264") && Catch::Contains("aac"));

  if (!real_time()) {
    WARN("ThreadSanitizer build: the audio/video offset is not measured (slower than real time)");
    return;
  }
  // Video: where the recorded pictures match the weights the channel sent.
  const int w = 80, h = 60;
  const std::string gray =
      run("ffmpeg -v error -i '" + flv.string() + "' -map 0:v:0 -vf scale=" + std::to_string(w) +
          ":" + std::to_string(h) + " -pix_fmt gray -fps_mode passthrough -f rawvideo pipe:1");
  const std::size_t frame_bytes = static_cast<std::size_t>(w * h);
  // Motion: mean absolute change of each recorded picture from the previous one, and of each
  // sent weights frame (shapes and head) from the previous one.
  std::vector<double> pose_out;
  for (std::size_t k = 1; (k + 1) * frame_bytes <= gray.size(); ++k) {
    double d = 0;
    for (std::size_t i = 0; i < frame_bytes; ++i)
      d += std::abs(int(static_cast<unsigned char>(gray[k * frame_bytes + i])) -
                    int(static_cast<unsigned char>(gray[(k - 1) * frame_bytes + i])));
    pose_out.push_back(d / frame_bytes);
  }
  std::vector<double> pose_sent;
  for (std::size_t f = 1; f < sent.frames.size(); ++f) {
    double d = 0;
    for (std::size_t i = 0; i < sent.per_frame; ++i)
      d += std::abs(sent.frames[f][i] - sent.frames[f - 1][i]);
    pose_sent.push_back(d);
  }
  REQUIRE(pose_out.size() > pose_sent.size());
  const int video_lag =
      best_lag(pose_out, pose_sent, 0, static_cast<int>(pose_out.size() - pose_sent.size()), 0.35);
  const double video_at = stream_start_time(flv, "v:0") + video_lag / kFps;

  // Audio: where the recorded sound's envelope matches the PCM the channel sent.
  const std::string raw =
      run("ffmpeg -v error -i '" + flv.string() + "' -map 0:a:0 -f s16le -ac 1 -ar 48000 pipe:1");
  std::vector<std::int16_t> out_pcm(raw.size() / 2);
  std::memcpy(out_pcm.data(), raw.data(), out_pcm.size() * 2);
  const double block = 0.005;
  const auto env_out = envelope(out_pcm, 48000, block);
  const auto env_sent = envelope(sent.pcm, sent.rate, block);
  REQUIRE(env_out.size() > env_sent.size());
  const int audio_lag =
      best_lag(env_out, env_sent, 0, static_cast<int>(env_out.size() - env_sent.size()), 0.8);
  const double audio_at = stream_start_time(flv, "a:0") + audio_lag * block;

  const double offset = video_at - audio_at;
  WARN("RTMP audio/video offset " << offset * 1000 << " ms (video pts 0 at " << video_at
                                  << " s, audio at " << audio_at << " s)");
  CHECK(std::abs(offset) <= 1.0 / kFps);
}
