// Forced alignment quality and speed: word-onset error against the true times on speech from
// other synthesizers (festival, flite) and on altered Chinese espeak-ng speech (see
// tests/viseme/align_cases.hpp), and against hand labels on human English speech
// (tests/viseme/human_cases.hpp): the development set (human, eval/human_words.tsv) and issue
// 36's held-out set (heldout, eval/human_words_heldout.tsv: pocketsphinx-testdata's cards/ and
// librivox/, never tuned on). English runs through both backends (HMM, DTW). Prints mean,
// median, p95 and max per language, voice set and backend, then per source.
// BENCH_ALIGN_ONLY=en|zh keeps one language, BENCH_ALIGN_SET=synthetic|human|heldout one voice
// set; BENCH_ALIGN_SET=function runs only the short function-word sentences ("to be", "of the":
// festival, flite's four voices, and flite 30 % faster; align_cases.hpp). BENCH_ALIGN_VERBOSE=1
// prints each word's error, =2 also each word's aligned span and the true onsets.
// BENCH_ALIGN_PAD=S puts S seconds of faint noise before and after every recording
// (test::pad_audio), as recordings of a quiet room hold it.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>

#include "align_cases.hpp"
#include "align_hmm.hpp"
#include "build_paths.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"
#include "human_cases.hpp"

using namespace facecast;

namespace {

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

double median(std::vector<double> v) {
  return percentile(std::move(v), 0.5);
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

}  // namespace

int main() {
  const char* only = std::getenv("BENCH_ALIGN_ONLY");
  const double pad = std::getenv("BENCH_ALIGN_PAD") ? std::atof(std::getenv("BENCH_ALIGN_PAD")) : 0;
  const char* set = std::getenv("BENCH_ALIGN_SET");
  const auto wanted = [&](const char* name) { return !set || std::string(set) == name; };
  std::vector<test::AlignCase> cases;
  std::vector<std::string> sets;  // each case's voice set
  if (wanted("synthetic")) cases = test::all_cases(facecast::test::test_data_dir() / "align");
  sets.assign(cases.size(), "synthetic");
  if (set && std::string(set) == "function") {
    // Short function words after pauses and plosives (align_cases.hpp).
    const auto dir = facecast::test::test_data_dir() / "align_function";
    std::filesystem::create_directories(dir);
    const auto& s = test::function_word_sentences();
    cases = test::festival_cases(dir, s, "fw");
    for (auto& c : test::flite_cases(dir, s, {"slt", "kal16", "awb", "rms"}, "fw"))
      cases.push_back(std::move(c));
    for (auto& c : test::flite_cases(dir, s, {"rms", "slt", "awb", "kal16"}, "fast", 0.7))
      cases.push_back(std::move(c));
    sets.assign(cases.size(), "function");
  }
  for (const auto& [name, file] : {std::pair<const char*, const char*>{"human", "human_words.tsv"},
                                   {"heldout", "human_words_heldout.tsv"}}) {
    if (!wanted(name)) continue;
    for (auto& c : test::human_cases(facecast::test::source_dir() / "tests/viseme/eval" / file)) {
      cases.push_back(std::move(c));
      sets.push_back(name);
    }
  }
  const viseme::AlignOptions options = viseme::load_align_options();
  // "lang set backend" and "lang set backend (source)" -> errors
  std::map<std::string, std::vector<double>> errors, by_source, phone_errors;
  std::map<std::string, std::size_t> true_phones;
  std::map<std::string, std::pair<double, double>> speed;  // backend -> seconds, audio seconds
  for (std::size_t i = 0; i < cases.size(); ++i) {
    test::AlignCase c = cases[i];
    if (only && c.lang != only) continue;
    const bool human = sets[i] != "synthetic" && sets[i] != "function";
    viseme::Audio audio = human ? test::human_audio(c) : viseme::read_audio(c.audio);
    if (pad > 0) test::pad_audio(audio, c, pad);
    std::vector<std::pair<std::string, viseme::AlignOptions::Backend>> backends = {
        {"dtw", viseme::AlignOptions::Backend::kDtw}};
    if (c.lang == "en")
      backends.insert(backends.begin(), {"hmm", viseme::AlignOptions::Backend::kHmm});
    for (const auto& [backend, b] : backends) {
      viseme::AlignOptions o = options;
      o.english = b;
      const auto t0 = std::chrono::steady_clock::now();
      const viseme::Utterance u = viseme::align(c.text, audio, {}, o);
      speed[backend].first +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      speed[backend].second += audio.seconds();
      const std::string key = c.lang + " " + sets[i] + " " + backend;
      const auto e = test::scored_onset_errors(u, c);
      const std::string source = c.name.substr(0, c.name.find(' '));
      errors[key].insert(errors[key].end(), e.begin(), e.end());
      if (!human) {
        auto& s = by_source[key + " (" + source + ")"];
        s.insert(s.end(), e.begin(), e.end());
        for (double x : test::phone_onset_errors(u, c)) phone_errors[key].push_back(x);
        for (const auto& p : c.phones) true_phones[key] += p.phone != "pau" && p.end > p.start;
      }
      if (std::getenv("BENCH_ALIGN_VERBOSE")) {
        std::printf("%-4s %-34s", backend.c_str(), c.name.c_str());
        for (std::size_t w = 0; w < u.words.size(); ++w)
          std::printf(" %4.0f", (u.words[w].start - c.onsets[w]) * 1000);
        std::printf("\n");
        if (std::getenv("BENCH_ALIGN_VERBOSE")[0] == '2') {
          std::printf("     spans:");
          for (const auto& w : u.words)
            std::printf(" %s %.3f-%.3f(%.0f)", w.text.c_str(), w.start, w.end,
                        (w.end - w.start) * 1000);
          std::printf("\n     true:");
          for (std::size_t w = 0; w < u.words.size(); ++w) std::printf(" %.3f", c.onsets[w]);
          std::printf("\n");
        }
      }
    }
  }
  const auto row = [](const std::string& name, const std::vector<double>& e) {
    if (e.empty()) return;
    std::printf("%-34s %6zu %6.1f %6.1f %6.1f %6.1f\n", name.c_str(), e.size(), mean(e) * 1000,
                median(e) * 1000, percentile(e, 0.95) * 1000, percentile(e, 1.0) * 1000);
  };
  std::printf("word-onset error, ms (lang set backend)  words   mean median    p95  worst\n");
  for (const auto& [name, e] : errors) row(name, e);
  for (const auto& [name, e] : by_source) row(name, e);
  std::printf("phone-onset error, ms (synthetic)      phones   mean median    p95  worst\n");
  for (const auto& [name, e] : phone_errors) {
    row(name, e);
    std::printf("%-34s (%zu of %zu true phones compared)\n", "", e.size(), true_phones[name]);
  }
  for (const auto& [backend, s] : speed)
    std::printf("%s speed: %.1f s for %.1f s of audio (%.0fx real time)\n", backend.c_str(),
                s.first, s.second, s.second / s.first);
  const auto pool = viseme::detail::hmm_pool_stats();
  std::printf("HMM decoders loaded: %d (the last in %.0f ms)\n", pool.created,
              pool.last_load_seconds * 1000);
}
