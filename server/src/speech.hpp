#pragma once
// One speak request made ready to stream (on a worker thread): text or timestamps -> utterance
// (viseme engine) -> Performance (animation) for the rig, plus audio and, in frames mode, a
// renderer.
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/anim/animation.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/server/protocol.hpp"
#include "rigs.hpp"
#include "state.hpp"

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

/// Viseme options for a request (the server's defaults, overridden by the request).
viseme::Options speech_options(const State& state, viseme::LangMode lang, viseme::Timing timing,
                               const std::string& voice, double rate);

/// Idle life only (blinks, small head and eye motion), `seconds` long, no audio: what a channel
/// plays between utterances.
std::shared_ptr<PreparedSpeech> prepare_idle(State& state, const SpeakRequest& request,
                                             double seconds, std::uint32_t seed);

/// Throws facecast::Error (bad text, unknown rig, voice, ...).
std::shared_ptr<PreparedSpeech> prepare_speech(State& state, const SpeakRequest& request,
                                               std::uint32_t seed);

}  // namespace facecast::server
