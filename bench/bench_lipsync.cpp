// Audio-only lip-sync quality (docs/algorithms.md#audio-lipsync), side by side with the "mouth
// follows loudness" baseline, on the speech of tests/viseme/align_cases.hpp (festival and flite
// English; altered espeak-ng Mandarin): viseme-class frame accuracy against the classes of the
// text path's visemes on the true timing, and the Pearson correlation of jawOpen at 60 fps with
// the curve the text path makes from the true timing. Baseline: the same silence/closure
// decision, every sounding frame "a", jaw = the smoothed loudness.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include "align_cases.hpp"
#include "build_paths.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/core/config.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "lipsync_eval.hpp"

using namespace facecast;

int main() {
  std::vector<test::AlignCase> cases = test::all_cases(facecast::test::test_data_dir() / "align");
  const viseme::LipsyncOptions lo = viseme::load_lipsync_options();
  std::map<std::string, test::LipsyncScore> scores;
  for (const auto& c : cases) {
    const test::LipsyncScore s = test::score_lipsync(c, lo);
    const std::string source = c.name.substr(0, c.name.find(' '));
    scores[c.lang] += s;
    scores[c.lang + " (" + source + ")"] += s;
  }
  std::printf("audio-only lip-sync         frames | class accuracy     | jawOpen correlation\n");
  std::printf("                                   | ours   loudness    | ours   loudness\n");
  for (const auto& [name, s] : scores)
    std::printf("%-28s %6zu | %5.1f%%  %5.1f%%     | %5.3f  %5.3f\n", name.c_str(), s.frames,
                100 * s.accuracy(), 100 * s.baseline_accuracy(), s.correlation(),
                s.baseline_correlation());
}
