// Audio files -> mono float at the working rate: libsndfile in process, ffmpeg for the rest.
// See docs/algorithms.md#audio-in.
#include <fcntl.h>
#include <signal.h>
#include <sndfile.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/audio.hpp"

namespace facecast::viseme {
namespace {

std::string seconds_text(double s) {
  std::ostringstream o;
  o << std::round(s * 10) / 10 << " s";
  return o.str();
}

Error too_long(const std::string& path, const std::string& how_long, double limit) {
  return Error(path + ": " + how_long + " of audio is longer than the limit of " +
                   seconds_text(limit) + " (audio.max_seconds)",
               ErrorCode::kLimit);
}

void check_length(const std::string& path, const Audio& a, const AudioOptions& o) {
  if (a.samples.empty()) throw Error(path + ": the file holds no audio samples");
  if (a.seconds() < o.min_seconds)
    throw Error(path + ": " + seconds_text(a.seconds()) + " of audio is too short to analyze");
}

// Whether the file starts like a container libsndfile reads (WAV/RF64, AIFF, AU, CAF, FLAC, OGG,
// MP3 with an ID3 tag or a frame sync). Others go straight to ffmpeg: libsndfile's MP3 decoder
// prints resync notes to stderr on files that are not MP3 at all.
bool sndfile_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[4] = {};
  in.read(reinterpret_cast<char*>(b), 4);
  if (in.gcount() < 4) return false;
  const std::string m(reinterpret_cast<const char*>(b), 4);
  for (const char* magic : {"RIFF", "RIFX", "RF64", "FORM", ".snd", "caff", "fLaC", "OggS"})
    if (m == magic) return true;
  return m.compare(0, 3, "ID3") == 0 || (b[0] == 0xFF && (b[1] & 0xE0) == 0xE0);
}

// libsndfile; false when it does not recognise the file (then ffmpeg tries).
bool read_sndfile(const std::string& path, const AudioOptions& o, Audio& out) {
  if (!sndfile_magic(path)) return false;
  SF_INFO info{};
  SNDFILE* f = sf_open(path.c_str(), SFM_READ, &info);
  if (!f) return false;
  const std::unique_ptr<SNDFILE, int (*)(SNDFILE*)> guard(f, sf_close);
  if (info.channels < 1 || info.samplerate < 1) return false;
  const double limit_frames = o.max_seconds * info.samplerate;
  if (static_cast<double>(info.frames) > limit_frames)
    throw too_long(path, seconds_text(static_cast<double>(info.frames) / info.samplerate),
                   o.max_seconds);
  std::vector<float> mono;
  std::vector<float> block(static_cast<std::size_t>(4096 * info.channels));
  for (;;) {
    const sf_count_t n = sf_readf_float(f, block.data(), 4096);
    if (n <= 0) break;
    for (sf_count_t i = 0; i < n; ++i) {
      float sum = 0;
      for (int c = 0; c < info.channels; ++c)
        sum += block[static_cast<std::size_t>(i * info.channels + c)];
      mono.push_back(std::isfinite(sum) ? sum / static_cast<float>(info.channels) : 0.0f);
    }
    // The header's length can be an estimate (MP3): the limit also holds while reading.
    if (static_cast<double>(mono.size()) > limit_frames)
      throw too_long(path, "more than " + seconds_text(o.max_seconds), o.max_seconds);
  }
  if (sf_error(f) != SF_ERR_NO_ERROR)
    throw Error(path + ": cannot decode audio: " + sf_strerror(f));
  out.samples = resample(mono, info.samplerate, o.sample_rate);
  out.sample_rate = o.sample_rate;
  return true;
}

// ffmpeg as a subprocess writing f32le mono at the working rate to a pipe; its output is capped
// at the length limit (plus a second) so an over-long file stops early.
void read_ffmpeg(const std::string& path, const AudioOptions& o, Audio& out) {
  const std::vector<std::string> args = {o.ffmpeg,
                                         "-nostdin",
                                         "-v",
                                         "error",
                                         "-i",
                                         path,
                                         "-vn",
                                         "-ac",
                                         "1",
                                         "-ar",
                                         std::to_string(o.sample_rate),
                                         "-t",
                                         std::to_string(o.max_seconds + 1),
                                         "-f",
                                         "f32le",
                                         "pipe:1"};
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  int pout[2], perr[2];
  if (pipe2(pout, O_CLOEXEC) != 0 || pipe2(perr, O_CLOEXEC) != 0)
    throw Error("pipe: " + std::string(std::strerror(errno)), ErrorCode::kInternal);
  const pid_t pid = fork();
  if (pid < 0) throw Error("fork: " + std::string(std::strerror(errno)), ErrorCode::kInternal);
  if (pid == 0) {  // only async-signal-safe calls until exec
    const int null = open("/dev/null", O_RDONLY);
    if (null >= 0) dup2(null, STDIN_FILENO);
    dup2(pout[1], STDOUT_FILENO);
    dup2(perr[1], STDERR_FILENO);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  close(pout[1]);
  close(perr[1]);
  const auto limit = static_cast<std::size_t>(o.max_seconds * o.sample_rate);
  std::string bytes;
  char buf[65536];
  bool over = false;
  for (;;) {
    const ssize_t n = read(pout[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.append(buf, static_cast<std::size_t>(n));
    if (bytes.size() / 4 > limit) {
      over = true;
      kill(pid, SIGKILL);
      break;
    }
  }
  close(pout[0]);
  std::string err;
  for (ssize_t n; (n = read(perr[0], buf, sizeof buf)) > 0;)
    err.append(buf, static_cast<std::size_t>(n));
  close(perr[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (over) throw too_long(path, "more than " + seconds_text(o.max_seconds), o.max_seconds);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  if (code == 127)
    throw Error("cannot run '" + o.ffmpeg + "' to decode " + path, ErrorCode::kInternal);
  if (code != 0) {
    std::string first = err.substr(0, err.find('\n'));
    if (const auto colon = first.rfind(": "); colon != std::string::npos)
      first = first.substr(colon + 2);
    throw Error(path + ": not audio that libsndfile or ffmpeg can read (" +
                (first.empty() ? "ffmpeg exit " + std::to_string(code) : first) + ")");
  }
  out.sample_rate = o.sample_rate;
  out.samples.resize(bytes.size() / 4);
  std::memcpy(out.samples.data(), bytes.data(), out.samples.size() * 4);
  for (float& s : out.samples)
    if (!std::isfinite(s)) s = 0;
}

}  // namespace

AudioOptions load_audio_options() {
  ConfigReader c = ConfigReader::open(config_path("viseme/audio.json"));
  AudioOptions o;
  c.read("sample_rate", o.sample_rate)
      .read("max_seconds", o.max_seconds)
      .read("min_seconds", o.min_seconds)
      .read("ffmpeg", o.ffmpeg);
  if (o.sample_rate < 8000 || o.sample_rate > 48000) c.fail("sample_rate", "must be 8000..48000");
  c.reject_unknown();
  return o;
}

Audio read_audio(const std::string& path, const AudioOptions& o) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(path + ": no such audio file", ErrorCode::kNotFound);
  if (std::filesystem::file_size(path, ec) == 0) throw Error(path + ": the file is empty");
  Audio out;
  if (!read_sndfile(path, o, out)) read_ffmpeg(path, o, out);
  check_length(path, out, o);
  return out;
}

Audio audio_from_pcm16(const std::vector<int16_t>& pcm, int sample_rate, const AudioOptions& o) {
  std::vector<float> f(pcm.size());
  for (std::size_t i = 0; i < pcm.size(); ++i) f[i] = static_cast<float>(pcm[i]) / 32768.0f;
  return {resample(f, sample_rate, o.sample_rate), o.sample_rate};
}

std::vector<int16_t> to_pcm16(const std::vector<float>& samples) {
  std::vector<int16_t> out(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i)
    out[i] = static_cast<int16_t>(std::lround(std::clamp(samples[i], -1.0f, 1.0f) * 32767.0f));
  return out;
}

}  // namespace facecast::viseme
