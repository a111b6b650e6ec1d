#pragma once
// Live audio-only lip-sync of one WebSocket connection (docs/protocol.md, "Live audio in";
// docs/algorithms.md#audio-lipsync): the client sends PCM16 chunks as binary messages of kind 4,
// the server answers with a weights stream at 60 fps. The analyser's viseme events go through the
// same coarticulation and mixing as the text path: a Performance over the last `window` seconds of
// events is built per chunk and sampled `delay` behind the analysed audio.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <optional>

#include "beast.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/viseme/align_stream.hpp"
#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "rigs.hpp"

namespace facecast::server {

inline constexpr std::uint8_t kAudioInKind = 4;
inline constexpr std::uint16_t kAudioInLast = 1;     // flags: the stream ends with this chunk
inline constexpr std::uint16_t kAudioInAligned = 2;  // flags (first chunk): text comes beside it

/// A client's audio chunk: the 24-byte header (kind 4, version 1, u16 flags, u32 sample_rate,
/// u32 first sample, u32 count, f64 reserved) and count PCM16 samples.
struct AudioChunk {
  int sample_rate = 0;
  std::uint32_t first = 0;
  bool last = false;
  bool aligned = false;  // the stream's text comes in audio_text messages (first chunk only)
  std::vector<std::int16_t> samples;
};
/// Throws Error naming the field (size, kind, version, rate 8000..48000, count vs payload).
AudioChunk read_audio_chunk(std::string_view bytes);

/// PCM in, frames of weights (rig shapes + the body pose's channels) out: from the audio alone, or
/// (`align` given) aligned to the stream's text as it arrives (viseme::StreamAligner). Not
/// thread-safe.
class LiveLipsync {
 public:
  LiveLipsync(std::shared_ptr<const LoadedRig> rig, const anim::AnimOptions& anim,
              const viseme::LipsyncOptions& options, const viseme::Options& speech, int input_rate,
              double fps, const viseme::AlignOptions* align = nullptr);
  /// More of the aligned stream's text (with its time, or without for the aligner to find;
  /// `final`: the text ends with it). Throws Error when the stream is not aligned or the text
  /// cannot be aligned.
  void add_text(const AudioTextRequest& text);
  /// Appends the frames this chunk completes to `values` (frame-major); returns their count.
  int push(const std::int16_t* pcm, std::size_t n, std::vector<float>& values);
  /// The end of the audio: the remaining frames up to its end.
  int finish(std::vector<float>& values);
  /// Expression tags over the audio ("(smile,40,0.5)", optionally "@time" in stream seconds); a tag
  /// without a time starts at the next frame sent. Throws Error for a malformed tag.
  void add_expressions(std::string_view tags);

  int input_rate() const { return resampler_.from_rate(); }
  std::uint64_t samples() const { return samples_; }  // received so far
  int frames() const { return next_frame_; }          // sent so far
  std::size_t values_per_frame() const {
    return rig_->mapping.shape_names().size() + rig::BodyPose::kChannels.size();
  }
  const LoadedRig& rig() const { return *rig_; }
  double fps() const { return fps_; }

 private:
  int emit(double until, std::vector<float>& values);
  int sample(double end, bool open_last, std::vector<float>& values);

  std::shared_ptr<const LoadedRig> rig_;
  anim::AnimOptions anim_;
  viseme::LipsyncOptions options_;
  viseme::VisemeSet set_;
  double fps_;
  viseme::StreamResampler resampler_;
  viseme::LipsyncAnalyzer analyzer_;
  std::optional<viseme::StreamAligner> aligner_;
  std::vector<float> resampled_;
  std::vector<viseme::LipsyncFrame> frames_;
  std::vector<viseme::VisemeEvent> events_;
  std::vector<viseme::ExpressionEvent> expressions_;
  double analysed_ = 0;  // seconds of audio the analyser has decided
  std::uint64_t samples_ = 0;
  int next_frame_ = 0;
};

/// A connection's open live audio stream.
/// A connection's open live audio stream. The analysis runs on `strand`, a strand of the worker
/// pool, never on the I/O threads: `engine` is made and used only there (in order: the strand
/// runs one task at a time, first in first out), and what it makes is posted back to the
/// connection. The connection's side keeps what it checks the next chunk against.
struct LiveAudio {
  explicit LiveAudio(net::strand<net::thread_pool::executor_type> on) : strand(std::move(on)) {}
  struct Engine {
    std::optional<LiveLipsync> lipsync;  // empty until made (or when making it failed)
  };
  std::shared_ptr<Engine> engine = std::make_shared<Engine>();
  // Its concrete type, not any_io_executor: a pool's strand does not fit in its small buffer, and
  // the shared target that would hold it counts references with fences (-Wtsan).
  net::strand<net::thread_pool::executor_type> strand;
  std::uint32_t stream = 0;
  std::string id;              // "audio-<stream>", the stream_start / stream_end id
  int rate = 0;                // the stream's sample rate
  std::uint64_t received = 0;  // samples taken so far: the next chunk's first sample
  // When the stream opened: audio may run at most live_audio_ahead seconds ahead of real time, so
  // a client cannot make the analysis run unbounded.
  std::chrono::steady_clock::time_point opened = std::chrono::steady_clock::now();
};

}  // namespace facecast::server
