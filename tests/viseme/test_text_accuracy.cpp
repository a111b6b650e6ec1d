// Text accuracy on held-out sets (issue 36), printed and checked against the goals:
// - English: Oculus viseme error against the CMU dictionary (festlex-cmu's cmudict-0.4) on two
//   samples of the whole dictionary the context rules were not learned on (OFFSET 26 and 39; the
//   rules were learned on OFFSET 0-9, en_eval.hpp), names and rare words included. Three figures:
//   (1) as the engine reads by default, with the English lexicon (pocketsphinx's cmudict-en-us, a
//   later release of the same dictionary: this measures the lexicon's coverage and agreement with
//   the older release; goal 5 %); (2) with the lexicon off, espeak-ng alone (6.77 % when the
//   lexicon came); (3) with the lexicon, the sampled words it does not list (true out-of-vocabulary
//   words, read by espeak-ng's letter-to-sound rules only). The same samples' words that are not
//   in wamerican's common-word list are printed apart.
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
#include "en_lexicon.hpp"
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
  en::Score all, uncommon;  // with the lexicon
  en::Score espeak;         // the lexicon off: espeak-ng alone
  en::Score unlisted;       // with the lexicon, the words it does not list
  // Every word of the dictionary outside the tuning offsets that the lexicon does not list: the
  // two samples hold too few of them for a figure.
  en::Score unlisted_all;
};

// Computed once for the test cases.
const EnglishFigures& english_figures() {
  static const EnglishFigures f = [] {
    EnglishFigures out;
    const en::Dictionary dict = en::read_cmu(kCmuDict);
    const std::set<std::string> common = en::read_word_list(kWordList);
    const auto& lexicon = facecast::viseme::detail::EnglishLexicon::get();
    for (std::size_t offset : kHeldOutOffsets) {
      REQUIRE(offset % (dict.size() / 2000) >= en::kTuningOffsets);  // not a tuning sample
      for (const auto& w : en::sample(dict, 2000, offset)) {
        const en::WordScore s = en::score_word(dict, w);
        out.all.add(s);
        if (!common.count(w)) out.uncommon.add(s);
        if (!lexicon.contains(w)) out.unlisted.add(s);
        out.espeak.add(en::score_word(dict, w, false));
      }
    }
    std::size_t i = 0;
    const std::size_t step = dict.size() / 2000;
    for (const auto& [w, prons] : dict)
      if (i++ % step >= en::kTuningOffsets && !lexicon.contains(w))
        out.unlisted_all.add(en::score_word(dict, w));
    std::cout << std::fixed << std::setprecision(2) << "English held-out viseme error ("
              << out.all.words << " CMU dictionary words, OFFSET 26 and 39): with the lexicon "
              << out.all.error_percent() << " % (names and rare words, not in wamerican, "
              << out.uncommon.error_percent() << " % of " << out.uncommon.words
              << "); espeak-ng alone " << out.espeak.error_percent()
              << " %; the words the lexicon lacks (letter-to-sound) "
              << out.unlisted.error_percent() << " % (" << out.unlisted.words
              << " words), of the whole dictionary outside the tuning offsets "
              << out.unlisted_all.error_percent() << " % (" << out.unlisted_all.words
              << " words)\n";
    return out;
  }();
  return f;
}

bool have_english_data() {
  return facecast::test::require_data(kCmuDict) && facecast::test::require_data(kWordList) &&
         facecast::test::require_data(facecast::viseme::detail::EnglishLexicon::default_path());
}

}  // namespace

TEST_CASE("English viseme error on held-out dictionary words meets the goal with the lexicon",
          "[viseme][accuracy]") {
  if (!have_english_data()) return;
  const auto& f = english_figures();
  CHECK(f.all.words == 4000);
  // The goal is 5 %; measured with the lexicon 0.87 % (names and rare words 0.69 %).
  CHECK(f.all.error_percent() <= 5.0);
  CHECK(f.all.error_percent() <= 1.5);
  CHECK(f.uncommon.error_percent() <= 1.5);
  // espeak-ng alone: 6.77 % when the context rules were learned (7.12 % before them).
  CHECK(f.espeak.error_percent() <= 7.0);
  // The lexicon lacks few of the older release's words (11 of the samples' 4,000; 267 of the
  // whole dictionary's 85,000 outside the tuning offsets, misspellings among them): 11.43 %.
  CHECK(f.unlisted.words < 40);
  CHECK(f.unlisted_all.words > 200);
  CHECK(f.unlisted_all.error_percent() <= 12.5);
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
