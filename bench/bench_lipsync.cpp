// Audio-only lip-sync quality (docs/algorithms.md#audio-lipsync), side by side with the "mouth
// follows loudness" baseline, per voice set: synthetic speech of tests/viseme/align_cases.hpp
// (festival and flite English; altered espeak-ng Mandarin) against the text path's visemes on the
// true timing, and the human English development recordings of tests/viseme/eval/human_words.tsv
// (alsa-utils, pocketsphinx-testdata) against the text path's visemes on the HMM alignment of
// their transcripts, and the same for the held-out recordings of human_words_heldout.tsv (a check
// only: nothing is tuned on them). Figures (tests/viseme/lipsync_eval.hpp): class frame accuracy,
// p/b/m closure recall and precision, f/v (FF) recall, jawOpen correlation. Then speaker adaptation
// (the cepstral mean frozen at the templates' prior; each recording heard twice, the second pass
// scored) and the analyser's cost per 10 ms frame.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "align_cases.hpp"
#include "build_paths.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/core/config.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "lipsync_eval.hpp"

using namespace facecast;

namespace {

struct Item {
  std::string set;  // row name
  viseme::Audio audio;
  std::vector<viseme::VisemeEvent> truth;
};

void print_header(const char* title) {
  std::printf("\n%s\n", title);
  std::printf("%-38s %6s | %-15s | %-19s | %-15s | %-15s | %-12s | %-13s\n", "voices", "frames",
              "class accuracy", "p/b/m closed", "closure prec.", "closure in pause", "FF shown",
              "jaw correl.");
  std::printf("%-38s %6s | %-15s | %-19s | %-15s | %-15s | %-12s | %-13s\n", "", "",
              "ours  loudness", "ours        loudness", "ours  loudness", "ours  loudness",
              "ours  prec.", "ours  loudness");
}

void print_row(const std::string& name, const test::LipsyncScore& s) {
  std::printf("%-38s %6zu | %5.1f%%  %5.1f%% | %2zu/%-2zu %5.1f%%  %5.1f%% | %5.1f%%  %5.1f%% | ",
              name.c_str(), s.frames, 100 * s.accuracy(), 100 * s.baseline_accuracy(), s.pbm_closed,
              s.pbm, 100 * s.closure_recall(), 100 * s.baseline_closure_recall(),
              100 * s.closure_precision(), 100 * s.baseline_closure_precision());
  std::printf("%5.1f%%  %5.1f%% | ", 100 * s.closure_in_pause(),
              100 * s.baseline_closure_in_pause());
  std::printf("%2zu/%-2zu %5.1f%% | %5.3f  %5.3f\n", s.ff_shown, s.ff, 100 * s.ff_precision(),
              s.correlation(), s.baseline_correlation());
}

// The recording twice in a row; the reference shifted onto the second copy.
Item twice(const Item& it) {
  Item out = it;
  out.audio.samples.insert(out.audio.samples.end(), it.audio.samples.begin(),
                           it.audio.samples.end());
  const double d = it.audio.seconds();
  for (auto& e : out.truth) e.start += d, e.end += d;
  return out;
}

}  // namespace

int main() {
  std::vector<Item> items;
  for (const auto& c : test::all_cases(facecast::test::test_data_dir() / "align")) {
    const std::string source = c.name.substr(0, c.name.find(' '));
    items.push_back({c.lang == "zh" ? "Chinese synthetic (altered espeak-ng)"
                                    : "English synthetic (" + source + ")",
                     viseme::read_audio(c.audio), c.visemes});
  }
  const auto human =
      test::human_lipsync_cases(test::source_dir() / "tests/viseme/eval/human_words.tsv");
  if (human.empty())
    std::printf("human recordings missing (alsa-utils, pocketsphinx-testdata): no human rows\n");
  for (const auto& h : human) items.push_back({"English human (dev recordings)", h.audio, h.truth});
  // The held-out recordings (cards/, librivox/): a check only, never tuned on.
  for (const auto& h :
       test::human_lipsync_cases(test::source_dir() / "tests/viseme/eval/human_words_heldout.tsv"))
    items.push_back({"English human (held-out recordings)", h.audio, h.truth});

  const viseme::LipsyncOptions lo = viseme::load_lipsync_options();
  viseme::LipsyncOptions frozen = lo;
  frozen.prior_frames = 1e9;  // the cepstral mean stays at the templates' prior

  std::map<std::string, test::LipsyncScore> scores, frozen_scores, warm_scores;
  for (const auto& it : items) {
    const test::LipsyncScore s = test::score_lipsync(it.audio, it.truth, lo);
    scores[it.set] += s;
    if (it.set.rfind("English synthetic", 0) == 0) scores["English synthetic (all)"] += s;
    frozen_scores[it.set] += test::score_lipsync(it.audio, it.truth, frozen);
    const Item w = twice(it);
    warm_scores[it.set] += test::score_lipsync(w.audio, w.truth, lo, it.audio.seconds());
  }
  // BENCH_LIPSYNC_DUMP=<substring of a row name>: the frames of those recordings, with the truth.
  if (const char* dump = std::getenv("BENCH_LIPSYNC_DUMP"))
    for (const auto& it : items) {
      if (it.set.find(dump) == std::string::npos) continue;
      viseme::LipsyncAnalyzer a(it.audio.sample_rate, lo);
      std::vector<viseme::LipsyncFrame> out;
      a.push(it.audio.samples.data(), it.audio.samples.size(), out);
      a.finish(out);
      std::printf("== %s\n", it.set.c_str());
      for (const auto& f : out) {
        std::string truth = "-";
        for (const auto& e : it.truth)
          if (e.start <= f.time && f.time < e.end) truth = e.viseme;
        std::printf("%6.3f %-4s %-11s %c %.2f %.2f\n", f.time, truth.c_str(),
                    std::string(viseme::to_string(f.cls)).c_str(), f.silent ? 's' : '-', f.loudness,
                    f.openness);
      }
    }
  print_header("audio-only lip-sync (closure and FF: segments shown / segments)");
  for (const auto& [name, s] : scores) print_row(name, s);
  print_header("speaker adaptation off (cepstral mean = the templates' prior)");
  for (const auto& [name, s] : frozen_scores) print_row(name, s);
  print_header("adapted before it starts (each recording heard twice, the second scored)");
  for (const auto& [name, s] : warm_scores) print_row(name, s);

  // Cost: the analyser alone over every recording, pushed in 20 ms chunks as the server does.
  std::size_t frames = 0;
  double seconds = 0;
  for (int rep = 0; rep < 3; ++rep)
    for (const auto& it : items) {
      viseme::LipsyncAnalyzer a(it.audio.sample_rate, lo);
      std::vector<viseme::LipsyncFrame> out;
      const auto chunk = static_cast<std::size_t>(it.audio.sample_rate / 50);
      const auto t0 = std::chrono::steady_clock::now();
      for (std::size_t at = 0; at < it.audio.samples.size(); at += chunk)
        a.push(it.audio.samples.data() + at, std::min(chunk, it.audio.samples.size() - at), out);
      a.finish(out);
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      frames += out.size();
    }
  std::printf("\ncost: %.1f us per 10 ms frame (%zu frames, one core)\n", 1e6 * seconds / frames,
              frames);
}
