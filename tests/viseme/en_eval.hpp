#pragma once
// English viseme accuracy against the CMU dictionary (eval_viseme and the text-accuracy test share
// it): words are read by the engine (the English lexicon's or espeak-ng's phonemes -> Oculus
// visemes), the dictionary's ARPAbet pronunciations are mapped through
// configs/viseme/phones_arpabet.json, consecutive repeats merge, and a word's error is the edit
// distance to its closest pronunciation. The error is edits over reference visemes. The reference
// (festival's cmudict-0.4) and the engine's lexicon (pocketsphinx's cmudict-en-us, 0.7-era) are
// two releases of one dictionary: with the lexicon the figure measures its coverage and agreement,
// on the words it lacks (or with it off) espeak-ng's letter-to-sound rules.
//
// Samples: the dictionary's words (a-z only, two letters or more) in byte order, every
// (count / n)-th from OFFSET % step, so OFFSETs 0..step-1 give disjoint samples. The context rules
// of phones_espeak_en.json were learned on OFFSET 0-9 of the whole dictionary (kTuningOffsets);
// other offsets are held out.
#include <algorithm>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "facecast/core/files.hpp"
#include "facecast/viseme/viseme.hpp"

namespace facecast::test::en {

namespace v = facecast::viseme;

using Dictionary = std::map<std::string, std::vector<std::vector<std::string>>>;

inline constexpr std::size_t kTuningOffsets = 10;  // OFFSET 0..9 of the whole dictionary

template <class T>
std::size_t edit_distance(const std::vector<T>& a, const std::vector<T>& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] =
          std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

inline std::vector<std::string> merged(std::vector<std::string> v) {
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

/// Festival's CMU lexicon: ("word" pos (((ph ph) 1) ((ph) 0))) -> word -> pronunciations.
inline Dictionary read_cmu(const std::string& path) {
  Dictionary dict;
  std::istringstream in(facecast::read_file(path));
  for (std::string line; std::getline(in, line);) {
    if (line.size() < 4 || line[0] != '(' || line[1] != '"') continue;
    const auto q = line.find('"', 2);
    const std::string word = line.substr(2, q - 2);
    if (!std::all_of(word.begin(), word.end(), [](char ch) { return ch >= 'a' && ch <= 'z'; }) ||
        word.size() < 2)
      continue;
    const auto body = line.find("(((", q);
    if (body == std::string::npos) continue;
    std::vector<std::string> phones;
    std::string tok;
    for (std::size_t i = body; i < line.size(); ++i) {
      const char ch = line[i];
      if (ch >= 'a' && ch <= 'z') {
        tok += ch;
      } else {
        if (!tok.empty()) phones.push_back(tok);
        tok.clear();
      }
    }
    dict[word].push_back(phones);
  }
  return dict;
}

/// The lines of a word list (e.g. /usr/share/dict/american-english).
inline std::set<std::string> read_word_list(const std::string& path) {
  std::set<std::string> out;
  std::istringstream in(facecast::read_file(path));
  for (std::string w; std::getline(in, w);) out.insert(w);
  return out;
}

/// Every (count / n)-th word of `dict` from `offset` (only words in `allowed` when it is given).
inline std::vector<std::string> sample(const Dictionary& dict, std::size_t n, std::size_t offset,
                                       const std::set<std::string>* allowed = nullptr) {
  std::vector<std::string> words;
  for (const auto& [w, p] : dict)
    if (!allowed || allowed->count(w)) words.push_back(w);
  const std::size_t step = std::max<std::size_t>(1, words.size() / n);
  std::vector<std::string> out;
  for (std::size_t i = offset % step; i < words.size() && out.size() < n; i += step)
    out.push_back(words[i]);
  return out;
}

inline std::vector<std::string> oculus_of_arpabet(const std::vector<std::string>& phones) {
  nlohmann::json j = nlohmann::json::array();
  double t = 0;
  for (const auto& p : phones) {
    j.push_back({{"phone", p}, {"start", t}, {"end", t + 0.1}});
    t += 0.1;
  }
  v::Options o;
  o.set = v::VisemeSet::kOculus;
  const auto u =
      v::import_timestamps(v::TimestampFormat::kJson, j.dump(), o, v::PhoneSet::kArpabet);
  std::vector<std::string> out;
  for (const auto& e : u.visemes) out.push_back(e.viseme);
  return merged(out);
}

/// The engine's Oculus visemes of one English word (pauses left out, repeats merged), read with
/// the English lexicon or by espeak-ng alone.
inline std::vector<std::string> oculus_of_word(const std::string& word, bool lexicon = true) {
  v::Options o;
  o.set = v::VisemeSet::kOculus;
  o.lang = v::LangMode::kEn;
  o.english_lexicon = lexicon;
  std::vector<std::string> got;
  for (const auto& e : v::analyze(word, o).visemes)
    if (e.viseme != "sil") got.push_back(e.viseme);
  return merged(got);
}

struct WordScore {
  std::size_t edits = 0, ref_len = 0;
  std::vector<std::string> ref, got;  // the closest pronunciation's visemes, ours
};

inline WordScore score_word(const Dictionary& dict, const std::string& word, bool lexicon = true) {
  WordScore s;
  s.got = oculus_of_word(word, lexicon);
  std::size_t best = SIZE_MAX;
  for (const auto& pron : dict.at(word)) {
    auto ref = oculus_of_arpabet(pron);
    const std::size_t e = edit_distance(ref, s.got);
    if (e < best) {
      best = e;
      s.ref = std::move(ref);
    }
  }
  s.edits = best;
  s.ref_len = s.ref.size();
  return s;
}

struct Score {
  std::size_t words = 0, exact = 0, edits = 0, ref_len = 0;
  double error_percent() const {
    return ref_len ? 100.0 * static_cast<double>(edits) / static_cast<double>(ref_len) : 0.0;
  }
  void add(const WordScore& w) {
    ++words;
    exact += w.edits == 0;
    edits += w.edits;
    ref_len += w.ref_len;
  }
};

inline Score score(const Dictionary& dict, const std::vector<std::string>& words) {
  Score s;
  for (const auto& w : words) s.add(score_word(dict, w));
  return s;
}

}  // namespace facecast::test::en
