// Text accuracy on held-out sets (issue 36), printed and checked against the goals:
// - English: Oculus viseme error against the CMU dictionary (festlex-cmu) on two samples of the
//   whole dictionary the context rules were not learned on (OFFSET 26 and 39; the rules were
//   learned on OFFSET 0-9, en_eval.hpp), names and rare words included; the same samples' words
//   that are not in wamerican's common-word list are printed apart. The goal is 5 %; the
//   case holds the level measured (6.8 %), the goal is not reached yet.
// - Chinese: polyphonic characters (several readings in the Xiandai Hanyu Cidian) read with the
//   right tone on tests/viseme/eval/zh_polyphones_heldout.tsv (written before the word table and
//   the context rules were tuned on zh_polyphones_dev.tsv). Goal: >= 95 %.
// The data files come from Debian packages (festlex-cmu, wamerican); under CI=true a missing one
// fails the test, otherwise it warns and the English part is skipped.
#include <catch2/catch.hpp>
#include <iomanip>
#include <iostream>

#include "build_paths.hpp"
#include "en_eval.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "test_data.hpp"
#include "tones_eval.hpp"

namespace {

namespace en = facecast::test::en;
namespace tones = facecast::test::tones;

const char* kCmuDict = "/usr/share/festival/dicts/cmu/cmudict-0.4.out";
const char* kWordList = "/usr/share/dict/american-english";
constexpr std::size_t kHeldOutOffsets[] = {26, 39};

struct EnglishFigures {
  en::Score all, uncommon;
};

// Computed once for both test cases.
const EnglishFigures& english_figures() {
  static const EnglishFigures f = [] {
    EnglishFigures out;
    const en::Dictionary dict = en::read_cmu(kCmuDict);
    const std::set<std::string> common = en::read_word_list(kWordList);
    for (std::size_t offset : kHeldOutOffsets) {
      REQUIRE(offset % (dict.size() / 2000) >= en::kTuningOffsets);  // not a tuning sample
      for (const auto& w : en::sample(dict, 2000, offset)) {
        const en::WordScore s = en::score_word(dict, w);
        out.all.add(s);
        if (!common.count(w)) out.uncommon.add(s);
      }
    }
    std::cout << std::fixed << std::setprecision(2)
              << "English held-out viseme error: " << out.all.error_percent() << " % ("
              << out.all.words << " CMU dictionary words, OFFSET 26 and 39); names and rare words "
              << "(not in wamerican) " << out.uncommon.error_percent() << " % ("
              << out.uncommon.words << " words)\n";
    return out;
  }();
  return f;
}

bool have_english_data() {
  return facecast::test::require_data(kCmuDict) && facecast::test::require_data(kWordList);
}

}  // namespace

TEST_CASE("English viseme error on held-out dictionary words stays at its measured level",
          "[viseme][accuracy]") {
  if (!have_english_data()) return;
  const auto& f = english_figures();
  CHECK(f.all.words == 4000);
  // Measured when the context rules were learned: 6.8 % (7.1 % before them).
  CHECK(f.all.error_percent() <= 7.0);
  CHECK(f.uncommon.error_percent() <= 9.5);
}

TEST_CASE("Chinese polyphones read with the right tone on the held-out set (95 %)",
          "[viseme][accuracy]") {
  const auto set = facecast::test::source_dir() / "tests/viseme/eval/zh_polyphones_heldout.tsv";
  std::size_t skipped = 0;
  const auto lines = tones::read_set(set.string(), &skipped);
  CHECK(skipped == 0);
  tones::Score s;
  for (const auto& l : lines)
    tones::score(l, facecast::viseme::to_pinyin(l.text), s, false, nullptr);
  const double poly = tones::pct(s.poly_ok, s.poly);
  std::cout << std::fixed << std::setprecision(1)
            << "Chinese held-out polyphones read with the right tone: " << poly << " % ("
            << s.poly_ok << "/" << s.poly << " in " << lines.size() << " sentences); all syllables "
            << tones::pct(s.toned, s.syllables) << " %\n";
  CHECK(s.poly > 800);
  CHECK(poly >= 95.0);
}
