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

Speech::Speech(RigRegistry& rigs, RendererCache& renderers, Metrics& metrics,
               AudioUploadOptions uploads, double max_utterance_seconds)
    : rigs_(rigs),
      renderers_(renderers),
      metrics_(metrics),
      viseme_(viseme::load_options()),
      anim_(anim::load_anim_options()),
      uploads_(std::move(uploads)),
      max_utterance_seconds_(max_utterance_seconds) {}

viseme::Options Speech::options(viseme::LangMode lang, viseme::Timing timing,
                                const std::string& voice, double rate) const {
  viseme::Options o = viseme_;
  o.lang = lang;
  o.timing = timing;
  o.en_voice = voice;
  o.rate = rate;
  return o;
}

std::shared_ptr<PreparedSpeech> Speech::prepare(const SpeakRequest& r, std::uint32_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  auto p = std::make_shared<PreparedSpeech>();
  p->rig = rigs_.load(r.rig);
  const viseme::Options vo = options(r.lang, r.timing, r.voice, r.rate);
  viseme::Utterance u;
  if (!r.audio_id.empty()) {
    const auto audio = uploads_.get(r.audio_id);
    if (!audio)
      throw Error("audio_id '" + r.audio_id + "': no such upload (POST /api/audio; uploads expire)",
                  ErrorCode::kNotFound);
    u = r.text ? viseme::align(*r.text, *audio, vo, uploads_.align_options())
               : viseme::lipsync(*audio, vo, uploads_.lipsync_options());
  } else if (r.text) {
    u = viseme::analyze(*r.text, vo);
  } else {
    u = viseme::import_timestamps(r.timestamps->format, r.timestamps->data, vo,
                                  r.timestamps->phones, "timestamps");
    if (!r.timestamps->text.empty()) u.text = r.timestamps->text;
  }
  check_length(u, max_utterance_seconds_);
  anim::AnimOptions ao = anim_;
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
  if (r.output == Output::kFrames) p->renderer = renderers_.get(*p->rig, r.width, r.height);
  metrics_.analysis_seconds.observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return p;
}

std::shared_ptr<PreparedSpeech> Speech::prepare_idle(const SpeakRequest& r, double seconds,
                                                     std::uint32_t seed) {
  auto p = std::make_shared<PreparedSpeech>();
  p->rig = rigs_.load(r.rig);
  viseme::Utterance u;  // no phones: the performance is idle life over `seconds`
  u.duration = seconds;
  anim::AnimOptions ao = anim_;
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
