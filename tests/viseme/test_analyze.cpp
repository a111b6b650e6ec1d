// Text -> Utterance: English visemes, mixed text, expressions, timing, threads, JSON.
#include <algorithm>
#include <catch2/catch.hpp>
#include <future>

#include "facecast/core/error.hpp"
#include "facecast/viseme/viseme.hpp"
#include "viseme_names.hpp"

using namespace facecast;
using namespace facecast::viseme;

using facecast::test::visemes;

namespace {

std::string oculus(const char* text, bool english_lexicon = true) {
  Options o;
  o.set = VisemeSet::kOculus;
  o.english_lexicon = english_lexicon;
  return visemes(analyze(text, o));
}

void check_track(const Utterance& u) {
  INFO(u.text);
  for (std::size_t i = 0; i < u.visemes.size(); ++i) {
    CHECK(u.visemes[i].end > u.visemes[i].start);
    if (i > 0) {
      CHECK(u.visemes[i].start >= u.visemes[i - 1].end - 1e-9);
      CHECK(u.visemes[i].viseme != u.visemes[i - 1].viseme);  // consecutive repeats merge
    }
  }
  for (const auto& p : u.phones) {
    CHECK(p.start >= 0);
    CHECK(p.end >= p.start);
    CHECK(p.end <= u.duration + 1e-6);
  }
}

bool all_in(const Utterance& u, const std::vector<std::string>& names) {
  return std::all_of(u.visemes.begin(), u.visemes.end(), [&](const VisemeEvent& v) {
    return std::find(names.begin(), names.end(), v.viseme) != names.end();
  });
}

const std::vector<std::string> kZh15 = {"sil", "a", "bpm", "dtnl", "e",   "f",      "gkh", "i",
                                        "jqx", "o", "r",   "uv",   "zcs", "zhchsh", "n",   "ng"};
const std::vector<std::string> kOculus = {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS",
                                          "nn",  "RR", "aa", "E",  "I",  "O",  "U"};

}  // namespace

TEST_CASE("English words become Oculus viseme sequences", "[viseme][analyze]") {
  CHECK(oculus("mom") == "PP aa PP");
  CHECK(oculus("fish") == "FF I CH");
  CHECK(oculus("think") == "TH I kk");
  CHECK(oculus("view") == "FF I U");
  CHECK(oculus("church") == "CH RR CH");
  CHECK(oculus("zoo") == "SS U");
  CHECK(oculus("red") == "RR E DD");
  CHECK(oculus("water") == "U O DD RR");
  Options o;
  o.set = VisemeSet::kMpeg4;
  CHECK(visemes(analyze("mom", o)) == "pbm A pbm");
}

TEST_CASE("English context rules: reduced vowels and vowel pairs as the dictionary writes them",
          "[viseme][analyze]") {
  // The rules serve espeak-ng's readings (the words the English lexicon lacks): without it here.
  const auto espeak = [](const char* word) { return oculus(word, false); };
  CHECK(espeak("area") == "E RR I aa");                               // unstressed i@: two vowels
  CHECK(espeak("science") == "SS aa nn SS");                          // aI@ has no r
  CHECK(espeak("dialog") == "DD aa nn aa kk");                        // (was DD aa RR nn ...)
  CHECK(espeak("capacity").find("SS aa DD I") != std::string::npos);  // -ity: a schwa
  // The lexicon reads it as both releases of the CMU dictionary do (D AY AH L AO G).
  CHECK(oculus("dialog") == "DD aa nn O kk");
}

TEST_CASE("mixed Chinese and English text is one track in one set", "[viseme][analyze]") {
  const char* text = "(joy, 40, 0.5)大家好，欢迎来到 Facecast 的发布会。(surprise, 63, 0.3) Wow!";
  const Utterance u = analyze(text);
  CHECK(u.set == VisemeSet::kZh15);  // auto: any Chinese -> zh15
  check_track(u);
  CHECK(all_in(u, kZh15));
  REQUIRE(u.syllables.size() == 11);
  CHECK(u.syllables[0].pinyin == "da4");
  CHECK(u.syllables[7].text == "的");
  CHECK(u.syllables[7].pinyin == "de5");
  const auto facecast = std::find_if(u.words.begin(), u.words.end(),
                                     [](const Word& w) { return w.text == "Facecast"; });
  REQUIRE(facecast != u.words.end());
  CHECK(
      std::any_of(u.phones.begin(), u.phones.end(), [](const Phone& p) { return p.lang == "en"; }));
  REQUIRE(u.expressions.size() == 2);
  CHECK(u.expressions[0].name == "joy");
  CHECK(u.expressions[0].intensity == 40);
  CHECK(u.expressions[0].start == 0);
  CHECK(u.expressions[0].ramp == Approx(0.5));
  CHECK(u.expressions[1].name == "surprise");
  CHECK(u.expressions[1].start == Approx(u.words.back().start));  // at "Wow", after the pause
  CHECK(u.words.back().text == "Wow");
  // A pause viseme where the full stop is.
  CHECK(std::any_of(u.visemes.begin(), u.visemes.end(),
                    [](const VisemeEvent& v) { return v.viseme == "sil"; }));

  Options o;
  o.set = VisemeSet::kOculus;
  const Utterance uo = analyze(text, o);
  CHECK(all_in(uo, kOculus));
  CHECK(uo.syllables.size() == u.syllables.size());
  Options en;
  const Utterance english = analyze("Hello there", en);
  CHECK(english.set == VisemeSet::kOculus);  // auto: no Chinese -> oculus
  CHECK(english.syllables.empty());
}

// See docs/algorithms.md#duration-model.
TEST_CASE("the duration model follows the rate and the configured proportions",
          "[viseme][timing]") {
  Options slow, fast;
  slow.rate = 4;
  fast.rate = 8;
  const Utterance a = analyze("今天学习汉语", slow), b = analyze("今天学习汉语", fast);
  check_track(a);
  CHECK(a.duration == Approx(2 * b.duration).epsilon(1e-6));
  // 6 syllables at 4 per second, the last lengthened at the phrase end.
  CHECK(a.duration == Approx(5 * 0.25 + 0.25 * slow.phrase_final_lengthening));
  // bpm initials are longer than dtnl, open finals longer than e, medial u short.
  const auto share = [](const char* text, std::size_t phone) {
    const Utterance u = analyze(text);
    return (u.phones[phone].end - u.phones[phone].start) / u.duration;
  };
  CHECK(share("八", 0) > share("大", 0));
  CHECK(share("大", 1) > share("的", 1));
  CHECK(share("光", 1) < share("光", 0));
  // Punctuation pauses come from configs/viseme/punctuation.json.
  const Utterance p = analyze("好。好"), q = analyze("好好");
  // The first 好 of "好。好" is phrase-final too, so it is lengthened as well.
  CHECK(p.duration - q.duration ==
        Approx(0.45 + (1.0 / 4.5) * (Options{}.phrase_final_lengthening - 1)).margin(1e-9));
}

TEST_CASE("espeak-ng timing gives audio and phones that fit it", "[viseme][timing][tts]") {
  Options o;
  o.timing = Timing::kTts;
  const Utterance u = analyze("(joy, 20, 0.2)你好，hello world!", o);
  CHECK(u.sample_rate == 22050);
  REQUIRE_FALSE(u.pcm.empty());
  CHECK(u.duration == Approx(static_cast<double>(u.pcm.size()) / u.sample_rate));
  check_track(u);
  REQUIRE(u.syllables.size() == 2);
  CHECK(u.syllables[0].end <= u.syllables[1].start + 1e-9);
  REQUIRE(u.words.size() == 3);
  CHECK(u.words[1].text == "hello");
  CHECK(u.words[1].start >= u.syllables[1].end + 0.2);  // the comma pause is silence
  // The audio is not silent where the words are.
  const auto energy = [&](double t0, double t1) {
    double e = 0;
    for (auto i = static_cast<std::size_t>(t0 * u.sample_rate);
         i < static_cast<std::size_t>(t1 * u.sample_rate); ++i)
      e += std::abs(static_cast<double>(u.pcm[i]));
    return e / ((t1 - t0) * u.sample_rate);
  };
  CHECK(energy(u.words[1].start, u.words[1].end) > 500);
  CHECK(energy(u.syllables[1].end + 0.05, u.words[1].start - 0.05) < 50);
}

// espeak-ng speaks phones in running text that no word alone has (en-us's "the" before a
// consonant ends in @2, not @): a phone missing from the tables would leave a hole in its word.
TEST_CASE("every phone espeak-ng speaks in running English text is read", "[viseme][timing][tts]") {
  Options o;
  o.timing = Timing::kTts;
  const Utterance u = analyze(
      "Pass on to the recipients the same freedoms that you received, and give the others a "
      "copy of the notice along with the program. The little people of the village, in their "
      "usual way, thought the whole thing was rather odd.",
      o);
  check_track(u);
  REQUIRE(u.words.size() == 41);
  std::size_t checked = 0;
  for (const Word& w : u.words) {
    INFO(w.text << " at " << w.start);
    std::vector<const Phone*> in;
    for (const Phone& p : u.phones)
      if (p.start >= w.start - 1e-6 && p.end <= w.end + 1e-6 && p.end > p.start) in.push_back(&p);
    REQUIRE_FALSE(in.empty());
    for (std::size_t i = 1; i < in.size(); ++i) CHECK(in[i]->start - in[i - 1]->end < 0.002);
    if (w.text == "the" || w.text == "The") {
      CHECK(in.size() >= 2);  // a vowel after the D
      ++checked;
    }
  }
  CHECK(checked == 8);
}

// The visemes without pauses, repeats merged.
std::vector<std::string> spoken(const Utterance& u) {
  std::vector<std::string> out;
  for (const auto& v : u.visemes)
    if (v.viseme != "sil" && (out.empty() || out.back() != v.viseme)) out.push_back(v.viseme);
  return out;
}

// The duration model is exact; espeak-ng timings vary by a few milliseconds with the synthesizer's
// history (its intonation state), so TTS results are compared by their visemes and a duration
// within 50 ms.
TEST_CASE("concurrent utterances give the same results as one at a time", "[viseme][threads]") {
  const std::vector<std::string> texts = {"银行行长来了。", "Hello world, this is Facecast.",
                                          "(joy,10,0.1)我们用iPhone打电话。",
                                          "2024年3月5日，价格¥12。"};
  Options tts;
  tts.timing = Timing::kTts;
  std::vector<Utterance> model_ref, tts_ref;
  for (const auto& t : texts) {
    model_ref.push_back(analyze(t));
    tts_ref.push_back(analyze(t, tts));
  }
  std::vector<std::future<std::pair<Utterance, Utterance>>> futures;
  for (int round = 0; round < 3; ++round)
    for (const auto& t : texts)
      futures.push_back(std::async(
          std::launch::async, [t, tts] { return std::make_pair(analyze(t), analyze(t, tts)); }));
  for (std::size_t i = 0; i < futures.size(); ++i) {
    const auto [model, speech] = futures[i].get();
    const Utterance& m = model_ref[i % texts.size()];
    const Utterance& s = tts_ref[i % texts.size()];
    CHECK(to_json(model) == to_json(m));
    CHECK(spoken(speech) == spoken(s));
    CHECK(speech.duration == Approx(s.duration).margin(0.05));
  }
}

TEST_CASE("utterances round-trip through JSON", "[viseme][json]") {
  const Utterance u = analyze("(sadness, 30, 1)重庆的火锅 is spicy.");
  const auto j = to_json(u);
  for (const char* key :
       {"text", "duration", "phones", "syllables", "visemes", "expressions", "words"})
    CHECK(j.contains(key));
  CHECK(j["syllables"][0]["pinyin"] == "chong2");
  CHECK(j["phones"][0]["lang"] == "zh");
  const Utterance back = utterance_from_json(j);
  CHECK(to_json(back) == j);
  CHECK_THROWS_AS(utterance_from_json(nlohmann::json{{"duration", 1}}), facecast::Error);
}

TEST_CASE("option defaults mirror configs/viseme/options.json", "[viseme][config]") {
  const Options d, c = load_options();
  CHECK(c.lang == d.lang);
  CHECK(c.set == d.set);
  CHECK(c.timing == d.timing);
  CHECK(c.rate == d.rate);
  CHECK(c.en_voice == d.en_voice);
  CHECK(c.english_lexicon == d.english_lexicon);
  CHECK(c.zh_voice == d.zh_voice);
  CHECK(c.espeak_speed == d.espeak_speed);
  CHECK(c.phrase_final_lengthening == d.phrase_final_lengthening);
  CHECK(c.neutral_tone_factor == d.neutral_tone_factor);
}

TEST_CASE("WAV encoding", "[viseme][wav]") {
  const std::string wav = encode_wav({0, 1000, -1000}, 22050);
  CHECK(wav.size() == 44 + 6);
  CHECK(wav.substr(0, 4) == "RIFF");
  CHECK(wav.substr(8, 8) == "WAVEfmt ");
  CHECK(wav.substr(36, 4) == "data");
  // Round trip, then the failures a user can cause.
  const Pcm back = decode_wav(wav, "a.wav");
  CHECK(back.sample_rate == 22050);
  CHECK(back.samples == std::vector<int16_t>{0, 1000, -1000});
  CHECK_THROWS_WITH(decode_wav("hello", "b.wav"), Catch::Contains("b.wav: not a RIFF/WAVE"));
  CHECK_THROWS_WITH(decode_wav(wav.substr(0, 36), "c.wav"),
                    Catch::Contains("c.wav: no data chunk"));
  std::string eight = wav;
  eight[34] = 8;  // 8 bits per sample
  CHECK_THROWS_WITH(decode_wav(eight, "d.wav"), Catch::Contains("unsupported encoding"));
  std::string stereo = wav;  // two channels: (0, 1000) and a truncated frame are averaged
  stereo[22] = 2;
  CHECK(decode_wav(stereo, "e.wav").samples == std::vector<int16_t>{500});
}
