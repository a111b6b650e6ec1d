// Forced alignment quality and speed: word-onset error against the true times on speech from
// other synthesizers (festival, flite) and on altered Chinese espeak-ng speech (see
// tests/viseme/align_cases.hpp). Prints mean, p95 and max per language and source.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>

#include "align_cases.hpp"
#include "build_paths.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"

using namespace facecast;

namespace {

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

}  // namespace

int main() {
  std::vector<test::AlignCase> cases = test::all_cases(facecast::test::test_data_dir() / "align");
  if (const char* only = std::getenv("BENCH_ALIGN_ONLY"))
    std::erase_if(cases, [&](const auto& c) { return c.lang != only; });
  const viseme::AlignOptions options = viseme::load_align_options();
  std::map<std::string, std::vector<double>> errors;        // per language and per source
  std::map<std::string, std::vector<double>> phone_errors;  // per language
  std::map<std::string, std::size_t> true_phones;
  double seconds = 0, audio_seconds = 0;
  for (const auto& c : cases) {
    const viseme::Audio audio = viseme::read_audio(c.audio);
    const auto t0 = std::chrono::steady_clock::now();
    const viseme::Utterance u = viseme::align(c.text, audio, {}, options);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    audio_seconds += audio.seconds();
    const auto e = test::onset_errors(u, c);
    const std::string source = c.name.substr(0, c.name.find(' '));
    for (double x : test::phone_onset_errors(u, c)) phone_errors[c.lang].push_back(x);
    for (const auto& p : c.phones) true_phones[c.lang] += p.phone != "pau" && p.end > p.start;
    for (double x : e) {
      errors[c.lang].push_back(x);
      errors[c.lang + " (" + source + ")"].push_back(x);
    }
    if (std::getenv("BENCH_ALIGN_VERBOSE")) {
      std::printf("%-34s", c.name.c_str());
      for (std::size_t w = 0; w < u.words.size(); ++w)
        std::printf(" %4.0f", (u.words[w].start - c.onsets[w]) * 1000);
      std::printf("\n");
      if (c.lang == "zh") {
        std::printf("  true:");
        for (const auto& p : c.phones)
          std::printf(" %s%s", p.phone.c_str(), p.end > p.start ? "" : "*");
        std::printf("\n  mine:");
        for (const auto& p : u.phones)
          std::printf(" %s%s", p.phone.c_str(), p.end > p.start ? "" : "*");
        std::printf("\n");
      }
    }
  }
  std::printf("word-onset error, ms         words   mean    p95    max\n");
  for (const auto& [name, e] : errors)
    std::printf("%-28s %6zu %6.1f %6.1f %6.1f\n", name.c_str(), e.size(), mean(e) * 1000,
                percentile(e, 0.95) * 1000, percentile(e, 1.0) * 1000);
  std::printf("phone-onset error, ms        phones  mean    p95    max  (compared of true)\n");
  for (const auto& [name, e] : phone_errors)
    std::printf("%-28s %6zu %6.1f %6.1f %6.1f  (%zu of %zu)\n", name.c_str(), e.size(),
                mean(e) * 1000, percentile(e, 0.95) * 1000, percentile(e, 1.0) * 1000, e.size(),
                true_phones[name]);
  std::printf("alignment speed: %.1f s for %.1f s of audio (%.0fx real time)\n", seconds,
              audio_seconds, audio_seconds / seconds);
}
