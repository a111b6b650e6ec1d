#include "speech.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "facecast/viseme/align.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/import.hpp"
#include "facecast/viseme/lipsync.hpp"

namespace facecast::server {

namespace {

// The latest time anything in `u` happens: the frame count, idle life and the stream's lifetime
// are sized by it, so it is checked before any of them is made.
double utterance_end(const viseme::Utterance& u) {
  double end = u.duration;
  for (const auto& p : u.phones) end = std::max(end, p.end);
  for (const auto& v : u.visemes) end = std::max(end, v.end);
  for (const auto& w : u.words) end = std::max(end, w.end);
  for (const auto& e : u.expressions) end = std::max(end, e.start + e.ramp);
  return end;
}

void check_length(const viseme::Utterance& u, double max_seconds) {
  const double end = utterance_end(u);
  if (!(end <= max_seconds)) {  // NaN too
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "speak: the utterance lasts %.6g s, over max_utterance_seconds (%g s)", end,
                  max_seconds);
    throw RequestError(Code::kLimit, buf);
  }
}

}  // namespace

viseme::Options speech_options(const State& state, viseme::LangMode lang, viseme::Timing timing,
                               const std::string& voice, double rate) {
  viseme::Options o = state.viseme_options;
  o.lang = lang;
  o.timing = timing;
  o.en_voice = voice;
  o.rate = rate;
  return o;
}

std::shared_ptr<PreparedSpeech> prepare_speech(State& state, const SpeakRequest& r,
                                               std::uint32_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  auto p = std::make_shared<PreparedSpeech>();
  p->rig = state.rigs.load(r.rig);
  const viseme::Options vo = speech_options(state, r.lang, r.timing, r.voice, r.rate);
  viseme::Utterance u;
  if (!r.audio_id.empty()) {
    const auto audio = state.audio_uploads.get(r.audio_id);
    if (!audio)
      throw Error("audio_id '" + r.audio_id + "': no such upload (POST /api/audio; uploads expire)",
                  ErrorCode::kNotFound);
    u = r.text ? viseme::align(*r.text, *audio, vo, state.audio_uploads.align_options())
               : viseme::lipsync(*audio, vo, state.audio_uploads.lipsync_options());
  } else if (r.text) {
    u = viseme::analyze(*r.text, vo);
  } else {
    u = viseme::import_timestamps(r.timestamps->format, r.timestamps->data, vo,
                                  r.timestamps->phones, "timestamps");
    if (!r.timestamps->text.empty()) u.text = r.timestamps->text;
  }
  check_length(u, state.options.max_utterance_seconds);
  anim::AnimOptions ao = state.anim_options;
  ao.idle = r.idle;
  ao.seed = seed;
  p->performance.emplace(u, p->rig->mapping, ao);
  p->duration = p->performance->duration();
  p->speech_duration = p->performance->speech_duration();
  p->frames = p->performance->frame_count(r.fps);
  p->utterance = viseme::to_json(u);
  if (r.audio) {
    p->pcm = std::move(u.pcm);
    p->sample_rate = u.sample_rate;
  }
  if (r.output == Output::kFrames) p->renderer = state.renderers.get(*p->rig, r.width, r.height);
  state.metrics.analysis_seconds.observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return p;
}

std::shared_ptr<PreparedSpeech> prepare_idle(State& state, const SpeakRequest& r, double seconds,
                                             std::uint32_t seed) {
  auto p = std::make_shared<PreparedSpeech>();
  p->rig = state.rigs.load(r.rig);
  viseme::Utterance u;  // no phones: the performance is idle life over `seconds`
  u.duration = seconds;
  anim::AnimOptions ao = state.anim_options;
  ao.idle = true;
  ao.seed = seed;
  ao.tail = 0;
  p->performance.emplace(u, p->rig->mapping, ao);
  p->duration = p->performance->duration();
  p->speech_duration = 0;
  p->frames = p->performance->frame_count(r.fps);
  p->utterance = viseme::to_json(u);
  return p;
}

}  // namespace facecast::server
