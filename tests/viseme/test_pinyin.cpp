// Mandarin: syllables -> phones -> visemes, and text -> pinyin in word context.
#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/pinyin.hpp"

using namespace facecast::viseme;
using V = std::vector<std::string>;

namespace {

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : " ") + x;
  return s;
}

std::string zh15(const char* syllable) {
  return joined(syllable_visemes(split_pinyin(syllable), VisemeSet::kZh15));
}

std::string pinyin(const char* text) {
  return joined(to_pinyin(text));
}

std::string toneless(std::string s) {
  std::string out;
  for (char c : s)
    if (c < '0' || c > '9') out += c;
  return out;
}

}  // namespace

TEST_CASE("syllables split into initial, medial, nucleus and coda", "[viseme][pinyin]") {
  const auto p = split_pinyin("zhuang1");
  CHECK(p.initial == "zh");
  CHECK(p.medial == "u");
  CHECK(p.nucleus == "a");
  CHECK(p.coda == "-ng");
  CHECK(p.tone == 1);
  CHECK(split_pinyin("shi4").nucleus == "-i");  // apical vowel after zh ch sh r z c s
  CHECK(split_pinyin("xi1").nucleus == "i");
  CHECK(split_pinyin("lve4").medial == "v");
  CHECK(split_pinyin("ju4").nucleus == "v");  // u after j q x y is u-umlaut
  CHECK(split_pinyin("de").tone == 5);
  CHECK(split_pinyin("ng").coda == "-ng");
  CHECK_THROWS_AS(split_pinyin("xyz1"), facecast::Error);
  CHECK_THROWS_AS(split_pinyin("bv1x"), facecast::Error);
  CHECK_FALSE(is_pinyin("hello"));
}

// See docs/algorithms.md#viseme-sets.
TEST_CASE("syllables map to the 15 Chinese visemes (zh15)", "[viseme][pinyin]") {
  CHECK(zh15("zhuang1") == "zhchsh uv a ng");
  CHECK(zh15("xue2") == "jqx uv e");
  CHECK(zh15("shi4") == "zhchsh i");
  CHECK(zh15("er2") == "e");
  CHECK(zh15("ba1") == "bpm a");
  CHECK(zh15("fo2") == "f o");
  CHECK(zh15("yu2") == "uv");  // y before u-umlaut is rounded, repeats merge
  CHECK(zh15("yue4") == "uv e");
  CHECK(zh15("yi1") == "i");
  CHECK(zh15("ying1") == "i ng");
  CHECK(zh15("wo3") == "uv o");
  CHECK(zh15("wu3") == "uv");
  CHECK(zh15("xiong2") == "jqx i o ng");
  CHECK(zh15("zong3") == "zcs o ng");
  CHECK(zh15("gei3") == "gkh e");
  CHECK(zh15("lv4") == "dtnl uv");
  CHECK(zh15("kun4") == "gkh uv e n");
  CHECK(zh15("ri4") == "r i");
  CHECK(joined(syllable_visemes(split_pinyin("zhuang1"), VisemeSet::kOculus)) == "CH U aa kk");
  CHECK(joined(syllable_visemes(split_pinyin("ma1"), VisemeSet::kMpeg4)) == "pbm A");
}

TEST_CASE("tone marks become numbered pinyin with v", "[viseme][pinyin]") {
  CHECK(numbered_pinyin("hǎo") == "hao3");
  CHECK(numbered_pinyin("lüè") == "lve4");
  CHECK(numbered_pinyin("de") == "de5");
  CHECK(numbered_pinyin("nu:3") == "nv3");
  CHECK(numbered_pinyin("Zhōng") == "zhong1");
}

TEST_CASE("characters are read in their word's context", "[viseme][pinyin]") {
  CHECK(pinyin("银行行长") == "yin2 hang2 hang2 zhang3");
  CHECK(pinyin("重庆") == "chong2 qing4");
  CHECK(pinyin("重要") == "zhong4 yao4");
  CHECK(pinyin("他还了还书") == "ta1 huan2 le5 huan2 shu1");
  CHECK(pinyin("我还没有还书") == "wo3 hai2 mei2 you3 huan2 shu1");
  CHECK(pinyin("你还好吗") == "ni3 hai2 hao3 ma5");
  CHECK(pinyin("孩子长大了") == "hai2 zi5 zhang3 da4 le5");
  CHECK(pinyin("这条河很长") == "zhe4 tiao2 he2 hen3 chang2");
  CHECK(pinyin("我得走了") == "wo3 dei3 zou3 le5");
  CHECK(pinyin("他跑得很快") == "ta1 pao3 de5 hen3 kuai4");
  CHECK(pinyin("他慢慢地走") == "ta1 man4 man4 de5 zou3");
  CHECK(pinyin("绿色") == "lv4 se4");
  CHECK(pinyin("略微") == "lve4 wei1");
}

TEST_CASE("numbers, dates, times, percentages and money are read out", "[viseme][pinyin]") {
  CHECK(pinyin("2024年") == "er4 ling2 er4 si4 nian2");
  CHECK(pinyin("3.5%") == "bai3 fen1 zhi1 san1 dian3 wu3");
  CHECK(pinyin("10:30") == "shi2 dian3 san1 shi2 fen1");
  CHECK(pinyin("8:05") == "ba1 dian3 ling2 wu3 fen1");
  CHECK(pinyin("¥12") == "shi2 er4 yuan2");
  CHECK(pinyin("$1,200") == "yi1 qian1 er4 bai3 mei3 yuan2");
  CHECK(pinyin("2个人") == "liang3 ge4 ren2");
  CHECK(pinyin("第2名") == "di4 er4 ming2");
  CHECK(pinyin("10005") == "yi1 wan4 ling2 wu3");
  CHECK(pinyin("110") == "yi1 bai3 yi1 shi2");
  CHECK(pinyin("15") == "shi2 wu3");
  CHECK(pinyin("2万") == "liang3 wan4");
  CHECK(pinyin("2024-06-18") == "er4 ling2 er4 si4 nian2 liu4 yue4 shi2 ba1 ri4");
  CHECK(pinyin("1/3") == "san1 fen1 zhi1 yi1");
  CHECK(pinyin("-5度") == "fu4 wu3 du4");
  CHECK(pinyin("3.14") == "san1 dian3 yi1 si4");
}

// Our own held-out-style set (tests/viseme/eval/zh_sentences.tsv, hand-written pinyin): the
// toneless reading must stay at or above 98% of syllables. eval_viseme prints the full breakdown.
TEST_CASE("toneless pinyin accuracy on the evaluation sentences", "[viseme][pinyin][eval]") {
  std::ifstream in((facecast::test::source_dir() / "tests/viseme/eval").string() +
                   "/zh_sentences.tsv");
  REQUIRE(in);
  std::size_t total = 0, right = 0, sentences = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto t1 = line.find('\t'), t2 = line.find('\t', t1 + 1);
    std::istringstream exp(line.substr(t2 + 1));
    V expected;
    for (std::string s; exp >> s;) expected.push_back(toneless(s));
    const V got = to_pinyin(line.substr(t1 + 1, t2 - t1 - 1));
    ++sentences;
    total += expected.size();
    if (got.size() != expected.size()) continue;  // a length mismatch counts as all wrong
    for (std::size_t i = 0; i < got.size(); ++i) right += toneless(got[i]) == expected[i];
  }
  INFO(right << " of " << total << " syllables in " << sentences << " sentences");
  CHECK(sentences >= 200);
  CHECK(static_cast<double>(right) / static_cast<double>(total) >= 0.98);
}
