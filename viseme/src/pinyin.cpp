#include "facecast/viseme/pinyin.hpp"

// GCC 12 reports a false -Wrestrict inside std::string::assign of a literal (GCC bug 105329).
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic ignored "-Wrestrict"
#endif

#include <algorithm>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "pinyin_detail.hpp"
#include "tables.hpp"

namespace facecast::viseme {
namespace {

bool contains(const std::vector<std::string>& v, std::string_view s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// Tone-marked vowels -> (base letter, tone).
struct Marked {
  char32_t cp;
  char base;
  int tone;
};
constexpr Marked kMarks[] = {
    {U'ā', 'a', 1}, {U'á', 'a', 2}, {U'ǎ', 'a', 3}, {U'à', 'a', 4}, {U'ē', 'e', 1}, {U'é', 'e', 2},
    {U'ě', 'e', 3}, {U'è', 'e', 4}, {U'ī', 'i', 1}, {U'í', 'i', 2}, {U'ǐ', 'i', 3}, {U'ì', 'i', 4},
    {U'ō', 'o', 1}, {U'ó', 'o', 2}, {U'ǒ', 'o', 3}, {U'ò', 'o', 4}, {U'ū', 'u', 1}, {U'ú', 'u', 2},
    {U'ǔ', 'u', 3}, {U'ù', 'u', 4}, {U'ǖ', 'v', 1}, {U'ǘ', 'v', 2}, {U'ǚ', 'v', 3}, {U'ǜ', 'v', 4},
    {U'ü', 'v', 0}, {U'ń', 'n', 2}, {U'ň', 'n', 3}, {U'ǹ', 'n', 4}, {U'ḿ', 'm', 2}, {U'ê', 'e', 0},
};

}  // namespace

std::vector<std::string> PinyinParts::phones() const {
  std::vector<std::string> out;
  for (const auto* p : {&initial, &medial, &nucleus, &coda})
    if (!p->empty()) out.push_back(*p);
  return out;
}

std::string numbered_pinyin(std::string_view marked) {
  std::string body;
  int tone = 0;
  for (std::size_t pos = 0; pos < marked.size();) {
    const char32_t c = next_code_point(marked, pos);
    const auto* m = std::find_if(std::begin(kMarks), std::end(kMarks),
                                 [c](const Marked& k) { return k.cp == c; });
    if (m != std::end(kMarks)) {
      body += m->base;
      if (m->tone) tone = m->tone;
    } else if (c >= '1' && c <= '5' && pos == marked.size()) {
      tone = static_cast<int>(c - '0');
    } else if (c == '0' && pos == marked.size()) {
      tone = 5;
    } else if (c < 0x80) {
      body += static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
    } else {
      throw Error("not pinyin: '" + std::string(marked) + "'");
    }
  }
  std::string out;
  for (std::size_t i = 0; i < body.size(); ++i) {
    if (body[i] == 'u' && i + 1 < body.size() && body[i + 1] == ':') {
      out += 'v';
      ++i;
    } else {
      out += body[i];
    }
  }
  out += static_cast<char>('0' + (tone == 0 ? 5 : tone));
  return out;
}

PinyinParts split_pinyin(std::string_view syllable) {
  const auto& t = detail::tables();
  const std::string numbered = numbered_pinyin(syllable);
  PinyinParts p;
  p.tone = numbered.back() - '0';
  std::string body = numbered.substr(0, numbered.size() - 1);
  const auto bad = [&] {
    return Error("not a Mandarin pinyin syllable: '" + std::string(syllable) + "'");
  };
  if (body.empty()) throw bad();

  if (contains(t.syllabic_initials, body)) {  // m, n, ng, hm, hng: syllabic nasals
    if (body == "ng" || body == "hng") {
      if (body == "hng") p.initial = "h";
      p.coda = "-ng";
    } else {
      p.initial.assign(body == "hm" ? std::string_view("m") : std::string_view(body));
    }
    return p;
  }
  for (const auto& ini : t.initials) {
    if (body.compare(0, ini.size(), ini) == 0) {
      p.initial = ini;
      break;
    }
  }
  std::string fin = body.substr(p.initial.size());
  const bool umlaut_initial =
      p.initial == "j" || p.initial == "q" || p.initial == "x" || p.initial == "y";
  if (umlaut_initial && !fin.empty() && fin[0] == 'u') fin[0] = 'v';
  if ((p.initial == "l" || p.initial == "n") && fin == "ue") fin = "ve";
  const auto it = t.finals.find(fin);
  if (it == t.finals.end() || (fin.empty() && p.initial.empty())) throw bad();
  if (fin.empty() && !contains(t.syllabic_initials, p.initial)) throw bad();
  p.medial = it->second[0];
  p.nucleus = it->second[1];
  p.coda = it->second[2];
  if (p.nucleus == "i" && p.medial.empty() && contains(t.apical_after, p.initial)) p.nucleus = "-i";
  return p;
}

bool is_pinyin(std::string_view syllable) {
  try {
    split_pinyin(syllable);
    return true;
  } catch (const Error&) {
    return false;
  }
}

std::vector<std::string> syllable_visemes(const PinyinParts& parts, VisemeSet set) {
  std::vector<std::string> out;
  for (const auto& m : detail::zh_phone_maps(parts))
    for (auto& v : m.in(set))
      if (out.empty() || out.back() != v) out.push_back(std::move(v));
  return out;
}

namespace detail {

std::vector<PhoneMap> zh_phone_maps(const PinyinParts& parts) {
  const auto& t = tables();
  const auto phones = parts.phones();
  std::vector<PhoneMap> out;
  for (std::size_t i = 0; i < phones.size(); ++i) {
    const bool rounded_y = i == 0 && parts.initial == "y" &&
                           (parts.medial == "v" || (parts.medial.empty() && parts.nucleus == "v"));
    out.push_back(rounded_y ? t.y_rounded : t.pinyin_units.at(phones[i]));
  }
  return out;
}

std::vector<double> zh_phone_weights(const PinyinParts& parts) {
  const auto& t = tables();
  const auto lookup = [](const auto& map, const std::string& key, double fallback) {
    const auto it = map.find(key);
    return it == map.end() ? fallback : it->second;
  };
  std::vector<double> w;
  if (!parts.initial.empty())
    w.push_back(lookup(t.initial_weight, t.pinyin_units.at(parts.initial).zh15.at(0), 1.0));
  if (!parts.medial.empty()) w.push_back(lookup(t.medial_weight, parts.medial, 0.6));
  if (!parts.nucleus.empty())
    w.push_back(lookup(t.nucleus_weight, parts.nucleus, t.nucleus_default_weight));
  if (!parts.coda.empty()) w.push_back(t.coda_weight);
  return w;
}

std::string toneless(std::string_view numbered) {
  std::string s(numbered);
  while (!s.empty() && s.back() >= '0' && s.back() <= '9') s.pop_back();
  return s;
}

}  // namespace detail
}  // namespace facecast::viseme
