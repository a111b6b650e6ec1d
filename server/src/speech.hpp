#pragma once
// The speech service: one speak request made ready to stream (on a worker thread): text,
// timestamps or uploaded audio -> utterance (viseme engine) -> Performance (animation) for the rig,
// plus audio and, in frames mode, a renderer. It owns the speech settings (configs/viseme,
// configs/anim) and the uploaded audio.
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "audio_uploads.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/viseme/options.hpp"
#include "metrics.hpp"
#include "rigs.hpp"

namespace facecast::server {

struct PreparedSpeech {
  std::shared_ptr<const LoadedRig> rig;
  std::optional<anim::Performance> performance;
  std::vector<std::int16_t> pcm;
  int sample_rate = 0;
  nlohmann::json utterance;                    // the viseme engine's JSON
  std::shared_ptr<render::Renderer> renderer;  // frames mode
  int frames = 0;
  double duration = 0, speech_duration = 0;
};

class Speech {
 public:
  /// Reads configs/viseme and configs/anim; `rigs` and `renderers` outlive it.
  Speech(RigRegistry& rigs, RendererCache& renderers, Metrics& metrics, AudioUploadOptions uploads,
         double max_utterance_seconds);

  /// Viseme options for a request (the server's defaults, overridden by the request).
  viseme::Options options(viseme::LangMode lang, viseme::Timing timing, const std::string& voice,
                          double rate) const;
  /// The server's defaults (configs/viseme/viseme.json, configs/anim/animation.json).
  const viseme::Options& viseme_options() const noexcept { return viseme_; }
  const anim::AnimOptions& anim_options() const noexcept { return anim_; }
  /// POST /api/audio's uploads, spoken by `speak` with audio_id.
  AudioUploads& uploads() noexcept { return uploads_; }

  /// Throws facecast::Error (bad text, unknown rig, voice, ...).
  std::shared_ptr<PreparedSpeech> prepare(const SpeakRequest& request, std::uint32_t seed);
  /// Idle life only (blinks, small head and eye motion), `seconds` long, no audio: what a channel
  /// plays between utterances.
  std::shared_ptr<PreparedSpeech> prepare_idle(const SpeakRequest& request, double seconds,
                                               std::uint32_t seed);

 private:
  RigRegistry& rigs_;
  RendererCache& renderers_;
  Metrics& metrics_;
  viseme::Options viseme_;
  anim::AnimOptions anim_;
  AudioUploads uploads_;
  double max_utterance_seconds_;
};

}  // namespace facecast::server
