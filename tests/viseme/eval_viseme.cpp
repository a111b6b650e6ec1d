// eval_viseme: accuracy of the viseme engine on Facecast's own evaluation sets (prints figures).
//   eval_viseme zh tests/viseme/eval/zh_sentences.tsv
//       toneless pinyin / tone / polyphone / zh15 viseme accuracy against hand-written pinyin
//   eval_viseme en /usr/share/festival/dicts/cmu/cmudict-0.4.out [N=2000]
//       Oculus viseme error of N words sampled evenly from the CMU dictionary (festlex-cmu), the
//       reference mapped ARPAbet -> Oculus through configs/viseme/phones_arpabet.json; with
//       WORDLIST (e.g. /usr/share/dict/american-english from wamerican) only words in it, and
//       OFFSET picks a different sample (use one sample to study errors, another to report; the
//       English context rules were learned on OFFSET 0-9 without a word list: en_eval.hpp);
//       --no-lexicon reads the words with espeak-ng alone (Options::english_lexicon off)
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "chars.hpp"
#include "en_eval.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/viseme.hpp"
#include "lexicon.hpp"
#include "pinyin_detail.hpp"

namespace v = facecast::viseme;
namespace d = facecast::viseme::detail;
namespace en = facecast::test::en;

namespace {

std::vector<std::string> words_of(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

using en::edit_distance;
using en::merged;

std::vector<std::string> zh15_of(const std::vector<std::string>& pinyin) {
  std::vector<std::string> out;
  for (const auto& p : pinyin)
    for (auto& c : v::syllable_visemes(v::split_pinyin(p), v::VisemeSet::kZh15)) out.push_back(c);
  return merged(out);
}

bool polyphonic(char32_t c, const d::Lexicon& lex) {
  std::set<std::string> bare;
  for (const auto& r : lex.readings(c)) bare.insert(d::toneless(r));
  return bare.size() > 1;
}

struct Counts {
  std::size_t syllables = 0, toneless = 0, toned = 0, poly = 0, poly_ok = 0, vis_ref = 0,
              vis_err = 0;
};

int eval_zh(const std::string& path) {
  const d::Lexicon& lex = d::Lexicon::get();
  std::map<std::string, Counts> by_cat;
  std::istringstream in(facecast::read_file(path));
  std::vector<std::string> failures;
  v::Options o;
  o.set = v::VisemeSet::kZh15;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto tab1 = line.find('\t'), tab2 = line.find('\t', tab1 + 1);
    const std::string cat = line.substr(0, tab1), text = line.substr(tab1 + 1, tab2 - tab1 - 1);
    const auto expected = words_of(line.substr(tab2 + 1));
    const v::Utterance u = v::analyze(text, o);
    std::vector<std::string> got;
    for (const auto& s : u.syllables) got.push_back(s.pinyin);
    Counts& c = by_cat[cat];
    // Toneless / toned accuracy: reference syllables minus edit operations.
    std::vector<std::string> eb, gb;
    for (const auto& s : expected) eb.push_back(d::toneless(s));
    for (const auto& s : got) gb.push_back(d::toneless(s));
    const std::size_t ed = edit_distance(eb, gb);
    const std::size_t ed_tone = edit_distance(expected, got);
    c.syllables += expected.size();
    c.toneless += expected.size() - std::min(ed, expected.size());
    c.toned += expected.size() - std::min(ed_tone, expected.size());
    // Polyphones: Han characters of sentences without digits/Latin line up with the syllables.
    std::u32string han;
    for (char32_t ch : facecast::to_u32(text))
      if (d::is_han(ch)) han += ch;
    if (han.size() == expected.size() && got.size() == expected.size()) {
      for (std::size_t i = 0; i < han.size(); ++i) {
        if (!polyphonic(han[i], lex)) continue;
        ++c.poly;
        if (eb[i] == gb[i]) ++c.poly_ok;
      }
    }
    const auto ref_vis = zh15_of(expected);
    std::vector<std::string> got_vis;
    for (const auto& e : u.visemes) {
      const double mid = 0.5 * (e.start + e.end);
      const bool in_chinese =
          std::any_of(u.syllables.begin(), u.syllables.end(),
                      [&](const v::Syllable& s) { return mid >= s.start && mid <= s.end; });
      if (e.viseme != "sil" && in_chinese) got_vis.push_back(e.viseme);
    }
    c.vis_ref += ref_vis.size();
    c.vis_err += edit_distance(ref_vis, merged(got_vis));
    if (ed) {
      std::string g;
      for (const auto& s : got) g += s + " ";
      failures.push_back(text + "\n    expected: " + line.substr(tab2 + 1) +
                         "\n    got:      " + g);
    }
  }
  Counts all;
  std::cout << std::fixed << std::setprecision(1);
  const auto pct = [](std::size_t a, std::size_t b) {
    return b ? 100.0 * static_cast<double>(a) / static_cast<double>(b) : 100.0;
  };
  for (const auto& [cat, c] : by_cat) {
    std::cout << std::left << std::setw(10) << cat << " syllables " << std::setw(5) << c.syllables
              << " toneless " << pct(c.toneless, c.syllables) << "%  toned "
              << pct(c.toned, c.syllables) << "%  polyphones " << c.poly_ok << "/" << c.poly
              << " = " << pct(c.poly_ok, c.poly) << "%  zh15 visemes "
              << 100.0 - pct(c.vis_err, c.vis_ref) << "%\n";
    all.syllables += c.syllables;
    all.toneless += c.toneless;
    all.toned += c.toned;
    all.poly += c.poly;
    all.poly_ok += c.poly_ok;
    all.vis_ref += c.vis_ref;
    all.vis_err += c.vis_err;
  }
  std::cout << "ALL        syllables " << all.syllables << " toneless "
            << pct(all.toneless, all.syllables) << "%  toned " << pct(all.toned, all.syllables)
            << "%  polyphones " << all.poly_ok << "/" << all.poly << " = "
            << pct(all.poly_ok, all.poly) << "%  zh15 visemes "
            << 100.0 - pct(all.vis_err, all.vis_ref) << "%\n";
  std::cout << "\nsentences with a toneless error (" << failures.size() << "):\n";
  for (const auto& f : failures) std::cout << "  " << f << '\n';
  return 0;
}

// Substitutions / insertions / deletions between two sequences (for the confusion table).
void count_confusions(const std::vector<std::string>& ref, const std::vector<std::string>& got,
                      std::map<std::string, int>& confusions) {
  const std::size_t n = ref.size(), m = got.size();
  std::vector<std::vector<std::size_t>> dp(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) dp[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) dp[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j)
      dp[i][j] = std::min({dp[i - 1][j] + 1, dp[i][j - 1] + 1,
                           dp[i - 1][j - 1] + (ref[i - 1] == got[j - 1] ? 0 : 1)});
  for (std::size_t i = n, j = m; i > 0 || j > 0;) {
    if (i > 0 && j > 0 && dp[i][j] == dp[i - 1][j - 1] + (ref[i - 1] == got[j - 1] ? 0 : 1)) {
      if (ref[i - 1] != got[j - 1]) ++confusions[ref[i - 1] + " -> " + got[j - 1]];
      --i;
      --j;
    } else if (i > 0 && dp[i][j] == dp[i - 1][j] + 1) {
      ++confusions[ref[i - 1] + " -> (none)"];
      --i;
    } else {
      ++confusions["(none) -> " + got[j - 1]];
      --j;
    }
  }
}

int eval_en(const std::string& path, std::size_t n, const std::string& word_list,
            std::size_t offset, bool lexicon) {
  const en::Dictionary dict = en::read_cmu(path);
  std::set<std::string> allowed;
  if (!word_list.empty()) allowed = en::read_word_list(word_list);
  const auto words = en::sample(dict, n, offset, word_list.empty() ? nullptr : &allowed);
  std::map<std::string, int> confusions;
  en::Score total;
  std::vector<std::string> worst;
  for (const auto& w : words) {
    const en::WordScore s = en::score_word(dict, w, lexicon);
    count_confusions(s.ref, s.got, confusions);
    total.add(s);
    if (s.edits >= 2 && worst.size() < 25) {
      std::string r, g;
      for (const auto& x : s.ref) r += x + " ";
      for (const auto& x : s.got) g += x + " ";
      worst.push_back(w + ": ref " + r + "| got " + g);
    }
  }
  std::cout << std::fixed << std::setprecision(2) << "English words " << total.words
            << "  Oculus viseme error " << total.error_percent() << "%  (" << total.edits
            << " edits / " << total.ref_len << " reference visemes), words exact "
            << 100.0 * static_cast<double>(total.exact) / static_cast<double>(total.words) << "%\n";
  for (const auto& w : worst) std::cout << "  " << w << '\n';
  std::vector<std::pair<int, std::string>> top;
  for (const auto& [k, c] : confusions) top.emplace_back(-c, k);
  std::sort(top.begin(), top.end());
  std::cout << "most frequent differences (reference -> ours):\n";
  for (std::size_t i = 0; i < top.size() && i < 15; ++i)
    std::cout << "  " << std::setw(5) << -top[i].first << "  " << top[i].second << '\n';
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::vector<std::string> args(argv + 1, argv + argc);
    const auto flag = std::find(args.begin(), args.end(), "--no-lexicon");
    const bool lexicon = flag == args.end();
    if (!lexicon) args.erase(flag);
    const std::size_t n = args.size();
    const std::string mode = n > 0 ? args[0] : "";
    if (mode == "zh" && n == 2) return eval_zh(args[1]);
    if (mode == "en" && n >= 2)
      return eval_en(args[1], n > 2 ? std::stoul(args[2]) : 2000, n > 3 ? args[3] : "",
                     n > 4 ? std::stoul(args[4]) : 0, lexicon);
    std::cerr << "usage: eval_viseme zh SENTENCES.tsv | en CMUDICT [N [WORDLIST [OFFSET]]] "
                 "[--no-lexicon]\n";
    return 2;
  } catch (const facecast::Error& e) {
    std::cerr << "eval_viseme: " << e.what() << '\n';
    return 2;
  }
}
