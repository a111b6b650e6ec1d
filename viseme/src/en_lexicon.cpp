// The English lexicon: see en_lexicon.hpp and docs/algorithms.md#english-reading.
#include "en_lexicon.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <unordered_map>

#include "facecast/core/error.hpp"
#include "tables.hpp"

#ifndef FACECAST_PS_DICT
#define FACECAST_PS_DICT "/usr/share/pocketsphinx/model/en-us/cmudict-en-us.dict"
#endif

namespace facecast::viseme::detail {
namespace {

// The vowels of ARPAbet: the phones CMUdict gives a stress digit.
bool is_cmu_vowel(std::string_view p) {
  static constexpr std::string_view kVowels[] = {"AA", "AE", "AH", "AO", "AW", "AY", "EH", "ER",
                                                 "EY", "IH", "IY", "OW", "OY", "UH", "UW"};
  return std::find(std::begin(kVowels), std::end(kVowels), p) != std::end(kVowels);
}

// The lexicon's spelling of a word: ASCII lower case, the typographic apostrophe as '.
std::string key_of(std::string_view word) {
  std::string out;
  for (std::size_t i = 0; i < word.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(word[i]);
    if (word.compare(i, 3, "\xE2\x80\x99") == 0) {  // U+2019
      out += '\'';
      i += 2;
    } else {
      out += static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
    }
  }
  return out;
}

// The file's bytes, at most `max_bytes` of them (a larger file is refused, one that grows while
// it is read is cut at the size it had).
std::string read_bounded(const std::filesystem::path& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(path.string() + ": cannot open", ErrorCode::kNotFound);
  if (size > max_bytes)
    throw Error(path.string() + ": larger than " + std::to_string(max_bytes) + " bytes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open", ErrorCode::kNotFound);
  std::string out(static_cast<std::size_t>(size), '\0');
  in.read(out.data(), static_cast<std::streamsize>(out.size()));
  if (in.bad()) throw Error(path.string() + ": cannot read");
  out.resize(static_cast<std::size_t>(in.gcount()));
  return out;
}

// A phone of espeak-ng's reading in CMU phones: stress '1' primary, '2' secondary, '0' none
// (vowels), 0 (consonants).
struct Stressed {
  std::string phone;
  char stress = 0;
};

// espeak-ng's reading as CMU phones (configs/viseme/phones_espeak_cmu.json); a phone that stands
// for several gives its stress to the first vowel.
std::vector<Stressed> cmu_of_espeak(const std::vector<std::string>& espeak_phones) {
  std::vector<Stressed> out;
  for (std::string name : espeak_phones) {
    char stress = '0';
    while (!name.empty() && (name[0] == '\'' || name[0] == ',')) {
      if (stress != '1') stress = name[0] == '\'' ? '1' : '2';
      name.erase(0, 1);
    }
    const auto it = tables().espeak_cmu.find(name);
    if (it == tables().espeak_cmu.end()) continue;
    for (const auto& p : it->second) {
      const bool vowel = is_cmu_vowel(p);
      out.push_back({p, vowel ? stress : char(0)});
      if (vowel) stress = '0';
    }
  }
  return out;
}

// Edit-distance alignment of a pronunciation with espeak-ng's reading: its cost, and for each of
// the pronunciation's phones the reading's phone it is matched or substituted with (or npos). A
// vowel is never put against a consonant.
struct Alignment {
  double cost = 0;
  std::vector<std::size_t> to;
};

Alignment align(const std::vector<std::string>& pron, const std::vector<Stressed>& reading) {
  const std::size_t n = pron.size(), m = reading.size();
  const auto sub = [&](std::size_t i, std::size_t j) {
    if (pron[i] == reading[j].phone) return 0.0;
    return is_cmu_vowel(pron[i]) == is_cmu_vowel(reading[j].phone)
               ? 1.0
               : std::numeric_limits<double>::infinity();
  };
  std::vector<double> d((n + 1) * (m + 1));
  const auto at = [&](std::size_t i, std::size_t j) -> double& { return d[i * (m + 1) + j]; };
  for (std::size_t i = 0; i <= n; ++i) at(i, 0) = static_cast<double>(i);
  for (std::size_t j = 0; j <= m; ++j) at(0, j) = static_cast<double>(j);
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j)
      at(i, j) =
          std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + sub(i - 1, j - 1)});
  Alignment a;
  a.cost = at(n, m);
  a.to.assign(n, std::string::npos);
  for (std::size_t i = n, j = m; i > 0 || j > 0;) {
    if (i > 0 && j > 0 && at(i, j) == at(i - 1, j - 1) + sub(i - 1, j - 1)) {
      a.to[--i] = --j;
    } else if (i > 0 && at(i, j) == at(i - 1, j) + 1) {
      --i;
    } else {
      --j;
    }
  }
  return a;
}

}  // namespace

std::filesystem::path EnglishLexicon::default_path() {
  if (const char* e = std::getenv("FACECAST_EN_LEXICON"); e && *e) return e;
  return FACECAST_PS_DICT;
}

const EnglishLexicon& EnglishLexicon::get() {
  static const EnglishLexicon lexicon = [] {
    try {
      return load(default_path());
    } catch (const Error&) {
      return EnglishLexicon();  // missing or unreadable: espeak-ng reads every word
    }
  }();
  return lexicon;
}

EnglishLexicon EnglishLexicon::load(const std::filesystem::path& path) {
  const std::string text = read_bounded(path, kMaxFileBytes);
  EnglishLexicon lex;
  std::unordered_map<std::string, std::uint8_t> index;
  for (const auto& [cmu, phone] : tables().cmu_espeak) {
    if (cmu.find(' ') != std::string::npos) continue;
    index.emplace(cmu, static_cast<std::uint8_t>(lex.inventory_.size()));
    lex.inventory_.push_back(cmu);
  }
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  std::string codes;
  for (std::size_t at = 0; at < text.size() && lex.entries_.size() < kMaxEntries;) {
    const std::size_t eol = std::min(text.find('\n', at), text.size());
    const std::string_view line(text.data() + at, eol - at);
    at = eol + 1;
    std::size_t i = 0;
    while (i < line.size() && !is_space(line[i])) ++i;
    std::string_view word = line.substr(0, i);
    if (const auto paren = word.find('('); paren != std::string_view::npos && word.back() == ')')
      word = word.substr(0, paren);  // a variant: "read(2)"
    if (word.empty() || word.size() > kMaxWordBytes) continue;
    codes.clear();
    bool ok = true;
    while (ok && i < line.size()) {
      while (i < line.size() && is_space(line[i])) ++i;
      const std::size_t start = i;
      while (i < line.size() && !is_space(line[i])) ++i;
      if (i == start) break;
      const auto it = index.find(std::string(line.substr(start, i - start)));
      ok = it != index.end() && codes.size() < kMaxPhones;
      if (ok) codes += static_cast<char>(it->second);
    }
    if (!ok || codes.empty()) continue;
    const std::string key = key_of(word);
    lex.entries_.push_back({static_cast<std::uint32_t>(lex.words_.size()),
                            static_cast<std::uint32_t>(lex.phones_.size()),
                            static_cast<std::uint8_t>(key.size()),
                            static_cast<std::uint8_t>(codes.size())});
    lex.words_ += key;
    lex.phones_ += codes;
  }
  std::stable_sort(lex.entries_.begin(), lex.entries_.end(),
                   [&](const Entry& a, const Entry& b) { return lex.word_of(a) < lex.word_of(b); });
  lex.entries_.shrink_to_fit();
  lex.words_.shrink_to_fit();
  lex.phones_.shrink_to_fit();
  return lex;
}

std::pair<const EnglishLexicon::Entry*, const EnglishLexicon::Entry*> EnglishLexicon::find(
    std::string_view word) const {
  const std::string key = key_of(word);
  const std::string_view k = key;
  const Entry* const begin = entries_.data();
  const Entry* const end = begin + entries_.size();
  const Entry* lo = std::lower_bound(
      begin, end, k, [&](const Entry& e, std::string_view w) { return word_of(e) < w; });
  const Entry* hi = std::upper_bound(
      lo, end, k, [&](std::string_view w, const Entry& e) { return w < word_of(e); });
  return {lo, hi};
}

std::vector<std::vector<std::string>> EnglishLexicon::pronunciations(std::string_view word) const {
  std::vector<std::vector<std::string>> out;
  const auto [lo, hi] = find(word);
  for (const Entry* e = lo; e != hi; ++e) {
    std::vector<std::string> phones;
    for (std::size_t k = 0; k < e->phone_count; ++k)
      phones.push_back(inventory_[static_cast<unsigned char>(phones_[e->phones + k])]);
    out.push_back(std::move(phones));
  }
  return out;
}

bool EnglishLexicon::contains(std::string_view word) const {
  const auto [lo, hi] = find(word);
  return lo != hi;
}

std::size_t EnglishLexicon::memory_bytes() const {
  std::size_t n =
      sizeof(*this) + words_.capacity() + phones_.capacity() + entries_.capacity() * sizeof(Entry);
  for (const auto& p : inventory_) n += sizeof(p) + p.capacity();
  return n;
}

bool english_lexicon_applies(const Options& options) {
  return options.english_lexicon && options.en_voice.starts_with("en-us");
}

std::optional<std::vector<std::string>> lexicon_phones(
    const EnglishLexicon& lexicon, std::string_view word,
    const std::vector<std::string>& espeak_phones) {
  const std::vector<Stressed> reading = cmu_of_espeak(espeak_phones);
  const auto primary = std::find_if(reading.begin(), reading.end(),
                                    [](const Stressed& s) { return s.stress == '1'; });
  if (primary == reading.end()) return std::nullopt;
  const auto prons = lexicon.pronunciations(word);
  if (prons.empty()) return std::nullopt;
  // The pronunciation closest to espeak-ng's reading (the first of equals).
  std::size_t best = 0;
  Alignment a = align(prons[0], reading);
  for (std::size_t k = 1; k < prons.size(); ++k)
    if (Alignment b = align(prons[k], reading); b.cost < a.cost) {
      a = std::move(b);
      best = k;
    }
  if (a.cost == 0) return std::nullopt;  // espeak-ng reads it as the dictionary does
  const std::vector<std::string>& pron = prons[best];
  std::vector<char> stress(pron.size(), 0);
  bool has_primary = false;
  for (std::size_t i = 0; i < pron.size(); ++i) {
    if (!is_cmu_vowel(pron[i])) continue;
    stress[i] =
        a.to[i] != std::string::npos && reading[a.to[i]].stress ? reading[a.to[i]].stress : '0';
    has_primary = has_primary || stress[i] == '1';
  }
  if (!has_primary) {
    // espeak-ng's stressed vowel found no partner: the vowel aligned nearest to it takes it.
    const auto p = static_cast<std::size_t>(primary - reading.begin());
    std::size_t pick = std::string::npos, distance = std::string::npos;
    for (std::size_t i = 0; i < pron.size(); ++i) {
      if (!is_cmu_vowel(pron[i])) continue;
      const std::size_t d = a.to[i] == std::string::npos
                                ? pron.size() + reading.size()
                                : (a.to[i] > p ? a.to[i] - p : p - a.to[i]);
      if (pick == std::string::npos || d < distance) pick = i, distance = d;
    }
    if (pick == std::string::npos) return std::nullopt;  // no vowel at all ("hmm" is M)
    stress[pick] = '1';
  }
  // CMU phones -> espeak-ng phones, a pair first (AA R -> A@).
  const Tables& t = tables();
  std::vector<std::string> out;
  for (std::size_t i = 0; i < pron.size();) {
    std::string phone;
    std::size_t used = 1;
    char s = stress[i];
    if (i + 1 < pron.size())
      if (const auto it = t.cmu_espeak.find(pron[i] + " " + pron[i + 1]);
          it != t.cmu_espeak.end()) {
        phone = it->second;
        used = 2;
        if (stress[i + 1] == '1' || (stress[i + 1] == '2' && s != '1')) s = stress[i + 1];
      }
    if (phone.empty()) {
      const auto un = t.cmu_espeak_unstressed.find(pron[i]);
      phone =
          s == '0' && un != t.cmu_espeak_unstressed.end() ? un->second : t.cmu_espeak.at(pron[i]);
    }
    out.push_back(s == '1' ? "'" + phone : s == '2' ? "," + phone : phone);
    i += used;
  }
  return out;
}

std::string espeak_phoneme_input(const std::vector<std::string>& phones) {
  std::string s = "[[";
  for (std::size_t i = 0; i < phones.size(); ++i) s += (i ? "|" : "") + phones[i];
  return s + "]]";
}

}  // namespace facecast::viseme::detail
