#pragma once
// The speech input shared by `facecast animate` and `facecast render`: --text or --timestamps
// with the viseme options, the animation options (--idle), or an MPEG-4 FAP file (--fap).
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "facecast/anim/animation.hpp"
#include "facecast/anim/fap.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::cli {

struct SpeechArgs {
  std::string text, timestamps, timestamps_format = "auto", lang = "auto", timing, voice,
                                idle = "on", fap;
  double rate = 0;
  bool given() const { return !text.empty() || !timestamps.empty(); }
};

void add_speech_options(CLI::App* cmd, SpeechArgs& a);

/// The utterance of --text (with espeak-ng audio when `tts`; aligned to the speech in the file
/// `audio` when given) or --timestamps.
viseme::Utterance speech_utterance(const SpeechArgs& a, bool tts, const std::string& audio = "");

/// An utterance and the speech that goes with it.
struct Speech {
  viseme::Utterance utterance;
  std::vector<int16_t> pcm;  // mono PCM16; empty without audio
  int sample_rate = 0;
};
/// The speech input with its audio: `audio` "tts" (espeak-ng speaks --text), "none" or "" (no
/// sound), or an audio file (--text is aligned to it; with --timestamps it is the sound; alone,
/// audio-only lip-sync).
Speech speech_with_audio(const SpeechArgs& a, const std::string& audio);

/// configs/anim/animation.json with --idle applied.
anim::AnimOptions speech_anim_options(const SpeechArgs& a);

/// The rig measured for FAPs at its 68 landmarks: stored with it or known to the rig builder,
/// else detected on renders of it (seconds).
anim::FapRig fap_rig(const rig::Rig& rig);
/// The FAP file at `path` driving the rig `fap` was measured on.
anim::FapMotion read_fap_motion(const std::string& path, const anim::FapRig& fap);

}  // namespace facecast::cli
