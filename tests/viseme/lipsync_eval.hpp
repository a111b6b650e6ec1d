#pragma once
// Scoring of the audio-only lip-sync against the text path on the true timing, shared by
// tests/viseme/test_lipsync.cpp and bench/bench_lipsync.cpp (see there). Header-only.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "align_cases.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/core/config.hpp"
#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/lipsync.hpp"

namespace facecast::test {

// Pearson correlation accumulated over pooled samples.
struct Correlation {
  double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  void add(double x, double y) {
    n += 1, sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
  }
  Correlation& operator+=(const Correlation& o) {
    n += o.n, sx += o.sx, sy += o.sy, sxx += o.sxx, syy += o.syy, sxy += o.sxy;
    return *this;
  }
  double value() const {
    const double cov = sxy - sx * sy / n, vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
    return cov / std::sqrt(std::max(vx * vy, 1e-30));
  }
};

struct LipsyncScore {
  std::size_t frames = 0, correct = 0, baseline_correct = 0;
  Correlation jaw, baseline_jaw;
  LipsyncScore& operator+=(const LipsyncScore& o) {
    frames += o.frames, correct += o.correct, baseline_correct += o.baseline_correct;
    jaw += o.jaw, baseline_jaw += o.baseline_jaw;
    return *this;
  }
  double accuracy() const { return static_cast<double>(correct) / static_cast<double>(frames); }
  double baseline_accuracy() const {
    return static_cast<double>(baseline_correct) / static_cast<double>(frames);
  }
  double correlation() const { return jaw.value(); }
  double baseline_correlation() const { return baseline_jaw.value(); }
};

// Oculus viseme -> sound class, from the generator's table (configs/viseme/lipsync_training.json).
inline const std::map<std::string, viseme::SoundClass>& class_of_oculus() {
  static const std::map<std::string, viseme::SoundClass> m = [] {
    std::map<std::string, viseme::SoundClass> out;
    const auto j = load_json(config_path("viseme/lipsync_training.json"));
    for (const auto& [name, list] : j.at("classes").items())
      for (const auto& v : list) out[v.get<std::string>()] = viseme::parse_sound_class(name);
    return out;
  }();
  return m;
}

inline viseme::SoundClass class_at(const std::vector<viseme::VisemeEvent>& events, double t) {
  for (const auto& e : events)
    if (e.start <= t && t < e.end) {
      const auto it = class_of_oculus().find(e.viseme);
      return it == class_of_oculus().end() ? viseme::SoundClass::kSilence : it->second;
    }
  return viseme::SoundClass::kSilence;
}

inline const anim::Mapping& arkit_mapping() {
  static const anim::Mapping m = anim::Mapping::for_rig(
      {"jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthStretchLeft",
       "mouthStretchRight", "mouthSmileLeft", "mouthSmileRight", "mouthLowerDownLeft",
       "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "mouthRollLower",
       "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft", "mouthPressRight",
       "tongueOut"});
  return m;
}

inline LipsyncScore score_lipsync(const AlignCase& c, const viseme::LipsyncOptions& lo) {
  using viseme::SoundClass;
  const viseme::Audio audio = viseme::read_audio(c.audio);
  viseme::Options o;
  o.set = viseme::VisemeSet::kOculus;
  const viseme::Utterance hyp = viseme::lipsync(audio, o, lo);
  // The analyser's frames again, for the baseline (same silence and closure decisions).
  viseme::LipsyncAnalyzer analyzer(audio.sample_rate, lo);
  std::vector<viseme::LipsyncFrame> frames;
  analyzer.push(audio.samples.data(), audio.samples.size(), frames);
  analyzer.finish(frames);
  viseme::Utterance truth;
  truth.set = viseme::VisemeSet::kOculus;
  truth.duration = audio.seconds();
  truth.visemes = c.visemes;
  anim::AnimOptions ao;
  ao.idle = false;
  const anim::Performance ptrue(truth, arkit_mapping(), ao), phyp(hyp, arkit_mapping(), ao);
  LipsyncScore s;
  double first = 1e9, last = 0;
  for (const auto& v : c.visemes)
    if (class_at(c.visemes, 0.5 * (v.start + v.end)) != SoundClass::kSilence)
      first = std::min(first, v.start), last = std::max(last, v.end);
  for (const auto& f : frames) {
    if (f.time < first - 0.1 || f.time > last + 0.1) continue;
    const SoundClass t = class_at(c.visemes, f.time), h = class_at(hyp.visemes, f.time);
    const SoundClass b =
        f.cls == SoundClass::kSilence || f.cls == SoundClass::kClosure ? f.cls : SoundClass::kA;
    ++s.frames;
    s.correct += t == h;
    s.baseline_correct += t == b;
  }
  std::vector<float> wt(arkit_mapping().shape_names().size()), wh(wt.size());
  double loud = 0;
  std::size_t k = 0;
  for (int i = 0; i / 60.0 < audio.seconds(); ++i) {
    const double t = i / 60.0;
    ptrue.sample(t, wt);
    phyp.sample(t, wh);
    while (k + 1 < frames.size() && frames[k + 1].time <= t) ++k;
    const bool quiet = frames.empty() || frames[k].cls == SoundClass::kSilence ||
                       frames[k].cls == SoundClass::kClosure;
    loud += 0.5 * ((quiet ? 0.0 : frames[k].loudness) - loud);  // one-pole, about 30 ms
    s.jaw.add(wt[0], wh[0]);
    s.baseline_jaw.add(wt[0], loud);
  }
  return s;
}

}  // namespace facecast::test
