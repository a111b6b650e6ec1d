// Audio files -> mono float at the working rate: libsndfile in process, ffmpeg for the rest.
// See docs/algorithms.md#audio-in.
#include <sndfile.h>

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
#include "facecast/core/subprocess.hpp"
#include "facecast/viseme/audio.hpp"

namespace facecast::viseme {
namespace {

std::string seconds_text(double s) {
  std::ostringstream o;
  o << std::round(s * 10) / 10 << " s";
  return o.str();
}

Error too_long(const std::string& path, const std::string& how_long, const AudioOptions& o) {
  return Error(path + ": " + how_long + " of audio is longer than the limit of " +
                   seconds_text(o.max_seconds) + " (" + o.limit_name + ")",
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
    throw too_long(path, seconds_text(static_cast<double>(info.frames) / info.samplerate), o);
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
      throw too_long(path, "more than " + seconds_text(o.max_seconds), o);
  }
  if (sf_error(f) != SF_ERR_NO_ERROR)
    throw Error(path + ": cannot decode audio: " + sf_strerror(f));
  out.samples = resample(mono, info.samplerate, o.sample_rate);
  out.sample_rate = o.sample_rate;
  return true;
}

// ffmpeg's last error line for a message: "[mp3 @ 0x55d0c8e4a740] " prefixes (an address of the
// server's child, nothing a client needs) dropped, "file:<path>" shown as <path>.
std::string ffmpeg_reason(const RunResult& r, const std::string& path) {
  std::string line = r.last_error_line();
  if (line.starts_with("[")) {
    const auto close = line.find("] ");
    if (close != std::string::npos && line.find(" @ 0x") < close) line.erase(0, close + 2);
  }
  for (const std::string& name : {"file:" + path + ": ", path + ": "})
    if (line.starts_with(name)) line.erase(0, name.size());
  for (auto at = line.find("file:" + path); at != std::string::npos;
       at = line.find("file:" + path, at))
    line.erase(at, 5);
  if (r.status.timed_out || r.status.signal != 0 || line.empty()) return r.describe();
  return line;
}

// ffmpeg as a subprocess writing f32le mono at the working rate to a pipe (core/subprocess.hpp:
// stdout and stderr read together, a wall-clock limit). Its output is capped at the length limit
// plus a second (-t, -fs, and the pipe's byte cap) so an over-long file stops early.
void read_ffmpeg(const std::string& path, const AudioOptions& o, Audio& out) {
  const double seconds = o.max_seconds + 1;
  const auto max_bytes =
      static_cast<std::size_t>(std::ceil(seconds * o.sample_rate)) * sizeof(float) + 65536;
  std::vector<std::string> args = {o.ffmpeg, "-nostdin", "-hide_banner", "-v", "error"};
  if (o.untrusted) {
    // Outside input: local files and pipes only (no network, no playlists reaching other files),
    // the audio demuxers we accept, nothing else.
    args.insert(args.end(),
                {"-protocol_whitelist", "file,pipe", "-format_whitelist", kUntrustedFormats});
  }
  args.insert(args.end(), {"-i", "file:" + path, "-map", "0:a:0", "-vn", "-sn", "-dn", "-ac", "1",
                           "-ar", std::to_string(o.sample_rate), "-t", std::to_string(seconds),
                           "-fs", std::to_string(max_bytes), "-f", "f32le", "pipe:1"});
  RunOptions run;
  run.timeout = o.decode_timeout;
  run.max_output = max_bytes;
  run.max_error = 16384;
  RunResult r;
  try {
    r = run_subprocess(args, run);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " to decode " + path, ErrorCode::kInternal);
  }
  const auto limit = static_cast<std::size_t>(o.max_seconds * o.sample_rate);
  if (r.output_limited || (r.ok() && r.out.size() / 4 > limit))
    throw too_long(path, "more than " + seconds_text(o.max_seconds), o);
  if (r.status.timed_out) {
    throw Error(path + ": decoding took longer than the limit of " +
                    seconds_text(o.decode_timeout) + " (" +
                    (o.untrusted ? "audio_decode_timeout" : "audio.decode_timeout") + ")",
                ErrorCode::kLimit);
  }
  if (!r.ok()) {
    if (o.untrusted)
      throw Error(path + ": ffmpeg could not decode the audio: " + ffmpeg_reason(r, path));
    throw Error(path + ": not audio that libsndfile or ffmpeg can read (" + ffmpeg_reason(r, path) +
                ")");
  }
  out.sample_rate = o.sample_rate;
  out.samples.resize(r.out.size() / 4);
  std::memcpy(out.samples.data(), r.out.data(), out.samples.size() * 4);
  for (float& v : out.samples)
    if (!std::isfinite(v)) v = 0;
}

}  // namespace

AudioOptions load_audio_options() {
  ConfigReader c = ConfigReader::open(config_path("viseme/audio.json"));
  AudioOptions o;
  c.read("sample_rate", o.sample_rate)
      .read("max_seconds", o.max_seconds)
      .read("min_seconds", o.min_seconds)
      .read("ffmpeg", o.ffmpeg)
      .read("decode_timeout", o.decode_timeout);
  if (o.sample_rate < 8000 || o.sample_rate > 48000) c.fail("sample_rate", "must be 8000..48000");
  if (!(o.decode_timeout > 0)) c.fail("decode_timeout", "must be positive");
  c.reject_unknown();
  return o;
}

Audio read_audio(const std::string& path, const AudioOptions& o) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(path + ": no such audio file", ErrorCode::kNotFound);
  if (std::filesystem::file_size(path, ec) == 0) throw Error(path + ": the file is empty");
  Audio out;
  if (o.untrusted || !read_sndfile(path, o, out)) read_ffmpeg(path, o, out);
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
