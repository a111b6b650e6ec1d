#include "lexicon.hpp"

#include <bzlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/install.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "pinyin_detail.hpp"

namespace facecast::viseme::detail {
namespace {

constexpr std::string_view kMagic = "facecast-zh-lexicon 1";
const std::vector<std::string> kNone;

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == sep) {
      if (i > start) out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return out;
}

template <class F>
void for_each_line(std::string_view text, F&& f) {
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    f(line);
    start = end + 1;
  }
}

// rime writes lüe as "lue"/"nue"; we write u-umlaut as v.
std::string normalize_rime_syllable(std::string_view s) {
  if ((s == "lue" || s == "nue")) return std::string(1, s[0]) + "ve";
  return std::string(s);
}

void add_reading(std::vector<std::string>& list, std::string_view marked) {
  std::string numbered;
  try {
    numbered = numbered_pinyin(marked);
  } catch (const Error&) {
    return;  // a reading Unihan spells in a form we do not use
  }
  if (std::find(list.begin(), list.end(), numbered) == list.end()) list.push_back(numbered);
}

// Unihan_Readings -> numbered readings in preference order.
std::unordered_map<char32_t, std::vector<std::string>> parse_unihan(const std::string& text) {
  // field -> char -> raw value
  std::map<std::string, std::unordered_map<char32_t, std::string>, std::less<>> fields;
  for_each_line(text, [&](std::string_view line) {
    if (line.size() < 3 || line[0] != 'U') return;
    const auto parts = split(line, '\t');
    if (parts.size() < 3) return;
    const std::string_view field = parts[1];
    if (field != "kHanyuPinlu" && field != "kMandarin" && field != "kTGHZ2013" &&
        field != "kXHC1983" && field != "kHanyuPinyin")
      return;
    unsigned cp = 0;
    std::from_chars(parts[0].data() + 2, parts[0].data() + parts[0].size(), cp, 16);
    fields[std::string(field)][static_cast<char32_t>(cp)] = std::string(parts[2]);
  });
  std::unordered_map<char32_t, std::vector<std::string>> out;
  // kHanyuPinlu: "le(30101) liǎo(654)" sorted by frequency.
  for (const auto& [cp, value] : fields["kHanyuPinlu"]) {
    std::vector<std::pair<long, std::string>> items;
    for (auto item : split(value, ' ')) {
      const auto paren = item.find('(');
      long freq = 0;
      if (paren != std::string_view::npos)
        std::from_chars(item.data() + paren + 1, item.data() + item.size() - 1, freq);
      items.emplace_back(-freq, std::string(item.substr(0, paren)));
    }
    std::stable_sort(items.begin(), items.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [f, r] : items) add_reading(out[cp], r);
  }
  for (const auto& [cp, value] : fields["kMandarin"])
    for (auto r : split(value, ' ')) add_reading(out[cp], r);
  // kTGHZ2013 / kXHC1983 / kHanyuPinyin: "loc:reading[,reading] loc:reading".
  for (const char* f : {"kTGHZ2013", "kXHC1983", "kHanyuPinyin"}) {
    for (const auto& [cp, value] : fields[f]) {
      for (auto entry : split(value, ' ')) {
        const auto colon = entry.find(':');
        if (colon == std::string_view::npos) continue;
        for (auto r : split(entry.substr(colon + 1), ',')) add_reading(out[cp], r);
      }
    }
  }
  return out;
}

std::uintmax_t size_of(const std::filesystem::path& p) {
  std::error_code ec;
  const auto s = std::filesystem::file_size(p, ec);
  return ec ? 0 : s;
}

}  // namespace

std::string read_maybe_bz2(const std::filesystem::path& path) {
  if (path.extension() != ".bz2") return read_file(path);
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(path.string() + ": cannot open", ErrorCode::kNotFound);
  int err = BZ_OK;
  BZFILE* bz = BZ2_bzReadOpen(&err, f, 0, 0, nullptr, 0);
  std::string out;
  char buf[1 << 16];
  while (err == BZ_OK) {
    const int n = BZ2_bzRead(&err, bz, buf, sizeof buf);
    if (n > 0) out.append(buf, static_cast<std::size_t>(n));
  }
  BZ2_bzReadClose(nullptr, bz);
  std::fclose(f);
  if (err != BZ_STREAM_END) throw Error(path.string() + ": corrupt bzip2 data");
  return out;
}

Lexicon::Sources Lexicon::default_sources() {
  Sources s{FACECAST_RIME_DICT, FACECAST_UNIHAN_READINGS};
  if (const char* e = std::getenv("FACECAST_RIME_DICT"); e && *e) s.rime_dict = e;
  if (const char* e = std::getenv("FACECAST_UNIHAN_READINGS"); e && *e) s.unihan_readings = e;
  return s;
}

std::filesystem::path Lexicon::default_cache() {
  if (const char* e = std::getenv("FACECAST_ZH_LEXICON"); e && *e) return e;
  if (const auto share = installed_share_dir(); !share.empty()) return share / "zh_lexicon.txt";
  return FACECAST_ZH_LEXICON_CACHE;
}

const Lexicon& Lexicon::get() {
  static const Lexicon lex = [] {
    const Sources src = default_sources();
    const auto cache = default_cache();
    if (std::filesystem::exists(cache)) {
      Lexicon l = load(cache);
      const bool have_sources = std::filesystem::exists(src.rime_dict);
      if (!have_sources || l.matches(src)) return l;
    }
    return compile(src);
  }();
  return lex;
}

Lexicon Lexicon::compile(const Sources& sources) {
  Lexicon lex;
  lex.rime_size_ = size_of(sources.rime_dict);
  lex.unihan_size_ = size_of(sources.unihan_readings);
  lex.readings_ = parse_unihan(read_maybe_bz2(sources.unihan_readings));

  // rime: "word\tpin yin\tweight" after the "..." line; a word may have several readings.
  struct Acc {
    double total = 0, best = -1;
    std::vector<std::string> py;
  };
  std::unordered_map<std::string, Acc> acc;
  const std::string rime = read_file(sources.rime_dict);
  bool body = false;
  double grand_total = 0;
  for_each_line(rime, [&](std::string_view line) {
    if (!body) {
      body = line == "...";
      return;
    }
    const auto parts = split(line, '\t');
    if (parts.size() < 2 || parts[0].front() == '#') return;
    const std::u32string chars = to_u32(parts[0]);
    const auto sylls = split(parts[1], ' ');
    if (chars.size() != sylls.size() ||
        !std::all_of(chars.begin(), chars.end(), [](char32_t c) { return is_han(c); }))
      return;
    double w = 0;
    if (parts.size() > 2) std::from_chars(parts[2].data(), parts[2].data() + parts[2].size(), w);
    w += 0.5;  // rime lists rare words with weight 0
    Acc& a = acc[std::string(parts[0])];
    a.total += w;
    grand_total += w;
    if (w > a.best) {
      a.best = w;
      a.py.clear();
      for (auto s : sylls) a.py.push_back(normalize_rime_syllable(s));
    }
  });
  if (acc.empty()) throw Error(sources.rime_dict.string() + ": no dictionary entries found");
  lex.unknown_cost_ = static_cast<float>(-std::log(0.1 / grand_total));
  for (auto& [word, a] : acc) {
    lex.max_len_ = std::max(lex.max_len_, a.py.size());
    lex.words_.emplace(
        word, Entry{static_cast<float>(-std::log(a.total / grand_total)), std::move(a.py)});
  }
  return lex;
}

void Lexicon::save(const std::filesystem::path& cache) const {
  write_file_atomic(cache, [&](std::ostream& out) {
    out << kMagic << '\n'
        << "# Generated by facecast_viseme_lexgen from rime-data-pinyin-simp's "
           "pinyin_simp.dict.yaml "
           "and unicode-data's Unihan_Readings.txt; do not edit.\n"
        << "S " << rime_size_ << ' ' << unihan_size_ << ' ' << unknown_cost_ << ' ' << max_len_
        << '\n';
    std::map<char32_t, const std::vector<std::string>*> chars;  // sorted: stable output
    for (const auto& [c, r] : readings_) chars.emplace(c, &r);
    for (const auto& [c, r] : chars) {
      out << "R " << to_utf8(c);
      for (const auto& s : *r) out << ' ' << s;
      out << '\n';
    }
    std::map<std::string_view, const Entry*> words;
    for (const auto& [w, e] : words_) words.emplace(w, &e);
    for (const auto& [w, e] : words) {
      out << "W " << w << ' ' << e->cost;
      for (const auto& s : e->py) out << ' ' << s;
      out << '\n';
    }
  });
}

Lexicon Lexicon::load(const std::filesystem::path& cache) {
  const std::string text = read_file(cache);
  if (text.compare(0, kMagic.size(), kMagic) != 0)
    throw Error(cache.string() + ": not a Facecast Chinese lexicon cache");
  Lexicon lex;
  std::size_t line_no = 0;
  for_each_line(text, [&](std::string_view line) {
    ++line_no;
    if (line.size() < 2 || line[1] != ' ') return;
    const auto parts = split(line.substr(2), ' ');
    const auto bad = [&] {
      return Error(cache.string() + ":" + std::to_string(line_no) + ": malformed entry");
    };
    if (line[0] == 'S' && parts.size() == 4) {
      std::from_chars(parts[0].data(), parts[0].data() + parts[0].size(), lex.rime_size_);
      std::from_chars(parts[1].data(), parts[1].data() + parts[1].size(), lex.unihan_size_);
      std::from_chars(parts[2].data(), parts[2].data() + parts[2].size(), lex.unknown_cost_);
      std::from_chars(parts[3].data(), parts[3].data() + parts[3].size(), lex.max_len_);
    } else if (line[0] == 'R' && !parts.empty()) {
      std::size_t pos = 0;
      const char32_t c = next_code_point(parts[0], pos);
      auto& list = lex.readings_[c];
      for (std::size_t i = 1; i < parts.size(); ++i) list.emplace_back(parts[i]);
    } else if (line[0] == 'W' && parts.size() >= 3) {
      Entry e;
      if (std::from_chars(parts[1].data(), parts[1].data() + parts[1].size(), e.cost).ec !=
          std::errc())
        throw bad();
      for (std::size_t i = 2; i < parts.size(); ++i) e.py.emplace_back(parts[i]);
      lex.words_.emplace(std::string(parts[0]), std::move(e));
    }
  });
  if (lex.words_.empty()) throw Error(cache.string() + ": empty lexicon cache");
  return lex;
}

bool Lexicon::matches(const Sources& sources) const {
  return size_of(sources.rime_dict) == rime_size_ &&
         size_of(sources.unihan_readings) == unihan_size_;
}

std::vector<Lexicon::Segment> Lexicon::segment(std::u32string_view run) const {
  const std::size_t n = run.size();
  // UTF-8 of the run with the byte offset of each character, for allocation-free lookups.
  std::string utf8;
  std::vector<std::size_t> at(n + 1);
  for (std::size_t i = 0; i < n; ++i) {
    at[i] = utf8.size();
    append_utf8(utf8, run[i]);
  }
  at[n] = utf8.size();

  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> best(n + 1, kInf);
  std::vector<std::size_t> from(n + 1, 0);
  std::vector<const Entry*> entry(n + 1, nullptr);
  best[0] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (best[i] == kInf) continue;
    for (std::size_t len = 1; len <= max_len_ && i + len <= n; ++len) {
      const std::string_view key(utf8.data() + at[i], at[i + len] - at[i]);
      const auto it = words_.find(key);
      const Entry* e = it == words_.end() ? nullptr : &it->second;
      if (!e && len > 1) continue;
      const float cost = best[i] + (e ? e->cost : unknown_cost_);
      if (cost < best[i + len]) {
        best[i + len] = cost;
        from[i + len] = i;
        entry[i + len] = e;
      }
    }
  }
  std::vector<Segment> out;
  for (std::size_t end = n; end > 0; end = from[end]) {
    Segment s{from[end], end, {}};
    if (entry[end]) {
      s.toneless = entry[end]->py;
    } else {  // unknown character: its most common Unihan reading
      const auto& r = readings(run[s.begin]);
      s.toneless.push_back(r.empty() ? std::string() : toneless(r.front()));
    }
    out.push_back(std::move(s));
  }
  std::reverse(out.begin(), out.end());
  return out;
}

const std::vector<std::string>& Lexicon::readings(char32_t c) const {
  const auto it = readings_.find(c);
  return it == readings_.end() ? kNone : it->second;
}

std::string Lexicon::tone(char32_t c, std::string_view bare, bool allow_neutral) const {
  const auto& list = readings(c);
  for (int pass = 0; pass < 2; ++pass) {
    for (const auto& r : list) {
      if (toneless(r) != bare) continue;
      if (r.back() == '5' && !allow_neutral && pass == 0) continue;
      return r;
    }
  }
  return std::string(bare) + "5";
}

bool Lexicon::has_reading(char32_t c, std::string_view bare) const {
  for (const auto& r : readings(c))
    if (toneless(r) == bare) return true;
  const auto it = words_.find(to_utf8(c));
  return it != words_.end() && !it->second.py.empty() && it->second.py[0] == bare;
}

}  // namespace facecast::viseme::detail
