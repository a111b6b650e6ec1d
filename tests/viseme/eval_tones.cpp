// eval_tones: Facecast's toned reading of Chinese beside another system's, against a reference.
//   eval_tones tests/viseme/eval/zh_tones.tsv [OTHER.tsv NAME] [--failures] [--ignore-yi-bu]
// SET.tsv and the figures printed: tones_eval.hpp. OTHER.tsv: text <TAB> that system's pinyin
// (tests/viseme/eval/pinyin_pro.mjs makes it for pinyin-pro). --ignore-yi-bu scores 一 and 不
// without their tone (for sets that write them with sandhi, like zh_sentences.tsv).
#include <iomanip>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "facecast/viseme/pinyin.hpp"
#include "tones_eval.hpp"

namespace v = facecast::viseme;
namespace t = facecast::test::tones;

namespace {

void print(const std::string& system, const std::map<std::string, t::Score>& by_cat) {
  t::Score all;
  const auto row = [&](const std::string& cat, const t::Score& s) {
    std::cout << std::left << std::setw(11) << system << std::setw(8) << cat << " syllables "
              << std::setw(4) << s.syllables << " toned " << std::setw(5)
              << t::pct(s.toned, s.syllables) << "%  neutral " << s.neutral_ok << "/" << s.neutral
              << " = " << t::pct(s.neutral_ok, s.neutral) << "%  false 5: " << s.false5
              << "  polyphones " << s.poly_ok << "/" << s.poly << " = " << t::pct(s.poly_ok, s.poly)
              << "%  tone-poly " << s.tone_poly_ok << "/" << s.tone_poly << " = "
              << t::pct(s.tone_poly_ok, s.tone_poly) << "%\n";
  };
  for (const auto& [cat, s] : by_cat) {
    row(cat, s);
    all.add(s);
  }
  row("ALL", all);
}

int run(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  bool show_failures = false, ignore_yi_bu = false;
  std::erase_if(args, [&](const std::string& a) {
    if (a == "--failures") return show_failures = true;
    if (a == "--ignore-yi-bu") return ignore_yi_bu = true;
    return false;
  });
  if (args.size() != 1 && args.size() != 3) {
    std::cerr << "usage: eval_tones SET.tsv [OTHER.tsv NAME] [--failures] [--ignore-yi-bu]\n";
    return 2;
  }
  std::size_t skipped = 0;
  const std::vector<t::Line> lines = t::read_set(args[0], &skipped);
  std::map<std::string, std::vector<std::string>> other;
  if (args.size() == 3)
    for (const auto& raw : t::split(facecast::read_file(args[1]), '\n')) {
      const auto f = t::split(raw, '\t');
      if (f.size() == 2) other[f[0]] = t::split(f[1], ' ');
    }
  std::map<std::string, t::Score> ours, theirs;
  std::vector<std::string> failures;
  for (const auto& l : lines) {
    t::score(l, v::to_pinyin(l.text), ours[l.cat], ignore_yi_bu, &failures);
    if (args.size() == 3) {
      const auto it = other.find(l.text);
      if (it == other.end()) throw facecast::Error(args[1] + ": no reading of " + l.text);
      t::score(l, it->second, theirs[l.cat], ignore_yi_bu, nullptr);
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
