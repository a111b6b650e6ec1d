// eval_tones: Facecast's toned reading of Chinese beside another system's, against a reference.
//   eval_tones tests/viseme/eval/zh_tones.tsv [OTHER.tsv NAME] [--failures] [--ignore-yi-bu]
// SET.tsv: category <TAB> text <TAB> reference numbered pinyin per Han character ("a|b" accepts
// either). OTHER.tsv: text <TAB> that system's pinyin (tests/viseme/eval/pinyin_pro.mjs makes it
// for pinyin-pro). Sentences whose reference does not give one syllable per Han character
// (numbers, Latin) are skipped. --ignore-yi-bu scores 一 and 不 without their tone (for sets that
// write them with sandhi, like zh_sentences.tsv). Printed per category and system:
//   toned     syllables whose reading (tone included) is one the reference accepts
//   neutral   recall of reference neutral tones (syllables whose only accepted tone is 5)
//   false 5   syllables read neutral where the reference does not accept it
//   tone-poly accuracy on characters Unihan gives one spelling with several tones
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "lexicon.hpp"
#include "pinyin_detail.hpp"

namespace v = facecast::viseme;
namespace d = facecast::viseme::detail;

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
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
              poly_ok = 0;
};

bool accepts(const std::vector<std::string>& alts, const std::string& s) {
  for (const auto& a : alts)
    if (a == s) return true;
  return false;
}

// One spelling, several tones (为 wei2/wei4, 好 hao3/hao4...): the word decides the tone.
bool tone_polyphone(char32_t c, const std::string& toneless, const d::Lexicon& lex) {
  std::set<char> tones;
  for (const auto& r : lex.readings(c))
    if (d::toneless(r) == toneless && r.back() != '5') tones.insert(r.back());
  return tones.size() > 1;
}

bool g_ignore_yi_bu = false;

void score(const Line& l, const std::vector<std::string>& got, Score& s,
           std::vector<std::string>* failures) {
  const std::u32string han = [&] {
    std::u32string h;
    for (char32_t c : facecast::to_u32(l.text))
      if (d::is_han(c)) h += c;
    return h;
  }();
  if (got.size() != l.ref.size() || han.size() != l.ref.size())
    throw facecast::Error(l.text + ": " + std::to_string(got.size()) + " syllables read, " +
                          std::to_string(l.ref.size()) + " in the reference");
  const d::Lexicon& lex = d::Lexicon::get();
  bool ok = true;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto& alts = l.ref[i];
    const bool yi_bu = g_ignore_yi_bu && (han[i] == U'一' || han[i] == U'不');
    const bool right =
        accepts(alts, got[i]) || (yi_bu && d::toneless(alts[0]) == d::toneless(got[i]));
    ok = ok && right;
    ++s.syllables;
    s.toned += right;
    const bool only_neutral = alts.size() == 1 && alts[0].back() == '5';
    if (only_neutral) {
      ++s.neutral;
      s.neutral_ok += got[i].back() == '5';
    }
    if (got[i].back() == '5' && !accepts(alts, d::toneless(got[i]) + "5")) ++s.false5;
    if (tone_polyphone(han[i], d::toneless(alts[0]), lex)) {
      ++s.poly;
      s.poly_ok += right;
    }
  }
  if (!ok && failures) {
    std::string g;
    for (const auto& x : got) g += x + " ";
    failures->push_back(l.text + "\n    got: " + g);
  }
}

void print(const std::string& system, const std::map<std::string, Score>& by_cat) {
  const auto pct = [](std::size_t a, std::size_t b) {
    return b ? 100.0 * static_cast<double>(a) / static_cast<double>(b) : 100.0;
  };
  Score all;
  const auto row = [&](const std::string& cat, const Score& s) {
    std::cout << std::left << std::setw(11) << system << std::setw(8) << cat << " syllables "
              << std::setw(4) << s.syllables << " toned " << std::setw(5)
              << pct(s.toned, s.syllables) << "%  neutral " << s.neutral_ok << "/" << s.neutral
              << " = " << pct(s.neutral_ok, s.neutral) << "%  false 5: " << s.false5
              << "  tone-poly " << s.poly_ok << "/" << s.poly << " = " << pct(s.poly_ok, s.poly)
              << "%\n";
  };
  for (const auto& [cat, s] : by_cat) {
    row(cat, s);
    all.syllables += s.syllables;
    all.toned += s.toned;
    all.neutral += s.neutral;
    all.neutral_ok += s.neutral_ok;
    all.false5 += s.false5;
    all.poly += s.poly;
    all.poly_ok += s.poly_ok;
  }
  row("ALL", all);
}

int run(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  bool show_failures = false;
  std::erase_if(args, [&](const std::string& a) {
    if (a == "--failures") return show_failures = true;
    if (a == "--ignore-yi-bu") return g_ignore_yi_bu = true;
    return false;
  });
  if (args.size() != 1 && args.size() != 3) {
    std::cerr << "usage: eval_tones SET.tsv [OTHER.tsv NAME] [--failures] [--ignore-yi-bu]\n";
    return 2;
  }
  std::vector<Line> lines;
  std::size_t skipped = 0;
  for (const auto& raw : split(facecast::read_file(args[0]), '\n')) {
    if (raw[0] == '#') continue;
    const auto f = split(raw, '\t');
    if (f.size() != 3) throw facecast::Error(args[0] + ": expected 3 fields: " + raw);
    Line l{f[0], f[1], {}};
    for (const auto& syl : split(f[2], ' ')) l.ref.push_back(split(syl, '|'));
    std::size_t han = 0;
    for (char32_t c : facecast::to_u32(l.text)) han += d::is_han(c);
    if (han == l.ref.size())
      lines.push_back(std::move(l));
    else
      ++skipped;
  }
  std::map<std::string, std::vector<std::string>> other;
  if (args.size() == 3)
    for (const auto& raw : split(facecast::read_file(args[1]), '\n')) {
      const auto f = split(raw, '\t');
      if (f.size() == 2) other[f[0]] = split(f[1], ' ');
    }
  std::map<std::string, Score> ours, theirs;
  std::vector<std::string> failures;
  for (const auto& l : lines) {
    score(l, v::to_pinyin(l.text), ours[l.cat], &failures);
    if (args.size() == 3) {
      const auto it = other.find(l.text);
      if (it == other.end()) throw facecast::Error(args[1] + ": no reading of " + l.text);
      score(l, it->second, theirs[l.cat], nullptr);
    }
  }
  std::cout << std::fixed << std::setprecision(1) << lines.size() << " sentences (" << skipped
            << " skipped: not one reference syllable per Han character)\n";
  print("facecast", ours);
  if (args.size() == 3) print(args[2], theirs);
  if (show_failures) {
    std::cout << "\nfacecast sentences with a tone error (" << failures.size() << "):\n";
    for (const auto& f : failures) std::cout << "  " << f << '\n';
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "eval_tones: " << e.what() << '\n';
    return 2;
  }
}
