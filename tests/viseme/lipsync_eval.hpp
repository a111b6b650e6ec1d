#pragma once
// Scoring of the audio-only lip-sync against the text path's visemes (true timing on synthetic
// speech, the English HMM alignment's on human speech), shared by tests/viseme/test_lipsync.cpp
// and bench/bench_lipsync.cpp. Header-only.
//
// Figures, each beside the "mouth follows loudness" baseline (the level's silence decision alone:
// a silence within closure_max after sound is a closure, every sounding frame "a", jaw = the
// loudness smoothed by a one-pole filter of about 30 ms):
// - class accuracy: frames whose class equals the truth's, over the frames from 0.1 s before the
//   first sounding viseme to 0.1 s after the last; the labiodental class counts as "fricative" so
//   the figure compares with the 9-class analyser of before;
// - closure recall: the truth's p/b/m segments (Oculus PP) holding at least one closure frame
//   (+- kTolerance, the reference's boundary error); closure precision: the analyser's closure runs
//   (consecutive closure frames) overlapping a p/b/m segment (+- kTolerance); closures in pauses:
//   the share of those runs lying in the truth's rest (touching no p/b/m);
// - FF recall: the truth's f/v segments holding a labiodental frame (+- kTolerance); FF precision:
//   the labiodental runs overlapping an f/v segment; the baseline has no such class;
// - jaw correlation: Pearson of jawOpen at 60 fps against the truth's curve (same rig mapping).
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "align_cases.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/core/config.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "human_cases.hpp"

namespace facecast::test {

inline constexpr double kTolerance = 0.02;  // seconds, either side of a reference segment

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

inline double ratio(std::size_t a, std::size_t b) {
  return b == 0 ? 0.0 : static_cast<double>(a) / static_cast<double>(b);
}

struct LipsyncScore {
  std::size_t frames = 0, correct = 0, baseline_correct = 0;
  std::size_t pbm = 0, pbm_closed = 0, baseline_pbm_closed = 0;                    // p/b/m segments
  std::size_t runs = 0, runs_true = 0, baseline_runs = 0, baseline_runs_true = 0;  // closures
  std::size_t runs_pause = 0, baseline_runs_pause = 0;              // closure runs inside a pause
  std::size_t ff = 0, ff_shown = 0, ff_runs = 0, ff_runs_true = 0;  // f/v segments, FF runs
  Correlation jaw, baseline_jaw;
  LipsyncScore& operator+=(const LipsyncScore& o) {
    frames += o.frames, correct += o.correct, baseline_correct += o.baseline_correct;
    pbm += o.pbm, pbm_closed += o.pbm_closed, baseline_pbm_closed += o.baseline_pbm_closed;
    runs += o.runs, runs_true += o.runs_true, baseline_runs += o.baseline_runs,
        baseline_runs_true += o.baseline_runs_true;
    runs_pause += o.runs_pause, baseline_runs_pause += o.baseline_runs_pause;
    ff += o.ff, ff_shown += o.ff_shown, ff_runs += o.ff_runs, ff_runs_true += o.ff_runs_true;
    jaw += o.jaw, baseline_jaw += o.baseline_jaw;
    return *this;
  }
  double accuracy() const { return ratio(correct, frames); }
  double baseline_accuracy() const { return ratio(baseline_correct, frames); }
  double closure_recall() const { return ratio(pbm_closed, pbm); }
  double baseline_closure_recall() const { return ratio(baseline_pbm_closed, pbm); }
  double closure_precision() const { return ratio(runs_true, runs); }
  double baseline_closure_precision() const { return ratio(baseline_runs_true, baseline_runs); }
  double ff_recall() const { return ratio(ff_shown, ff); }
  double closure_in_pause() const { return ratio(runs_pause, runs); }
  double baseline_closure_in_pause() const { return ratio(baseline_runs_pause, baseline_runs); }
  double ff_precision() const { return ratio(ff_runs_true, ff_runs); }
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

inline bool is_labiodental(viseme::SoundClass c) {
  return viseme::to_string(c) == "labiodental";
}
// The 9 classes of the analyser before the labiodental class: f/v count as fricatives.
inline viseme::SoundClass folded(viseme::SoundClass c) {
  return is_labiodental(c) ? viseme::SoundClass::kFricative : c;
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

// Segments of `truth` showing viseme `name`: how many hold a frame with `shown` true (+-
// kTolerance).
template <class Pred>
std::pair<std::size_t, std::size_t> segments_shown(const std::vector<viseme::VisemeEvent>& truth,
                                                   const std::string& name,
                                                   const std::vector<double>& times, Pred shown) {
  std::size_t n = 0, hit = 0;
  for (const auto& e : truth) {
    if (e.viseme != name) continue;
    ++n;
    for (std::size_t i = 0; i < times.size(); ++i)
      if (times[i] >= e.start - kTolerance && times[i] <= e.end + kTolerance && shown(i)) {
        ++hit;
        break;
      }
  }
  return {n, hit};
}

// Runs of consecutive flagged frames, and how many overlap a segment of viseme `name` (+-
// kTolerance).
inline std::pair<std::size_t, std::size_t> runs_on(const std::vector<viseme::VisemeEvent>& truth,
                                                   const std::string& name,
                                                   const std::vector<double>& times,
                                                   const std::vector<bool>& closed) {
  std::size_t runs = 0, good = 0;
  for (std::size_t i = 0; i < times.size();) {
    if (!closed[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < times.size() && closed[j + 1]) ++j;
    ++runs;
    const double a = times[i], b = times[j];
    good += std::any_of(truth.begin(), truth.end(), [&](const viseme::VisemeEvent& e) {
      return e.viseme == name && a <= e.end + kTolerance && b >= e.start - kTolerance;
    });
    i = j + 1;
  }
  return {runs, good};
}

// Flagged runs whose middle lies in the truth's rest (a pause) and that touch no p/b/m segment.
inline std::size_t runs_in_pause(const std::vector<viseme::VisemeEvent>& truth,
                                 const std::vector<double>& times, const std::vector<bool>& flag) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < times.size();) {
    if (!flag[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < times.size() && flag[j + 1]) ++j;
    const double a = times[i], b = times[j];
    const bool pp = std::any_of(truth.begin(), truth.end(), [&](const viseme::VisemeEvent& e) {
      return e.viseme == "PP" && a <= e.end + kTolerance && b >= e.start - kTolerance;
    });
    n += !pp && class_at(truth, times[(i + j) / 2]) == viseme::SoundClass::kSilence;
    i = j + 1;
  }
  return n;
}

/// The score of the analyser on `audio` against `truth` (Oculus visemes on the reference timing),
/// counting only what lies after `from` seconds.
inline LipsyncScore score_lipsync(const viseme::Audio& audio,
                                  const std::vector<viseme::VisemeEvent>& truth,
                                  const viseme::LipsyncOptions& lo, double from = 0) {
  using viseme::SoundClass;
  viseme::Options o;
  o.set = viseme::VisemeSet::kOculus;
  const viseme::Utterance hyp = viseme::lipsync(audio, o, lo);
  viseme::LipsyncAnalyzer analyzer(audio.sample_rate, lo);
  std::vector<viseme::LipsyncFrame> frames;
  analyzer.push(audio.samples.data(), audio.samples.size(), frames);
  analyzer.finish(frames);
  // The baseline's classes from the level decision alone (the analyser before it looked at the
  // spectrum for closures).
  std::vector<SoundClass> base(frames.size());
  double last_sound = -1e9;
  SoundClass prev = SoundClass::kSilence;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].silent)
      base[i] = frames[i].time - last_sound <= lo.closure_max && prev != SoundClass::kSilence
                    ? SoundClass::kClosure
                    : SoundClass::kSilence;
    else
      base[i] = SoundClass::kA, last_sound = frames[i].time;
    prev = base[i];
  }
  viseme::Utterance ref;
  ref.set = viseme::VisemeSet::kOculus;
  ref.duration = audio.seconds();
  ref.visemes = truth;
  anim::AnimOptions ao;
  ao.idle = false;
  const anim::Performance ptrue(ref, arkit_mapping(), ao), phyp(hyp, arkit_mapping(), ao);
  LipsyncScore s;
  double first = 1e9, last = 0;
  for (const auto& v : truth)
    if (class_at(truth, 0.5 * (v.start + v.end)) != SoundClass::kSilence)
      first = std::min(first, v.start), last = std::max(last, v.end);
  std::vector<double> times;
  std::vector<bool> closed, base_closed, labio;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto& f = frames[i];
    if (f.time < from) continue;
    times.push_back(f.time);
    closed.push_back(f.cls == SoundClass::kClosure);
    base_closed.push_back(base[i] == SoundClass::kClosure);
    labio.push_back(is_labiodental(f.cls));
    if (f.time < first - 0.1 || f.time > last + 0.1) continue;
    const SoundClass t = folded(class_at(truth, f.time));
    ++s.frames;
    s.correct += t == folded(f.cls);
    s.baseline_correct += t == base[i];
  }
  std::tie(s.pbm, s.pbm_closed) =
      segments_shown(truth, "PP", times, [&](std::size_t i) { return closed[i]; });
  s.baseline_pbm_closed =
      segments_shown(truth, "PP", times, [&](std::size_t i) { return base_closed[i]; }).second;
  std::tie(s.runs, s.runs_true) = runs_on(truth, "PP", times, closed);
  std::tie(s.baseline_runs, s.baseline_runs_true) = runs_on(truth, "PP", times, base_closed);
  std::tie(s.ff_runs, s.ff_runs_true) = runs_on(truth, "FF", times, labio);
  s.runs_pause = runs_in_pause(truth, times, closed);
  s.baseline_runs_pause = runs_in_pause(truth, times, base_closed);
  std::tie(s.ff, s.ff_shown) =
      segments_shown(truth, "FF", times, [&](std::size_t i) { return labio[i]; });
  std::vector<float> wt(arkit_mapping().shape_names().size()), wh(wt.size());
  double loud = 0;
  std::size_t k = 0;
  for (int i = 0; i / 60.0 < audio.seconds(); ++i) {
    const double t = i / 60.0;
    while (k + 1 < frames.size() && frames[k + 1].time <= t) ++k;
    const bool quiet = frames.empty() || frames[k].silent;
    loud += 0.5 * ((quiet ? 0.0 : frames[k].loudness) - loud);  // one-pole, about 30 ms
    if (t < from) continue;
    ptrue.sample(t, wt);
    phyp.sample(t, wh);
    s.jaw.add(wt[0], wh[0]);
    s.baseline_jaw.add(wt[0], loud);
  }
  return s;
}

inline LipsyncScore score_lipsync(const AlignCase& c, const viseme::LipsyncOptions& lo) {
  return score_lipsync(viseme::read_audio(c.audio), c.visemes, lo);
}

/// Human speech with its reference: the text path's Oculus visemes on the English HMM alignment
/// of the transcript (phone times about 15 ms from hand labels, docs/benchmarks.md).
struct HumanLipsyncCase {
  std::string name;
  viseme::Audio audio;
  std::vector<viseme::VisemeEvent> truth;
};

/// The development recordings of tests/viseme/eval/human_words.tsv (alsa-utils,
/// pocketsphinx-testdata; never librivox/ or cards/). Empty when a recording is missing.
inline std::vector<HumanLipsyncCase> human_lipsync_cases(const std::filesystem::path& tsv) {
  std::vector<HumanLipsyncCase> out;
  for (const AlignCase& c : human_cases(tsv)) {
    if (!std::filesystem::exists(c.audio)) return {};
    HumanLipsyncCase h{c.name, human_audio(c), {}};
    viseme::Options o;
    o.set = viseme::VisemeSet::kOculus;
    h.truth = viseme::align(c.text, h.audio, o).visemes;
    out.push_back(std::move(h));
  }
  return out;
}

}  // namespace facecast::test
