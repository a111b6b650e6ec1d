#pragma once
// Speech audio in: any file libsndfile or ffmpeg reads -> mono float at the working rate.
// See docs/algorithms.md#audio-in.
//
// libsndfile (in process) reads WAV, AIFF, FLAC, OGG/Vorbis, Opus and MP3 and reports the length
// before decoding, so an absurdly long file is refused from its header; anything else (AAC/M4A,
// WebM, video containers) goes to the ffmpeg binary as a subprocess (configs/viseme/audio.json
// names it), whose output is capped at the length limit so a 10-hour file is never decoded whole,
// and whose run is capped at decode_timeout seconds (core/subprocess.hpp). Untrusted input (the
// server's uploads) goes to ffmpeg only, with allow-listed protocols and demuxers.
// libsndfile's channels are averaged and resampled here (windowed sinc); ffmpeg does both itself.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::viseme {

struct AudioOptions {
  int sample_rate = 16000;    // the working rate every analysis runs at
  double max_seconds = 1800;  // longer input is refused
  double min_seconds = 0.05;  // shorter (or empty) input is refused
  std::string ffmpeg = "ffmpeg";
  double decode_timeout = 300;  // wall-clock seconds ffmpeg may take; then it is killed
  // Not in the config file: set by whoever decodes files from outside (the server's uploads).
  // Untrusted input is decoded only by ffmpeg in a child process (never libsndfile in process),
  // with its protocols limited to file/pipe and its demuxers to kUntrustedFormats.
  bool untrusted = false;
  std::string limit_name = "audio.max_seconds";  // the setting a too-long error names
};

/// The ffmpeg demuxers untrusted audio may use (-format_whitelist): WAV/W64, MP3, Ogg (Vorbis,
/// Opus, FLAC), FLAC, raw AAC, MP4/M4A/MOV, Matroska/WebM, AIFF, CAF, AU.
inline constexpr const char* kUntrustedFormats =
    "wav,w64,mp3,ogg,flac,aac,mov,matroska,aiff,caf,au";

/// Options from configs/viseme/audio.json; Error naming the file and key.
AudioOptions load_audio_options();

struct Audio {
  std::vector<float> samples;  // mono, nominally in -1..1
  int sample_rate = 0;
  double seconds() const {
    return sample_rate > 0 ? static_cast<double>(samples.size()) / sample_rate : 0.0;
  }
};

/// Reads `path` (any format libsndfile or ffmpeg reads, any rate and channel count) to mono at
/// options.sample_rate. Throws a one-line Error naming the file when it is missing, empty, not
/// audio, holds no samples or less than min_seconds, or is longer than max_seconds (checked before
/// decoding it all).
Audio read_audio(const std::string& path, const AudioOptions& options = {});

/// Mono PCM16 -> float at options.sample_rate.
Audio audio_from_pcm16(const std::vector<int16_t>& pcm, int sample_rate,
                       const AudioOptions& options = {});

/// Float -> mono PCM16 (clipped), for video muxing and WAV output.
std::vector<int16_t> to_pcm16(const std::vector<float>& samples);

/// Band-limited resampling of a whole signal (Kaiser-windowed sinc, 16 zero crossings,
/// cut-off at 0.95 x the lower Nyquist frequency).
std::vector<float> resample(const std::vector<float>& in, int from_rate, int to_rate);

/// The same filter for a stream: push chunks, get the resampled samples as they become known
/// (the filter's half-length of delay). Not thread-safe; one per stream.
class StreamResampler {
 public:
  StreamResampler(int from_rate, int to_rate);
  /// Appends the output samples that `chunk` completes to `out`.
  void push(const float* chunk, std::size_t n, std::vector<float>& out);
  int from_rate() const { return from_; }
  int to_rate() const { return to_; }

 private:
  int from_, to_;
  std::vector<float> buffer_;  // input samples not yet fully used
  double next_ = 0;            // next output position in input samples, relative to buffer_[0]
};

}  // namespace facecast::viseme
