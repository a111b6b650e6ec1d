// Chinese tones: word readings and neutral tones (lexical, in the JSON) and tone sandhi (spoken by
// espeak-ng). See docs/algorithms.md#chinese-tones.
#include <catch2/catch.hpp>
#include <sstream>

#include "build_paths.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "facecast/viseme/viseme.hpp"
#include "plan.hpp"

using namespace facecast::viseme;

namespace {

std::string lexical(const char* text) {
  std::string s;
  for (const auto& p : to_pinyin(text)) s += (s.empty() ? "" : " ") + p;
  return s;
}

std::string spoken(const char* text) {
  Options o;
  o.lang = LangMode::kZh;
  std::string s;
  for (const auto& u : detail::make_plan(text, o).units) s += (s.empty() ? "" : " ") + u.spoken;
  return s;
}

}  // namespace

TEST_CASE("neutral tones come from words and rules, not citation tones", "[viseme][tones]") {
  CHECK(lexical("妈妈") == "ma1 ma5");
  CHECK(lexical("东西") == "dong1 xi5");
  CHECK(lexical("时候") == "shi2 hou5");
  CHECK(lexical("我的朋友") == "wo3 de5 peng2 you5");
  CHECK(lexical("他们在屋子里休息") == "ta1 men5 zai4 wu1 zi5 li3 xiu1 xi5");
  CHECK(lexical("你听听") == "ni3 ting1 ting5");  // reduplicated verb
  CHECK(lexical("看一看") == "kan4 yi5 kan4");
  CHECK(lexical("好吗") == "hao3 ma5");
  CHECK(lexical("姐") == "jie3");  // alone, a full tone (Unihan's first reading is jie5)
  CHECK(lexical("舌头和石头") == "she2 tou5 he2 shi2 tou5");
  CHECK(lexical("开头") == "kai1 tou2");  // 头 is not always a suffix
}

TEST_CASE("one spelling with tones that depend on the word", "[viseme][tones]") {
  CHECK(lexical("因为") == "yin1 wei4");
  CHECK(lexical("作为") == "zuo4 wei2");
  CHECK(lexical("爱好") == "ai4 hao4");
  CHECK(lexical("好人") == "hao3 ren2");
  CHECK(lexical("教室") == "jiao4 shi4");
  CHECK(lexical("他教英语") == "ta1 jiao1 ying1 yu3");
  CHECK(lexical("干净") == "gan1 jing5");
  CHECK(lexical("干部") == "gan4 bu4");
}

TEST_CASE("polyphone tones from the word table and context rules", "[viseme][tones]") {
  CHECK(lexical("差距") == "cha1 ju4");
  CHECK(lexical("倒下") == "dao3 xia4");
  CHECK(lexical("一只猫") == "yi1 zhi1 mao1");  // in_words: the measure word after a numeral
  CHECK(lexical("只有") == "zhi3 you3");
  CHECK(lexical("一场大雨") == "yi1 chang2 da4 yu3");
  CHECK(lexical("数一数") == "shu3 yi5 shu3");  // A一A: the verb repeats its reading
  CHECK(lexical("被选为") == "bei4 xuan3 wei2");
}

TEST_CASE("tone sandhi changes what is spoken, the JSON keeps lexical tones", "[viseme][tones]") {
  // Third tones: 3-3 -> 2-3 inside a prosodic word.
  CHECK(spoken("你好") == "ni2 hao3");
  CHECK(lexical("你好") == "ni3 hao3");
  CHECK(spoken("展览馆") == "zhan2 lan2 guan3");
  CHECK(spoken("姐姐") == "jie3 jie5");  // the neutral tone blocks it
  // 一: yi2 before tone 4, yi4 before 1-3, yi1 at a word's end, in numbers and ordinals.
  CHECK(spoken("一个") == "yi2 ge4");
  CHECK(spoken("一起") == "yi4 qi3");
  CHECK(spoken("一天") == "yi4 tian1");
  CHECK(spoken("统一") == "tong3 yi1");
  CHECK(spoken("第一") == "di4 yi1");
  CHECK(lexical("一个") == "yi1 ge4");
  // 不: bu2 before tone 4 only.
  CHECK(spoken("不是") == "bu2 shi4");
  CHECK(spoken("不好") == "bu4 hao3");
  CHECK(spoken("不来") == "bu4 lai2");
}

TEST_CASE("the utterance keeps lexical tones when espeak-ng speaks the sandhi", "[viseme][tones]") {
  Options o;
  o.timing = Timing::kTts;
  const Utterance u = analyze("你好，一个人。", o);
  REQUIRE(u.syllables.size() == 5);
  CHECK(u.syllables[0].pinyin == "ni3");
  CHECK(u.syllables[2].pinyin == "yi1");
  CHECK(u.syllables[0].end > u.syllables[0].start);
}

TEST_CASE("toned reading on the tone evaluation set", "[viseme][tones][eval]") {
  // tests/viseme/eval/zh_tones.tsv: a syllable is right when its tone is one the reference accepts.
  std::istringstream in(facecast::read_file(
      (facecast::test::source_dir() / "tests/viseme/eval").string() + "/zh_tones.tsv"));
  std::size_t total = 0, right = 0, neutral = 0, neutral_right = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto t1 = line.find('\t'), t2 = line.find('\t', t1 + 1);
    const auto got = to_pinyin(line.substr(t1 + 1, t2 - t1 - 1));
    std::istringstream ref(line.substr(t2 + 1));
    std::size_t i = 0;
    for (std::string alts; ref >> alts; ++i) {
      ++total;
      const bool ok =
          i < got.size() && ("|" + alts + "|").find("|" + got[i] + "|") != std::string::npos;
      right += ok;
      if (alts.find('|') == std::string::npos && alts.back() == '5') {
        ++neutral;
        neutral_right += ok;
      }
    }
    CHECK(i == got.size());
  }
  INFO("toned " << right << "/" << total << ", neutral " << neutral_right << "/" << neutral);
  CHECK(static_cast<double>(right) >= 0.97 * static_cast<double>(total));
  CHECK(static_cast<double>(neutral_right) >= 0.95 * static_cast<double>(neutral));
}
