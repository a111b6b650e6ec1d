// facecast_viseme_lipsyncgen OUT: learns the audio-only lip-sync class templates from espeak-ng
// speech (configs/viseme/lipsync_training.json) and writes them as JSON (run at build time; the
// output is a build artifact, never committed). See docs/algorithms.md#audio-lipsync.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "lipsync_features.hpp"

namespace {

using namespace facecast;
using namespace facecast::viseme;
constexpr int D = detail::kLipsyncDims;

struct Training {
  std::vector<std::string> english, chinese, english_voices, chinese_voices;
  std::vector<std::string> skip_phones;  // phones whose frames teach no class
  std::vector<int> speeds;
  std::vector<double> warps;
  int components = 4, iterations = 12;
  double prior_power = 0.5, variance_floor = 0.05;
  std::map<std::string, SoundClass> class_of;  // oculus viseme -> class
};

Training load_training() {
  ConfigReader c = ConfigReader::open(config_path("viseme/lipsync_training.json"));
  Training t;
  c.require("english", t.english)
      .require("chinese", t.chinese)
      .require("english_voices", t.english_voices)
      .require("chinese_voices", t.chinese_voices)
      .require("speeds", t.speeds)
      .require("warps", t.warps)
      .read("components", t.components)
      .read("iterations", t.iterations)
      .read("prior_power", t.prior_power)
      .read("variance_floor", t.variance_floor)
      .read("skip_phones", t.skip_phones);
  ConfigReader& classes = c.section("classes");
  for (const std::string& name : classes.keys()) {
    std::vector<std::string> visemes;
    classes.require(name, visemes);
    for (const auto& v : visemes) t.class_of[v] = parse_sound_class(name);
  }
  if (t.speeds.empty() || t.warps.empty()) c.fail("speeds and warps must not be empty");
  c.reject_unknown();
  return t;
}

struct Sample {
  Audio audio;
  std::vector<VisemeEvent> visemes;                // times in the (warped) audio
  std::vector<std::pair<double, double>> skipped;  // spans of Training::skip_phones
};

// Every sentence with every voice; speed and warp cycle so the combinations spread.
std::vector<Sample> synthesize(const Training& t) {
  std::vector<Sample> out;
  const auto run = [&](const std::vector<std::string>& texts,
                       const std::vector<std::string>& voices, bool zh) {
    for (std::size_t s = 0; s < texts.size(); ++s)
      for (std::size_t v = 0; v < voices.size(); ++v) {
        Options o;
        o.timing = Timing::kTts;
        o.set = VisemeSet::kOculus;
        // espeak-ng's own reading: the audio and its labels agree either way, and the lexicon's
        // few changed words only moved the learned templates (human jaw 0.630 -> 0.597).
        o.english_lexicon = false;
        (zh ? o.zh_voice : o.en_voice) = voices[v];
        o.espeak_speed = t.speeds[(s + v) % t.speeds.size()];
        const double warp = t.warps[(s + 2 * v) % t.warps.size()];
        const Utterance u = analyze(texts[s], o);
        // Played at warp x its rate: pitch and formants rise by warp, times shrink by it.
        Sample sm;
        sm.audio = audio_from_pcm16(u.pcm, static_cast<int>(std::lround(u.sample_rate * warp)));
        for (VisemeEvent e : u.visemes) {
          e.start /= warp;
          e.end /= warp;
          sm.visemes.push_back(e);
        }
        for (const Phone& p : u.phones)
          if (std::find(t.skip_phones.begin(), t.skip_phones.end(), p.phone) != t.skip_phones.end())
            sm.skipped.push_back({p.start / warp, p.end / warp});
        out.push_back(std::move(sm));
      }
  };
  run(t.english, t.english_voices, false);
  run(t.chinese, t.chinese_voices, true);
  return out;
}

// Mean cepstra c1..c12 over the frames that are not near-silent: the speaker-normalisation prior.
std::vector<float> cepstral_mean(const std::vector<Sample>& samples) {
  std::vector<double> sum(detail::kLipsyncCepstra, 0);
  double n = 0;
  for (const Sample& s : samples) {
    const detail::Features f = detail::compute_features(s.audio.samples, s.audio.sample_rate);
    for (std::size_t i = 0; i < f.frames(); ++i) {
      if (f.energy_db[i] < -50) continue;
      for (int q = 0; q < detail::kLipsyncCepstra; ++q)
        sum[static_cast<std::size_t>(q)] += f.row(i)[q + 1];
      ++n;
    }
  }
  std::vector<float> mean;
  for (double x : sum) mean.push_back(static_cast<float>(x / std::max(1.0, n)));
  return mean;
}

using Vec = std::array<float, D>;

// Labelled, non-silent feature frames per class, through the same FeatureStream as the analyser.
std::array<std::vector<Vec>, kSoundClasses> labelled_frames(const std::vector<Sample>& samples,
                                                            const Training& t,
                                                            const std::vector<float>& prior) {
  std::array<std::vector<Vec>, kSoundClasses> out;
  const LipsyncOptions lo;
  for (const Sample& s : samples) {
    detail::FeatureStream fs(s.audio.sample_rate, lo, prior);
    std::vector<detail::FeatureFrame> frames;
    fs.push(s.audio.samples.data(), s.audio.samples.size(), frames);
    fs.finish(frames);
    std::size_t e = 0;
    for (const auto& f : frames) {
      while (e < s.visemes.size() && s.visemes[e].end <= f.time) ++e;
      if (f.silent || e == s.visemes.size() || s.visemes[e].start > f.time) continue;
      if (std::any_of(s.skipped.begin(), s.skipped.end(),
                      [&](const auto& r) { return f.time >= r.first && f.time < r.second; }))
        continue;
      const auto it = t.class_of.find(s.visemes[e].viseme);
      if (it == t.class_of.end() || it->second == SoundClass::kSilence) continue;
      out[static_cast<std::size_t>(it->second)].push_back(f.x);
    }
  }
  return out;
}

// k-means (deterministic start: evenly spaced frames) then one diagonal Gaussian per cluster.
nlohmann::json fit_class(const std::vector<Vec>& x, const Training& t, const Vec& global_var) {
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(t.components), x.size());
  std::vector<Vec> centre(k);
  for (std::size_t c = 0; c < k; ++c) centre[c] = x[(2 * c + 1) * x.size() / (2 * k)];
  std::vector<std::size_t> label(x.size(), 0);
  for (int it = 0; it < t.iterations; ++it) {
    for (std::size_t i = 0; i < x.size(); ++i) {
      double best = 1e300;
      for (std::size_t c = 0; c < k; ++c) {
        double d = 0;
        for (int q = 0; q < D; ++q) d += std::pow(x[i][q] - centre[c][q], 2) / global_var[q];
        if (d < best) best = d, label[i] = c;
      }
    }
    std::vector<std::array<double, D>> sum(k, std::array<double, D>{});
    std::vector<double> n(k, 0);
    for (std::size_t i = 0; i < x.size(); ++i) {
      for (int q = 0; q < D; ++q) sum[label[i]][q] += x[i][q];
      ++n[label[i]];
    }
    for (std::size_t c = 0; c < k; ++c)
      if (n[c] > 0)
        for (int q = 0; q < D; ++q) centre[c][q] = static_cast<float>(sum[c][q] / n[c]);
  }
  nlohmann::json comps = nlohmann::json::array();
  for (std::size_t c = 0; c < k; ++c) {
    std::array<double, D> var{};
    double n = 0;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (label[i] == c) {
        for (int q = 0; q < D; ++q) var[q] += std::pow(x[i][q] - centre[c][q], 2);
        ++n;
      }
    if (n < 2) continue;
    std::vector<float> v;
    for (int q = 0; q < D; ++q)
      v.push_back(static_cast<float>(std::max(var[q] / n, t.variance_floor * global_var[q])));
    comps.push_back({{"weight", n / static_cast<double>(x.size())},
                     {"mean", std::vector<float>(centre[c].begin(), centre[c].end())},
                     {"var", v}});
  }
  return comps;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: facecast_viseme_lipsyncgen OUT\n";
    return 2;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const Training t = load_training();
    const std::vector<Sample> samples = synthesize(t);
    const std::vector<float> prior = cepstral_mean(samples);
    const auto frames = labelled_frames(samples, t, prior);
    Vec mean{}, var{};
    double n = 0;
    for (const auto& cls : frames)
      for (const Vec& v : cls) {
        for (int q = 0; q < D; ++q) mean[q] += v[q], var[q] += v[q] * v[q];
        ++n;
      }
    for (int q = 0; q < D; ++q) {
      mean[q] = static_cast<float>(mean[q] / n);
      var[q] = static_cast<float>(std::max(1e-6, var[q] / n - mean[q] * mean[q]));
    }
    nlohmann::json out{{"dims", D}, {"cepstral_mean", prior}, {"classes", nlohmann::json::array()}};
    double total = 0;
    for (int c = 1; c < kSoundClasses; ++c) total += std::pow(frames[c].size(), t.prior_power);
    for (int c = 1; c < kSoundClasses; ++c) {
      if (frames[c].size() < 10)
        throw Error(std::string("too few training frames of class ") +
                    std::string(to_string(static_cast<SoundClass>(c))));
      out["classes"].push_back({{"name", to_string(static_cast<SoundClass>(c))},
                                {"frames", frames[c].size()},
                                {"prior", std::pow(frames[c].size(), t.prior_power) / total},
                                {"components", fit_class(frames[c], t, var)}});
    }
    write_file_atomic(argv[1], out.dump());
    std::cerr << "lip-sync templates: " << samples.size() << " utterances, " << n << " frames, in "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()
              << " s\n";
  } catch (const facecast::Error& e) {
    std::cerr << "facecast_viseme_lipsyncgen: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
