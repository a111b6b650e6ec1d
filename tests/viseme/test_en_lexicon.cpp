// The English lexicon (viseme/src/en_lexicon.cpp): reading the dictionary within bounds, turning
// its phones into espeak-ng's with espeak-ng's stress, and the text path speaking them with either
// timing while Chinese stays as it was.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "en_lexicon.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/viseme.hpp"
#include "plan.hpp"
#include "test_data.hpp"

using namespace facecast::viseme;
using detail::EnglishLexicon;
using Phones = std::vector<std::string>;

namespace {

EnglishLexicon lexicon_of(const std::string& text) {
  const auto path = facecast::test::scratch_dir() / "en_lexicon.dict";
  std::ofstream(path, std::ios::binary) << text;
  return EnglishLexicon::load(path);
}

std::vector<std::string> visemes(const Utterance& u) {
  std::vector<std::string> out;
  for (const auto& v : u.visemes)
    if (out.empty() || out.back() != v.viseme) out.push_back(v.viseme);
  return out;
}

std::vector<std::string> phones(const Utterance& u) {
  std::vector<std::string> out;
  for (const auto& p : u.phones) out.push_back(p.phone);
  return out;
}

}  // namespace

TEST_CASE("the English lexicon reads its entries within bounds", "[viseme][en_lexicon]") {
  const std::string long_word(EnglishLexicon::kMaxWordBytes + 1, 'a');
  std::string many_phones = "many";
  for (std::size_t i = 0; i <= EnglishLexicon::kMaxPhones; ++i) many_phones += " AH";
  const EnglishLexicon lex =
      lexicon_of("read R IY D\r\nhello HH AH L OW\nread(2) R EH D\n" + long_word + " AH\n" +
                 many_phones + "\nbad Q AH\nnophones\n\n  \nCAPS K AE P S");
  CHECK(lex.size() == 4);
  CHECK(lex.pronunciations("Read") == std::vector<Phones>{{"R", "IY", "D"}, {"R", "EH", "D"}});
  CHECK(lex.pronunciations("hello") == std::vector<Phones>{{"HH", "AH", "L", "OW"}});
  CHECK(lex.contains("caps"));
  CHECK(lex.contains("CAPS"));
  CHECK_FALSE(lex.contains(long_word));
  CHECK_FALSE(lex.contains("many"));
  CHECK_FALSE(lex.contains("bad"));
  CHECK_FALSE(lex.contains("nophones"));
  CHECK(lex.memory_bytes() > 0);

  CHECK_THROWS_AS(EnglishLexicon::load(facecast::test::scratch_dir() / "missing.dict"),
                  facecast::Error);
  const auto big = facecast::test::scratch_dir() / "big.dict";
  std::ofstream(big) << "a AH\n";
  std::filesystem::resize_file(big, EnglishLexicon::kMaxFileBytes + 1);  // sparse
  CHECK_THROWS_AS(EnglishLexicon::load(big), facecast::Error);
}

TEST_CASE("a listed word is spoken with the dictionary's phones and espeak-ng's stress",
          "[viseme][en_lexicon]") {
  const EnglishLexicon lex = lexicon_of(
      "photography F AH T AA G R AE F IY\nread R IY D\nread(2) R EH D\ncar K AA R\n"
      "the DH AH\nagree AH G R IY\n");
  // Where espeak-ng and the dictionary differ, the dictionary's phones with espeak-ng's stress;
  // unstressed vowels take their reduced phones (AH @, IY i).
  CHECK(
      detail::lexicon_phones(lex, "photography", {"f", "@", "t", "'0", "g", "r", "@", "f", "i"}) ==
      Phones{"f", "@", "t", "'A:", "g", "r", "a", "f", "i"});
  // The pronunciation closest to espeak-ng's reading.
  CHECK(detail::lexicon_phones(lex, "read", {"r", "'i:", "t"}) == Phones{"r", "'i:", "d"});
  // A vowel and r that espeak-ng writes as one phone.
  CHECK(detail::lexicon_phones(lex, "car", {"k", "'a", "r"}) == Phones{"k", "'A@"});
  // espeak-ng reads it as the dictionary does: its own reading stays.
  CHECK_FALSE(detail::lexicon_phones(lex, "agree", {"@", "g", "r", "'i:"}));
  // Without a primary stress it is a function word, which espeak-ng reduces in context.
  CHECK_FALSE(detail::lexicon_phones(lex, "the", {"D", "@2"}));
  // Not listed.
  CHECK_FALSE(detail::lexicon_phones(lex, "bartosik", {"b", "'A@", "t", "@", "s", "I", "k"}));
  CHECK(detail::espeak_phoneme_input({"k", "'A@"}) == "[[k|'A@]]");
}

TEST_CASE("the lexicon serves American voices only", "[viseme][en_lexicon]") {
  Options o;
  CHECK(detail::english_lexicon_applies(o));
  o.en_voice = "en-us+f3";
  CHECK(detail::english_lexicon_applies(o));
  o.en_voice = "en-gb";
  CHECK_FALSE(detail::english_lexicon_applies(o));
  o.en_voice = "en-us";
  o.english_lexicon = false;
  CHECK_FALSE(detail::english_lexicon_applies(o));
}

TEST_CASE("the text path speaks the lexicon's phones with either timing", "[viseme][en_lexicon]") {
  if (!facecast::test::require_data(EnglishLexicon::default_path())) return;
  const char* text = "Bartosik met Angelillo in Pittsburgh.";
  Options o;
  o.set = VisemeSet::kOculus;
  const Utterance model = analyze(text, o);
  o.english_lexicon = false;
  const Utterance espeak = analyze(text, o);
  CHECK(phones(model) != phones(espeak));  // espeak-ng reads the names as English words
  // Stress marks reach espeak-ng.
  o.english_lexicon = true;
  const detail::Plan plan = detail::make_plan(text, o);
  CHECK(plan.units[0].spoken.find("'") != std::string::npos);

  // espeak-ng speaks the same phones: the visemes of its timing are the model's, each word is
  // spoken, and the speech lasts as long as espeak-ng's own reading of the text, give or take.
  o.timing = Timing::kTts;
  const Utterance tts = analyze(text, o);
  CHECK(visemes(tts) == visemes(model));
  REQUIRE(tts.words.size() == 5);
  for (const auto& w : tts.words) CHECK(w.end - w.start > 0.1);
  o.english_lexicon = false;
  const Utterance tts_espeak = analyze(text, o);
  CHECK(tts.duration == Approx(tts_espeak.duration).epsilon(0.1));
}

TEST_CASE("Chinese, and words espeak-ng reads as the dictionary, are unchanged by the lexicon",
          "[viseme][en_lexicon]") {
  for (const char* text : {"银行行长来了，大家好。", "你好, hello world. 欢迎来到上海。"}) {
    Options on, off;
    on.timing = off.timing = Timing::kTts;
    off.english_lexicon = false;
    const Utterance a = analyze(text, on), b = analyze(text, off);
    // (espeak-ng's samples differ from call to call; its phones and times do not, but by a sample)
    CHECK(phones(a) == phones(b));
    CHECK(visemes(a) == visemes(b));
    CHECK(a.duration == Approx(b.duration).margin(0.01));
  }
  // Mixed text with a word the lexicon reads: the Chinese syllables stay.
  Options on, off;
  off.english_lexicon = false;
  const char* mixed = "你好, Bartosik 先生, 欢迎。";
  const Utterance a = analyze(mixed, on), b = analyze(mixed, off);
  REQUIRE(a.syllables.size() == b.syllables.size());
  for (std::size_t i = 0; i < a.syllables.size(); ++i) {
    CHECK(a.syllables[i].pinyin == b.syllables[i].pinyin);
    CHECK(a.syllables[i].end - a.syllables[i].start ==
          Approx(b.syllables[i].end - b.syllables[i].start));
  }
}
