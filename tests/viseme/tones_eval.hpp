#pragma once
// Scoring of Chinese toned readings against a hand-written set (eval_tones and the text-accuracy
// test share it). SET.tsv: category <TAB> text <TAB> reference numbered pinyin per Han character
// ("a|b" accepts either). Sentences whose reference does not give one syllable per Han character
// (numbers, Latin) are skipped. Per category:
//   toned      syllables whose reading (tone included) is one the reference accepts
//   neutral    recall of reference neutral tones (syllables whose only accepted tone is 5)
//   false 5    syllables read neutral where the reference does not accept it
//   polyphones polyphonic characters read with the right tone: characters the Xiandai Hanyu Cidian
//              (Unihan kXHC1983) gives more than one reading, tones counted apart (行 xing2/hang2,
//              为 wei2/wei4, 地 di4/de5); 一 and 不 are left out (their other readings are sandhi)
//   tone-poly  the older, narrower figure: characters our lexicon gives one spelling with several
//              tones
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "lexicon.hpp"
#include "pinyin_detail.hpp"

namespace facecast::test::tones {

namespace d = facecast::viseme::detail;

inline std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string w; std::getline(in, w, sep);)
    if (!w.empty()) out.push_back(w);
  return out;
}

struct Line {
  std::string cat, text;
  std::vector<std::vector<std::string>> ref;  // accepted readings per syllable
};

struct Score {
  std::size_t syllables = 0, toned = 0, neutral = 0, neutral_ok = 0, false5 = 0, poly = 0,
              poly_ok = 0, tone_poly = 0, tone_poly_ok = 0;
  void add(const Score& s) {
    syllables += s.syllables;
    toned += s.toned;
    neutral += s.neutral;
    neutral_ok += s.neutral_ok;
    false5 += s.false5;
    poly += s.poly;
    poly_ok += s.poly_ok;
    tone_poly += s.tone_poly;
    tone_poly_ok += s.tone_poly_ok;
  }
};

inline double pct(std::size_t a, std::size_t b) {
  return b ? 100.0 * static_cast<double>(a) / static_cast<double>(b) : 100.0;
}

inline std::u32string han_of(const std::string& text) {
  std::u32string h;
  for (char32_t c : facecast::to_u32(text))
    if (d::is_han(c)) h += c;
  return h;
}

/// The set's sentences; `skipped` counts those without one reference syllable per Han character.
inline std::vector<Line> read_set(const std::string& path, std::size_t* skipped = nullptr) {
  std::vector<Line> lines;
  for (const auto& raw : split(facecast::read_file(path), '\n')) {
    if (raw[0] == '#') continue;
    const auto f = split(raw, '\t');
    if (f.size() != 3) throw facecast::Error(path + ": expected 3 fields: " + raw);
    Line l{f[0], f[1], {}};
    for (const auto& syl : split(f[2], ' ')) l.ref.push_back(split(syl, '|'));
    if (han_of(l.text).size() == l.ref.size())
      lines.push_back(std::move(l));
    else if (skipped)
      ++*skipped;
  }
  return lines;
}

/// Characters with more than one reading in the Xiandai Hanyu Cidian (Unihan kXHC1983), 一 and
/// 不 excepted.
inline const std::unordered_set<char32_t>& xhc_polyphones() {
  static const std::unordered_set<char32_t> set = [] {
    std::unordered_set<char32_t> out;
    const std::string text = d::read_maybe_bz2(d::Lexicon::default_sources().unihan_readings);
    for (const auto& line : split(text, '\n')) {
      const auto f = split(line, '\t');
      if (f.size() != 3 || f[1] != "kXHC1983") continue;
      std::set<std::string> readings;  // "0683.040:lè 1430.060:yuè"
      for (const auto& entry : split(f[2], ' '))
        for (const auto& r : split(entry.substr(entry.find(':') + 1), ',')) readings.insert(r);
      const char32_t c = static_cast<char32_t>(std::stoul(f[0].substr(2), nullptr, 16));
      if (readings.size() > 1 && c != U'一' && c != U'不') out.insert(c);
    }
    if (out.empty()) throw facecast::Error("Unihan_Readings: no kXHC1983 readings found");
    return out;
  }();
  return set;
}

inline bool accepts(const std::vector<std::string>& alts, const std::string& s) {
  for (const auto& a : alts)
    if (a == s) return true;
  return false;
}

// One spelling, several tones in our lexicon (为 wei2/wei4, 好 hao3/hao4...).
inline bool tone_polyphone(char32_t c, const std::string& toneless) {
  std::set<char> tones;
  for (const auto& r : d::Lexicon::get().readings(c))
    if (d::toneless(r) == toneless && r.back() != '5') tones.insert(r.back());
  return tones.size() > 1;
}

/// Scores one sentence's reading `got` into `s`; a sentence with an error goes to `failures`.
/// `ignore_yi_bu` scores 一 and 不 without their tone (for sets that write their sandhi).
inline void score(const Line& l, const std::vector<std::string>& got, Score& s, bool ignore_yi_bu,
                  std::vector<std::string>* failures) {
  const std::u32string han = han_of(l.text);
  if (got.size() != l.ref.size())
    throw facecast::Error(l.text + ": " + std::to_string(got.size()) + " syllables read, " +
                          std::to_string(l.ref.size()) + " in the reference");
  const auto& poly = xhc_polyphones();
  bool ok = true;
  std::string marks;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto& alts = l.ref[i];
    const bool yi_bu = ignore_yi_bu && (han[i] == U'一' || han[i] == U'不');
    const bool right =
        accepts(alts, got[i]) || (yi_bu && d::toneless(alts[0]) == d::toneless(got[i]));
    ok = ok && right;
    ++s.syllables;
    s.toned += right;
    if (alts.size() == 1 && alts[0].back() == '5') {
      ++s.neutral;
      s.neutral_ok += got[i].back() == '5';
    }
    if (got[i].back() == '5' && !accepts(alts, d::toneless(got[i]) + "5")) ++s.false5;
    if (poly.count(han[i])) {
      ++s.poly;
      s.poly_ok += right;
    }
    if (tone_polyphone(han[i], d::toneless(alts[0]))) {
      ++s.tone_poly;
      s.tone_poly_ok += right;
    }
    marks += right ? got[i] + " " : "[" + got[i] + "] ";
  }
  if (!ok && failures) failures->push_back(l.text + "\n    got: " + marks);
}

}  // namespace facecast::test::tones
