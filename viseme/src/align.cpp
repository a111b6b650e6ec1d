// Forced alignment through espeak-ng speech and DTW: see docs/algorithms.md#forced-alignment.
#include "facecast/viseme/align.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "align_hmm.hpp"
#include "dtw.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "features.hpp"
#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme {
namespace {

using detail::Features;

constexpr double kPad = 0.10;     // seconds of context kept around the speech when cropping
constexpr double kMargin = 0.30;  // seconds of silence put around the synthesized speech

struct Speech {
  Features f;
  std::vector<bool> silent;
  std::size_t first = 0, last = 0;  // first and last non-silent frame
  /// Seconds from the first to the last non-silent frame.
  double seconds() const { return static_cast<double>(last - first + 1) * f.hop_seconds; }
};

std::pair<std::size_t, std::size_t> padded(const Speech& s) {
  const auto pad = static_cast<std::size_t>(kPad / s.f.hop_seconds);
  return {s.first > pad ? s.first - pad : 0, std::min(s.f.frames() - 1, s.last + pad)};
}

Speech analyze_speech(const std::vector<float>& samples, int rate, const AlignOptions& ao,
                      const char* what, double warp = 1.0) {
  Speech s;
  detail::FeatureConfig fc;
  fc.warp = warp;
  s.f = detail::compute_features(samples, rate, fc);
  s.silent = detail::silent_frames(s.f, ao.silence_range, ao.silence_max_db);
  const auto loud = std::find(s.silent.begin(), s.silent.end(), false);
  if (loud == s.silent.end()) throw Error(std::string(what) + " holds no speech (all silent)");
  s.first = static_cast<std::size_t>(loud - s.silent.begin());
  s.last = s.silent.size() - 1 -
           static_cast<std::size_t>(std::find(s.silent.rbegin(), s.silent.rend(), false) -
                                    s.silent.rbegin());
  // The statistics of the frames DTW reads: silence around the speech would dominate them.
  const auto [a, b] = padded(s);
  detail::normalize(s.f, a, b + 1);
  if (ao.deltas) detail::add_deltas(s.f);
  return s;
}

// Frames [a, b] of `s` as their own Features / silence flags.
Speech crop(const Speech& s, std::size_t a, std::size_t b) {
  Speech c;
  c.f.dims = s.f.dims;
  c.f.hop_seconds = s.f.hop_seconds;
  c.f.frame_seconds = s.f.frame_seconds;
  const auto d = static_cast<std::size_t>(s.f.dims);
  c.f.mfcc.assign(s.f.mfcc.begin() + static_cast<std::ptrdiff_t>(a * d),
                  s.f.mfcc.begin() + static_cast<std::ptrdiff_t>((b + 1) * d));
  c.f.energy_db.assign(s.f.energy_db.begin() + static_cast<std::ptrdiff_t>(a),
                       s.f.energy_db.begin() + static_cast<std::ptrdiff_t>(b + 1));
  c.silent.assign(s.silent.begin() + static_cast<std::ptrdiff_t>(a),
                  s.silent.begin() + static_cast<std::ptrdiff_t>(b + 1));
  return c;
}

// Synthesized-speech time -> audio time through the path. A time between synthesized frames j-1
// and j maps between the last audio frame matched to j-1 and the first matched to j, so a boundary
// next to a stretched pause lands at the pause's edge, not in its middle.
class TimeMap {
 public:
  TimeMap(const std::vector<std::pair<int, int>>& path, std::size_t x0, std::size_t y0,
          std::size_t m, const Features& f)
      : x0_(x0),
        y0_(y0),
        hop_(f.hop_seconds),
        half_(f.frame_seconds / 2),
        first_(m, 1e30),
        last_(m, -1e30) {
    for (const auto& [i, j] : path) {
      auto& lo = first_[static_cast<std::size_t>(j)];
      auto& hi = last_[static_cast<std::size_t>(j)];
      lo = std::min(lo, static_cast<double>(i));
      hi = std::max(hi, static_cast<double>(i));
    }
  }
  double operator()(double t) const {
    const double p = (t + kMargin - half_) / hop_ - static_cast<double>(y0_);
    const auto m = static_cast<long>(first_.size());
    if (m < 2) return (static_cast<double>(x0_) + (m == 1 ? first_[0] : 0.0)) * hop_ + half_;
    const long j = std::clamp(static_cast<long>(std::floor(p + 0.5)), 1L, m - 1);
    const double edge =
        (last_[static_cast<std::size_t>(j - 1)] + first_[static_cast<std::size_t>(j)]) / 2;
    const double frame = edge + (p - (static_cast<double>(j) - 0.5));
    return (frame + static_cast<double>(x0_)) * hop_ + half_;
  }

 private:
  std::size_t x0_, y0_;
  double hop_, half_;
  std::vector<double> first_, last_;
};

// Moves a boundary at audio time `t` to the strongest spectral/energy change within +- window,
// between `lo` and `hi`, with a penalty on the distance moved.
double refine(double t, double lo, double hi, const Speech& a, const std::vector<float>& change,
              float mean_change, const AlignOptions& ao) {
  const double hop = a.f.hop_seconds, half = a.f.frame_seconds / 2;
  const auto frame_of = [&](double s) { return (s - half) / hop; };
  const double centre = frame_of(t);
  const double reach = ao.refine_seconds / hop;
  const auto k0 = static_cast<long>(std::ceil(std::max(frame_of(lo) + 1, centre - reach)));
  const auto k1 = static_cast<long>(std::floor(std::min(frame_of(hi) - 1, centre + reach)));
  double best = -1e30, best_t = t;
  for (long k = std::max(1L, k0); k <= k1 && k + 1 < static_cast<long>(change.size()); ++k) {
    const double score = change[static_cast<std::size_t>(k)] -
                         ao.refine_weight * mean_change * std::abs(k - centre) / reach;
    if (score > best) best = score, best_t = static_cast<double>(k) * hop + half;
  }
  return best_t;
}

// Spectral change per frame: distance between the frames either side (energy column included,
// so onsets and closures count).
std::vector<float> spectral_change(const Features& f, float& mean) {
  std::vector<float> c(f.frames(), 0);
  double sum = 0;
  for (std::size_t k = 1; k + 1 < f.frames(); ++k) {
    float s = 0;
    for (int q = 0; q < f.dims; ++q) s += std::pow(f.row(k + 1)[q] - f.row(k - 1)[q], 2.0f);
    c[k] = std::sqrt(s);
    sum += c[k];
  }
  mean = static_cast<float>(sum / std::max<std::size_t>(1, f.frames()));
  return c;
}

// Silent runs of at least `min` seconds in the audio, as time spans.
std::vector<detail::Span> pauses(const Speech& a, double min) {
  std::vector<detail::Span> out;
  const double hop = a.f.hop_seconds, half = a.f.frame_seconds / 2;
  for (std::size_t i = 0; i < a.silent.size();) {
    if (!a.silent[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < a.silent.size() && a.silent[j]) ++j;
    if (static_cast<double>(j - i) * hop >= min)
      out.push_back({static_cast<double>(i) * hop + half, static_cast<double>(j - 1) * hop + half});
    i = j;
  }
  return out;
}

// Clears a pause of a unit's phones: a phone reaching into it keeps the side where more of it
// lies, a phone wholly inside it (a quiet fricative the silence test took for pause) moves after
// it, and as a word or syllable never spans a pause, the phones on the shorter side of it move
// across (packed at the pause's edge, each keeping up to kPacked of its length).
constexpr double kPacked = 0.03;  // seconds per moved phone at most

void clear_pause(detail::UnitTime& tu, const detail::Span& gap) {
  const auto packed = [](const detail::Span& p) { return std::min(kPacked, p.end - p.start); };
  for (auto& p : tu.phones) {
    if (p.start >= gap.end || p.end <= gap.start) continue;
    if (p.start >= gap.start && p.end <= gap.end)
      p = {gap.end, gap.end + packed(p)};
    else if (gap.start - p.start < p.end - gap.end)
      p.start = gap.end;
    else
      p.end = gap.start;
  }
  double before = 0, after = 0;
  std::size_t split = 0;  // phones [0, split) lie before the pause
  for (const auto& p : tu.phones) {
    if (p.end <= gap.start + 1e-9) {
      before += p.end - p.start;
      ++split;
    } else {
      after += p.end - p.start;
    }
  }
  if (split == tu.phones.size()) return;
  if (before < after) {
    double t = gap.end;
    for (std::size_t k = 0; k < split; ++k) {
      const double len = packed(tu.phones[k]);
      tu.phones[k] = {t, t + len};
      t += len;
    }
    // The phones after the pause make room, in order.
    for (std::size_t k = 0; k < tu.phones.size(); ++k) {
      auto& p = tu.phones[k];
      if (k > 0 && p.start < tu.phones[k - 1].end) {
        const double from = tu.phones[k - 1].end;
        p = {from, std::max(p.end, from + packed(p))};
      }
    }
  } else if (split > 0) {
    double t = gap.start;
    for (std::size_t k = tu.phones.size(); k-- > split;) {
      const double len = packed(tu.phones[k]);
      tu.phones[k] = {t - len, t};
      t -= len;
    }
    for (std::size_t k = split; k-- > 0 && tu.phones[k].end > t;)
      tu.phones[k] = {std::min(t, tu.phones[k].start), t}, t = tu.phones[k].start;
  }
}

detail::Timeline map_timeline(const detail::Timeline& synth, const TimeMap& map, const Speech& a,
                              const AlignOptions& ao, double duration) {
  float mean_change = 0;
  const std::vector<float> change = spectral_change(a.f, mean_change);
  detail::Timeline tl;
  tl.duration = duration;
  tl.units.resize(synth.units.size());
  // Phone starts in order (each unit's phones are contiguous in the synthesized timeline).
  double previous = 0;
  for (std::size_t u = 0; u < synth.units.size(); ++u) {
    const auto& su = synth.units[u];
    auto& tu = tl.units[u];
    for (std::size_t k = 0; k < su.phones.size(); ++k) {
      const double start = std::max(previous, map(su.phones[k].start));
      const double end = std::max(start, map(su.phones[k].end));
      tu.phones.push_back({start, end});
    }
    for (std::size_t k = 0; k < tu.phones.size(); ++k) {
      auto& p = tu.phones[k];
      const double hi = k + 1 < tu.phones.size() ? tu.phones[k + 1].end : p.end + ao.refine_seconds;
      const double refined =
          !ao.refine ? p.start
                     : refine(p.start, previous, std::max(hi, p.start), a, change, mean_change, ao);
      // Phones that touch in the synthesized speech keep touching: the boundary moves for both.
      if (k > 0 && std::abs(su.phones[k - 1].end - su.phones[k].start) < 1e-9)
        tu.phones[k - 1].end = refined;
      p.start = refined;
      p.end = std::max(p.end, p.start);
      previous = p.start;
    }
    if (!tu.phones.empty()) previous = std::max(previous, tu.phones.back().start);
  }
  // Silences of the audio become rest: phones are clipped out of every pause.
  for (const detail::Span& gap : pauses(a, ao.min_pause))
    for (auto& tu : tl.units) clear_pause(tu, gap);
  for (std::size_t u = 0; u < tl.units.size(); ++u) {
    auto& tu = tl.units[u];
    if (tu.phones.empty()) {
      const double t = map(synth.units[u].span.start);
      tu.span = {t, t};
    } else {
      tu.span = {tu.phones.front().start, tu.phones.back().end};
    }
  }
  return tl;
}

}  // namespace

AlignOptions load_align_options() {
  ConfigReader c = ConfigReader::open(config_path("viseme/align.json"));
  AlignOptions o;
  c.read_choice("english", o.english,
                {{"hmm", AlignOptions::Backend::kHmm}, {"dtw", AlignOptions::Backend::kDtw}})
      .read_choice(
          "hmm_phones", o.hmm_phones,
          {{"espeak", AlignOptions::HmmPhones::kEspeak}, {"hmm", AlignOptions::HmmPhones::kHmm}})
      .read("min_speed", o.min_speed)
      .read("max_speed", o.max_speed)
      .read("band", o.band)
      .read("band_frames", o.band_frames)
      .read("refine_seconds", o.refine_seconds)
      .read("refine_weight", o.refine_weight)
      .read("min_pause", o.min_pause)
      .read("silence_range", o.silence_range)
      .read("silence_max_db", o.silence_max_db)
      .read("hold_penalty", o.hold_penalty)
      .read("deltas", o.deltas)
      .read("refine", o.refine)
      .read("warps", o.warps)
      .read("max_seconds", o.max_seconds)
      .read("stream_lag", o.stream_lag);
  if (o.stream_lag < 0.03 || o.stream_lag > 2)
    c.fail("stream_lag", "must lie within 0.03..2 seconds");
  if (o.warps.empty()) c.fail("warps", "must list at least one warp (1.0: none)");
  if (o.min_speed < 80 || o.max_speed > 450 || o.min_speed > o.max_speed)
    c.fail("min_speed", "min_speed..max_speed must lie within 80..450");
  c.reject_unknown();
  return o;
}

Utterance align(std::string_view text, const Audio& audio, const Options& options,
                const AlignOptions& ao) {
  if (audio.seconds() > ao.max_seconds)
    throw Error("alignment: " + std::to_string(static_cast<int>(audio.seconds())) +
                    " s of audio is longer than the limit of " +
                    std::to_string(static_cast<int>(ao.max_seconds)) +
                    " s (align.max_seconds); align it in parts",
                ErrorCode::kLimit);
  const Speech a = analyze_speech(audio.samples, audio.sample_rate, ao, "the audio");
  Options o = options;
  o.timing = Timing::kTts;
  const auto finish = [&](const detail::Plan& plan, detail::Timeline tl) {
    tl.pcm = to_pcm16(audio.samples);
    tl.sample_rate = audio.sample_rate;
    const VisemeSet set = o.set.value_or(plan.has_zh ? VisemeSet::kZh15 : VisemeSet::kOculus);
    Utterance u = detail::assemble(plan, tl, std::string(text), set);
    u.duration = audio.seconds();
    return u;
  };
  // English: the HMM when its model is installed (docs/algorithms.md#forced-alignment); DTW when
  // its search does not reach the transcript's end.
  if (ao.english == AlignOptions::Backend::kHmm && detail::hmm_installed()) {
    detail::Plan plan = detail::make_plan(text, o);
    if (plan.units.empty()) throw Error("alignment: the text has nothing to say");
    if (detail::hmm_applies(plan)) {
      const detail::Timeline synth = detail::time_by_tts(plan, o);
      if (auto tl = detail::align_hmm(plan, synth, audio, ao)) return finish(plan, std::move(*tl));
    }
  }
  // Speak the text twice: the second time at the pace that makes its speech as long as the audio's,
  // so DTW's 2:1 slope limit has room on both sides.
  detail::Plan plan;
  detail::Timeline synth;
  Speech s;
  for (int pass = 0; pass < 2; ++pass) {
    plan = detail::make_plan(text, o);
    if (plan.units.empty()) throw Error("alignment: the text has nothing to say");
    synth = detail::time_by_tts(plan, o);
    // Silent margins around the synthesized speech, so DTW can hold them against leading or
    // trailing noise of any length in the audio.
    std::vector<int16_t> pcm(static_cast<std::size_t>(kMargin * synth.sample_rate), 0);
    pcm.insert(pcm.end(), synth.pcm.begin(), synth.pcm.end());
    pcm.resize(pcm.size() + static_cast<std::size_t>(kMargin * synth.sample_rate), 0);
    const Audio spoken = audio_from_pcm16(pcm, synth.sample_rate, {audio.sample_rate});
    s = analyze_speech(spoken.samples, spoken.sample_rate, ao, "the synthesized text");
    const double ratio = s.seconds() / a.seconds();
    if (pass == 0)
      o.espeak_speed = std::clamp(static_cast<int>(std::lround(o.espeak_speed * ratio)),
                                  ao.min_speed, ao.max_speed);
  }
  const auto [x0, x1] = padded(a);
  const auto [y0, y1] = padded(s);
  const Speech sc = crop(s, y0, y1);
  // Vocal tract length normalisation: the audio's features under each frequency warp; the warp
  // whose DTW path costs least wins (docs/algorithms.md#forced-alignment).
  std::vector<std::pair<int, int>> path;
  double best = std::numeric_limits<double>::infinity();
  for (double warp : ao.warps) {
    const Speech aw =
        warp == 1.0 ? a : analyze_speech(audio.samples, audio.sample_rate, ao, "the audio", warp);
    const Speech ac = crop(aw, x0, x1);
    double cost = 0;
    auto p = detail::dtw_path(ac.f, sc.f, ac.silent, sc.silent,
                              {ao.band, ao.band_frames, 600, ao.hold_penalty}, &cost);
    if (cost < best) best = cost, path = std::move(p);
  }
  const TimeMap map(path, x0, y0, sc.f.frames(), a.f);
  return finish(plan, map_timeline(synth, map, a, ao, audio.seconds()));
}

}  // namespace facecast::viseme
