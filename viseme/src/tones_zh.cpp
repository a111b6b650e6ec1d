// Chinese tones in word context and tone sandhi. See docs/algorithms.md#chinese-tones.
#include "tones_zh.hpp"

#include <algorithm>
#include <unordered_map>

#include "chars.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "lexicon.hpp"
#include "pinyin_detail.hpp"

namespace facecast::viseme::detail {
namespace {

struct ToneTables {
  std::unordered_map<std::string, std::vector<std::string>, StringHash, std::equal_to<>> words;
  std::size_t max_len = 2;
  std::u32string particles, reduplicated;
};

ToneTables load_tone_tables() {
  const auto path = config_path("viseme/tones_zh.json");
  ConfigReader c = ConfigReader::open(path);
  nlohmann::json words;
  std::string particles, reduplicated;
  c.require("words", words).require("particles", particles).require("reduplicated", reduplicated);
  c.reject_unknown();
  ToneTables t;
  t.particles = to_u32(particles);
  t.reduplicated = to_u32(reduplicated);
  if (!words.is_object()) c.fail("words", "must be an object of word: reading");
  for (const auto& [word, value] : words.items()) {
    if (!value.is_string()) c.fail("words", word + ": the reading must be a string");
    const std::string reading = value.get<std::string>();
    std::vector<std::string> syllables;
    for (std::size_t pos = 0; pos < reading.size();) {
      const auto end = std::min(reading.find(' ', pos), reading.size());
      if (end > pos) syllables.push_back(reading.substr(pos, end - pos));
      pos = end + 1;
    }
    const bool valid = std::all_of(syllables.begin(), syllables.end(),
                                   [](const std::string& s) { return is_pinyin(s); });
    if (to_u32(word).size() != syllables.size() || !valid)
      c.fail("words",
             word + ": '" + reading + "' is not one numbered pinyin syllable per character");
    t.max_len = std::max(t.max_len, syllables.size());
    t.words.emplace(word, std::move(syllables));
  }
  return t;
}

const ToneTables& tone_tables() {
  static const ToneTables t = load_tone_tables();
  return t;
}

char tone_of(const std::string& pinyin) {
  return pinyin.empty() ? '0' : pinyin.back();
}

bool in(const std::u32string& set, char32_t c) {
  return set.find(c) != std::u32string::npos;
}

// The table's words over the run: a span lies inside one segmentation word or covers whole
// consecutive words; longer spans first. Returns which syllables the table decided.
std::vector<bool> table_tones(std::vector<ZhSyllable>& run) {
  const ToneTables& t = tone_tables();
  const std::size_t n = run.size();
  std::vector<bool> done(n, false);
  const auto starts_word = [&](std::size_t i) { return i == 0 || run[i - 1].word != run[i].word; };
  const auto ends_word = [&](std::size_t i) {
    return i + 1 == n || run[i + 1].word != run[i].word;
  };
  for (std::size_t len = std::min(t.max_len, n); len >= 2; --len) {
    for (std::size_t s = 0; s + len <= n; ++s) {
      const std::size_t e = s + len - 1;
      if (run[s].word != run[e].word && !(starts_word(s) && ends_word(e))) continue;
      if (std::any_of(done.begin() + s, done.begin() + s + len, [](bool d) { return d; })) continue;
      std::string key;
      for (std::size_t i = s; i <= e; ++i) append_utf8(key, run[i].c);
      const auto it = t.words.find(key);
      if (it == t.words.end()) continue;
      bool agrees = true;
      for (std::size_t i = s; i <= e; ++i)
        agrees = agrees && !run[i].pinyin.empty() &&
                 toneless(run[i].pinyin) == toneless(it->second[i - s]);
      if (!agrees) continue;
      for (std::size_t i = s; i <= e; ++i) {
        run[i].pinyin = it->second[i - s];
        done[i] = true;
      }
    }
  }
  return done;
}

}  // namespace

void word_tones(std::vector<ZhSyllable>& run) {
  const ToneTables& t = tone_tables();
  const Lexicon& lex = Lexicon::get();
  const std::vector<bool> done = table_tones(run);
  const std::size_t n = run.size();
  const auto single = [&](std::size_t i) {
    return (i == 0 || run[i - 1].word != run[i].word) &&
           (i + 1 == n || run[i + 1].word != run[i].word);
  };
  for (std::size_t i = 0; i < n; ++i) {
    ZhSyllable& s = run[i];
    if (done[i] || s.pinyin.empty()) continue;
    // The neutral tone only from the table, for particles and for the suffix 子: Unihan's most
    // frequent reading of 姐 is the jie5 of 姐姐, of 务 the wu5 of a corpus' 服务.
    if (tone_of(s.pinyin) == '5' && !in(t.particles, s.c) && s.c != U'子')
      s.pinyin = lex.tone(s.c, toneless(s.pinyin), false);
    // AA: the second A neutral (妈妈, 看看); A一A: 一 neutral (看一看).
    if (i > 0 && run[i - 1].c == s.c && in(t.reduplicated, s.c) && !run[i - 1].pinyin.empty()) {
      const bool own_word = run[i - 1].word == s.word ? i + 1 == n || run[i + 1].word != s.word
                                                      : single(i - 1) && single(i);
      if (own_word) {
        if (!done[i - 1]) run[i - 1].pinyin = lex.tone(s.c, toneless(run[i - 1].pinyin), false);
        s.pinyin = toneless(s.pinyin) + "5";
      }
    }
    if (s.c == U'一' && i > 0 && i + 1 < n && run[i - 1].c == run[i + 1].c &&
        in(t.reduplicated, run[i - 1].c))
      s.pinyin = "yi5";
    // A一A, A了A: the verb repeated reads as it did (数一数 shu3, 量了量 liang2).
    if (i >= 2 && run[i - 2].c == s.c && (run[i - 1].c == U'一' || run[i - 1].c == U'了') &&
        !done[i] && !run[i - 2].pinyin.empty() && toneless(run[i - 2].pinyin) == toneless(s.pinyin))
      s.pinyin = run[i - 2].pinyin;
  }
}

std::vector<std::string> spoken_tones(const std::vector<ZhSyllable>& run) {
  const std::size_t n = run.size();
  std::vector<char> tone(n);
  for (std::size_t i = 0; i < n; ++i) tone[i] = tone_of(run[i].pinyin);
  static const std::u32string kDigits = U"零〇一二三四五六七八九十两";
  // 一 and 不, decided on the lexical tone that follows.
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const char next = tone[i + 1];
    if (run[i].c == U'一' && tone[i] == '1') {
      const bool word_final =
          run[i + 1].word != run[i].word && i > 0 && run[i - 1].word == run[i].word;
      const bool number = in(kDigits, run[i + 1].c) || (i > 0 && in(kDigits, run[i - 1].c)) ||
                          (i > 0 && run[i - 1].c == U'第');
      if (!word_final && !number && next >= '1' && next <= '5')
        tone[i] = next == '4' || next == '5' ? '2' : '4';
    } else if (run[i].c == U'不' && tone[i] == '4' && next == '4') {
      tone[i] = '2';
    }
  }
  // Prosodic words: segmentation words; a one-syllable word joins its neighbour up to 3 syllables.
  std::vector<std::pair<std::size_t, std::size_t>> words;  // [begin, end)
  for (std::size_t i = 0; i < n; ++i) {
    if (words.empty() || run[words.back().first].word != run[i].word)
      words.push_back({i, i + 1});
    else
      words.back().second = i + 1;
  }
  std::vector<std::size_t> group(n);
  std::size_t g = 0, group_len = 0;
  for (std::size_t w = 0; w < words.size(); ++w) {
    const std::size_t len = words[w].second - words[w].first;
    const bool join =
        w > 0 && ((group_len == 1 && group_len + len <= 3) || (len == 1 && group_len <= 2));
    if (join) {
      group_len += len;
    } else {
      g += w > 0;
      group_len = len;
    }
    for (std::size_t i = words[w].first; i < words[w].second; ++i) group[i] = g;
  }
  // Third-tone runs inside a prosodic word.
  for (std::size_t a = 0; a < n;) {
    std::size_t b = a;
    if (tone[a] == '3')
      while (b + 1 < n && tone[b + 1] == '3' && group[b + 1] == group[a]) ++b;
    if (b > a) {
      const bool one_plus_two =
          b - a == 2 && run[a].word != run[a + 1].word && run[a + 1].word == run[b].word;
      for (std::size_t i = one_plus_two ? a + 1 : a; i < b; ++i) tone[i] = '2';
    }
    a = b + 1;
  }
  std::vector<std::string> out(n);
  for (std::size_t i = 0; i < n; ++i)
    if (!run[i].pinyin.empty()) out[i] = toneless(run[i].pinyin) + tone[i];
  return out;
}

}  // namespace facecast::viseme::detail
