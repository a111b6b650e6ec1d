#include "espeak.hpp"

#include <espeak-ng/speak_lib.h>

#include <mutex>
#include <sstream>

#include "facecast/core/error.hpp"

namespace facecast::viseme::detail::espeak {
namespace {

std::mutex g_mutex;             // guards every espeak-ng call
Synthesis* g_target = nullptr;  // the synthesis the callback fills (under g_mutex)
int g_rate = 0;
std::string g_voice;  // the voice espeak-ng has loaded

int on_synth(short* wav, int samples, espeak_EVENT* events) {
  if (!g_target) return 0;
  if (wav && samples > 0) g_target->pcm.insert(g_target->pcm.end(), wav, wav + samples);
  for (espeak_EVENT* e = events; e && e->type != espeakEVENT_LIST_TERMINATED; ++e) {
    Event ev;
    ev.time = e->audio_position / 1000.0;
    if (e->type == espeakEVENT_WORD) {
      ev.kind = Event::Kind::kWord;
      ev.text_position = e->text_position;
    } else if (e->type == espeakEVENT_PHONEME) {
      ev.kind = Event::Kind::kPhoneme;
      char name[9] = {};
      for (int i = 0; i < 8 && e->id.string[i]; ++i) name[i] = e->id.string[i];
      ev.phoneme = name;
    } else if (e->type == espeakEVENT_END || e->type == espeakEVENT_MSG_TERMINATED) {
      ev.kind = Event::Kind::kEnd;
    } else {
      continue;
    }
    g_target->events.push_back(std::move(ev));
  }
  return 0;
}

// Call with g_mutex held.
void ensure_initialized() {
  if (g_rate > 0) return;
  g_rate = espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0, nullptr,
                             espeakINITIALIZE_PHONEME_EVENTS | espeakINITIALIZE_DONT_EXIT);
  if (g_rate <= 0)
    throw Error("espeak-ng: cannot initialize (is espeak-ng-data installed?)",
                ErrorCode::kInternal);
  espeak_SetSynthCallback(on_synth);
}

// Call with g_mutex held. espeak-ng 1.51 allocates a voice structure on every voice change that it
// never frees (found by fuzzing), so the voice is switched only when it differs from the last one.
void select_voice(const std::string& voice) {
  if (voice == g_voice) return;
  if (espeak_SetVoiceByName(voice.c_str()) != EE_OK)
    throw Error("espeak-ng: unknown voice '" + voice + "'", ErrorCode::kNotFound);
  g_voice = voice;
}

}  // namespace

int sample_rate() {
  std::lock_guard lock(g_mutex);
  ensure_initialized();
  return g_rate;
}

std::vector<std::string> phonemize(std::string_view text, const std::string& voice) {
  const std::string buffer(text);
  std::string out;
  {
    std::lock_guard lock(g_mutex);
    ensure_initialized();
    select_voice(voice);
    const void* p = buffer.c_str();
    while (p) {
      const char* ph = espeak_TextToPhonemes(&p, espeakCHARS_UTF8, ' ' << 8);
      if (ph) (out += ph) += ' ';
    }
  }
  std::vector<std::string> phones;
  std::istringstream in(out);
  for (std::string s; in >> s;) {
    if (s.front() == '(') continue;  // language switch markers such as "(fr)"
    phones.push_back(s);
  }
  return phones;
}

Synthesis synthesize(std::string_view text, const std::string& voice, int speed,
                     bool phoneme_input) {
  const std::string buffer(text);
  Synthesis out;
  std::lock_guard lock(g_mutex);
  ensure_initialized();
  select_voice(voice);
  espeak_SetParameter(espeakRATE, speed, 0);
  out.sample_rate = g_rate;
  g_target = &out;
  const espeak_ERROR err =
      espeak_Synth(buffer.c_str(), buffer.size() + 1, 0, POS_CHARACTER, 0,
                   espeakCHARS_UTF8 | (phoneme_input ? espeakPHONEMES : 0), nullptr, nullptr);
  g_target = nullptr;
  if (err != EE_OK) throw Error("espeak-ng: synthesis failed", ErrorCode::kInternal);
  return out;
}

}  // namespace facecast::viseme::detail::espeak
