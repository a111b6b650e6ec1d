// The streaming audio-only lip-sync analyser: see docs/algorithms.md#audio-lipsync.
#include "facecast/viseme/lipsync.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <sstream>

#include "facecast/core/error.hpp"
#include "lipsync_features.hpp"
#include "tables.hpp"

namespace facecast::viseme {

struct LipsyncAnalyzer::Impl {
  struct Scored {
    detail::FeatureFrame f;
    std::array<double, kSoundClasses> ll{};
  };
  Impl(int sample_rate, const LipsyncOptions& o, const LipsyncTemplates& t)
      : options(o), templates(t), features(sample_rate, o, t.cepstral_mean), rate(sample_rate) {}

  LipsyncOptions options;
  const LipsyncTemplates& templates;
  detail::FeatureStream features;
  int rate;
  std::deque<Scored> window;  // context + the decided frame + look-ahead
  std::size_t decided = 0;    // index in `window` of the next frame to decide
  SoundClass current = SoundClass::kSilence;
  double last_sounding = -1e9;                // time of the last sounding frame
  float last_sounding_level = -100;           // its level, dB re the speech level
  static constexpr std::size_t kRecent = 10;  // sounding frames (100 ms) a murmur's dip looks back
  std::deque<float> recent;                   // their levels, dB re the speech level
  std::vector<detail::FeatureFrame> scratch;

  void add(const detail::FeatureFrame& f, std::vector<LipsyncFrame>& out) {
    Scored s{f, {}};
    if (f.silent)
      s.ll.fill(0);
    else
      templates.score(f.x.data(), s.ll);
    window.push_back(s);
    while (decided + static_cast<std::size_t>(options.lookahead_frames) < window.size())
      out.push_back(decide());
  }

  // The class of window[decided]:
  // - silent (by level): a closure when it follows, within closure_max, a sounding run that was
  //   loud just before (an abrupt stop, not a phrase's fading end) and was not frication (a pause
  //   after /s/); else rest;
  // - sounding: the class whose log-likelihood summed over the context and look-ahead is highest
  //   (with its prior), changing only by `switch_margin` over the current class; a nasal murmur or
  //   voiced closure (voiced, its energy low in frequency, a dip below the loudest frame around
  //   it) shows the lips closed unless "consonant" (n, ng) beats "closure" by closure_bias.
  LipsyncFrame decide() {
    const Scored& s = window[decided];
    LipsyncFrame out{s.f.time, SoundClass::kSilence, s.f.loudness, s.f.silent, s.f.openness};
    if (s.f.silent) {
      const bool after_voice = s.f.time - last_sounding <= options.closure_max;
      const bool stop =
          current == SoundClass::kClosure ||
          (current != SoundClass::kSilence && current != SoundClass::kFricative &&
           current != SoundClass::kLabiodental && last_sounding_level >= options.closure_entry_db);
      out.cls = after_voice && stop ? SoundClass::kClosure : SoundClass::kSilence;
      // Before a labial release: the look-ahead's first sounding frames (the burst of /p/ /b/
      // after a pause, learned as "closure") score closure above every other class.
      if (out.cls == SoundClass::kSilence) {
        std::array<double, kSoundClasses> onset{};
        int n = 0;
        for (std::size_t i = decided + 1; i < window.size() && n < 2; ++i)
          if (!window[i].f.silent) {
            ++n;
            for (int k = 1; k < kSoundClasses; ++k)
              onset[static_cast<std::size_t>(k)] += window[i].ll[static_cast<std::size_t>(k)];
          }
        const auto best = std::max_element(onset.begin() + 1, onset.end());
        if (n > 0 && best - onset.begin() == static_cast<std::ptrdiff_t>(SoundClass::kClosure))
          out.cls = SoundClass::kClosure;
      }
    } else {
      std::array<double, kSoundClasses> sum{};
      const std::size_t from = decided > static_cast<std::size_t>(options.context_frames)
                                   ? decided - static_cast<std::size_t>(options.context_frames)
                                   : 0;
      float loudest = s.f.level;
      for (float l : recent) loudest = std::max(loudest, l);
      for (std::size_t i = from; i < window.size(); ++i)
        if (!window[i].f.silent) {
          loudest = std::max(loudest, window[i].f.level);
          for (int k = 1; k < kSoundClasses; ++k)
            sum[static_cast<std::size_t>(k)] += window[i].ll[static_cast<std::size_t>(k)];
        }
      const auto closure = static_cast<std::size_t>(SoundClass::kClosure),
                 consonant = static_cast<std::size_t>(SoundClass::kConsonant);
      const auto murmur_like = [&](const detail::FeatureFrame& f) {
        return !f.silent && f.settled && f.voicing >= options.murmur_voicing &&
               f.nasal >= options.murmur_nasal_db && f.dull >= options.murmur_dull_db &&
               f.openness <= options.murmur_openness && f.level <= loudest - options.murmur_dip_db;
      };
      // A murmur lasts: it starts only where the next frame is one too.
      const bool murmur =
          murmur_like(s.f) && (current == SoundClass::kClosure ||
                               (decided + 1 < window.size() && murmur_like(window[decided + 1].f)));
      // Outside a murmur the closure templates (learned on synthetic murmurs and bursts) are
      // trusted only on weak frames (a burst, a voiced closure): loud, they fire on /r/ /l/.
      int best = murmur || s.f.level <= options.burst_max_db ? 1 : 2;
      for (int k = best; k < kSoundClasses; ++k) {
        sum[static_cast<std::size_t>(k)] += templates.log_prior[static_cast<std::size_t>(k)];
        if (sum[static_cast<std::size_t>(k)] > sum[static_cast<std::size_t>(best)]) best = k;
      }
      const auto cur = static_cast<std::size_t>(current);
      const bool keep = current != SoundClass::kSilence && current != SoundClass::kClosure &&
                        sum[static_cast<std::size_t>(best)] - sum[cur] < options.switch_margin;
      out.cls = keep ? current : static_cast<SoundClass>(best);
      if (murmur && sum[closure] + options.closure_bias >= sum[consonant])
        out.cls = SoundClass::kClosure;
      // f/v: weak frication the templates put with /s/ /th/ or the stops unless it leads.
      const auto labio = static_cast<std::size_t>(SoundClass::kLabiodental);
      if ((out.cls == SoundClass::kFricative || out.cls == SoundClass::kConsonant) &&
          s.f.level <= options.labiodental_max_db &&
          sum[labio] + options.labiodental_bias >= sum[static_cast<std::size_t>(out.cls)])
        out.cls = SoundClass::kLabiodental;
      last_sounding = s.f.time;
      last_sounding_level = s.f.level;
      recent.push_back(s.f.level);
      if (recent.size() > kRecent) recent.pop_front();
    }
    current = out.cls;
    ++decided;
    // Keep only the context the next decision needs.
    while (decided > static_cast<std::size_t>(options.context_frames)) {
      window.pop_front();
      --decided;
    }
    return out;
  }
};

LipsyncAnalyzer::LipsyncAnalyzer(int rate, const LipsyncOptions& o, const LipsyncTemplates& t)
    : impl_(std::make_unique<Impl>(rate, o, t)) {
  if (t.dims == 0) throw Error("lip-sync: templates are empty");
}
LipsyncAnalyzer::~LipsyncAnalyzer() = default;
LipsyncAnalyzer::LipsyncAnalyzer(LipsyncAnalyzer&&) noexcept = default;
LipsyncAnalyzer& LipsyncAnalyzer::operator=(LipsyncAnalyzer&&) noexcept = default;

void LipsyncAnalyzer::push(const float* samples, std::size_t n, std::vector<LipsyncFrame>& out) {
  auto& s = impl_->scratch;
  s.clear();
  impl_->features.push(samples, n, s);
  for (const auto& f : s) impl_->add(f, out);
}

void LipsyncAnalyzer::finish(std::vector<LipsyncFrame>& out) {
  auto& s = impl_->scratch;
  s.clear();
  impl_->features.finish(s);
  for (const auto& f : s) impl_->add(f, out);
  while (impl_->decided < impl_->window.size()) out.push_back(impl_->decide());
}

double LipsyncAnalyzer::latency() const {
  // A frame is scored when the next one is complete (deltas), decided lookahead frames later.
  const auto& f = impl_->features;
  return f.window_seconds() / 2 + (impl_->options.lookahead_frames + 1) * f.hop_seconds();
}

int LipsyncAnalyzer::sample_rate() const {
  return impl_->rate;
}

void append_lipsync_events(const std::vector<LipsyncFrame>& frames, VisemeSet set,
                           const LipsyncOptions& o, double hop, std::vector<VisemeEvent>& events) {
  for (const LipsyncFrame& f : frames) {
    const std::string& name = o.viseme(set, f.cls);
    const bool sounding = f.cls != SoundClass::kSilence;
    // The jaw: loudness, scaled for vowels by the first formant's openness (x 1 at 0.5).
    const bool vowel = f.cls >= SoundClass::kA && f.cls <= SoundClass::kU;
    const double open =
        vowel ? 1 - o.jaw_openness + o.jaw_openness * 2 * static_cast<double>(f.openness) : 1.0;
    const double strength =
        sounding ? o.jaw_min + (o.jaw_max - o.jaw_min) *
                                   std::min(1.0, static_cast<double>(f.loudness) * open)
                 : 1.0;
    const double start = f.time - hop / 2, end = f.time + hop / 2;
    if (!events.empty() && events.back().viseme == name &&
        std::abs(events.back().end - start) < hop / 4) {
      VisemeEvent& e = events.back();
      const double n = std::max(1.0, std::round((e.end - e.start) / hop));
      e.strength = (e.strength * n + strength) / (n + 1);
      e.end = end;
    } else {
      events.push_back({name, std::max(0.0, start), end, strength});
    }
  }
}

std::vector<ExpressionEvent> parse_expression_tags(std::string_view tags, double now) {
  std::vector<ExpressionEvent> out;
  std::istringstream in{std::string(tags)};
  for (std::string tok; in >> tok;) {
    const auto close = tok.find(')');
    const auto c1 = tok.find(','), c2 = tok.find(',', c1 == std::string::npos ? 0 : c1 + 1);
    const bool timed = close != std::string::npos && tok.compare(close, 2, ")@") == 0;
    if (tok.front() != '(' || close == std::string::npos || c1 == std::string::npos ||
        c2 == std::string::npos || c2 > close || (!timed && (now < 0 || close + 1 != tok.size())))
      throw Error("expression tag '" + tok + "': expected (name,intensity,seconds)" +
                  (now < 0 ? "@time" : "[@time]"));
    ExpressionEvent e;
    e.name = tok.substr(1, c1 - 1);
    const auto& known = detail::tables().expressions;
    if (std::find(known.begin(), known.end(), e.name) == known.end())
      throw Error("expression tag '" + tok + "': unknown expression '" + e.name +
                  "' (names are in configs/viseme/expressions.json)");
    try {
      e.intensity = std::stoi(tok.substr(c1 + 1, c2 - c1 - 1));
      e.ramp = std::stod(tok.substr(c2 + 1, close - c2 - 1));
      e.start = timed ? std::stod(tok.substr(close + 2)) : now;
    } catch (const std::exception&) {
      throw Error("expression tag '" + tok + "': intensity, seconds and time must be numbers");
    }
    if (e.intensity < 0 || e.intensity > 63 || !(e.ramp >= 0) || !(e.start >= 0))
      throw Error("expression tag '" + tok + "': intensity 0..63, seconds and time >= 0");
    out.push_back(std::move(e));
  }
  return out;
}

Utterance lipsync(const Audio& audio, const Options& options, const LipsyncOptions& lo,
                  std::string_view tags) {
  LipsyncAnalyzer analyzer(audio.sample_rate, lo);
  std::vector<LipsyncFrame> frames;
  analyzer.push(audio.samples.data(), audio.samples.size(), frames);
  analyzer.finish(frames);
  Utterance u;
  u.set = options.set.value_or(VisemeSet::kOculus);
  u.duration = audio.seconds();
  append_lipsync_events(frames, u.set, lo,
                        frames.size() > 1 ? frames[1].time - frames[0].time : 0.01, u.visemes);
  const bool speech = std::any_of(frames.begin(), frames.end(), [](const LipsyncFrame& f) {
    return f.cls != SoundClass::kSilence && f.cls != SoundClass::kClosure;
  });
  if (!speech) throw Error("lip-sync: the audio holds no speech (all silent)");
  for (auto& e : u.visemes) e.end = std::min(e.end, u.duration);
  u.expressions = parse_expression_tags(tags);
  u.pcm = to_pcm16(audio.samples);
  u.sample_rate = audio.sample_rate;
  return u;
}

}  // namespace facecast::viseme
