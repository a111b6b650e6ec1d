// Shared by the timestamp importers: field readers, phone sets, labels -> Utterance.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "import_detail.hpp"
#include "pinyin_detail.hpp"
#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme::detail {

using nlohmann::json;

namespace {

constexpr double kLastEventSeconds = 0.1;  // length given to a final event that has no end

std::string fmt_time(double t) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << t << " s";
  return s.str();
}

bool is_silence(const std::string& label) {
  static const char* kSilence[] = {"",    "sil", "sp", "spn",   "<eps>",
                                   "pau", "_",   "#",  "<sil>", "silence"};
  const std::string l = lower(label);
  return std::any_of(std::begin(kSilence), std::end(kSilence),
                     [&](const char* s) { return l == s; });
}

// ----- phone sets -------------------------------------------------------------------------------

std::string strip_stress(std::string s) {
  while (!s.empty() && std::isdigit(static_cast<unsigned char>(s.back()))) s.pop_back();
  return lower(s);
}

// IPA without length, tone letters, digits and modifier/combining marks.
std::string strip_ipa(const std::string& s) {
  std::string out;
  for (std::size_t pos = 0; pos < s.size();) {
    const char32_t c = next_code_point(s, pos, false);
    const bool mark =
        (c >= 0x0300 && c <= 0x036F) || (c >= 0x02B0 && c <= 0x02FF) || (c >= '0' && c <= '9');
    if (!mark) append_utf8(out, c);
  }
  return out;
}

const PhoneMap* find_phone(const std::string& label, PhoneSet set) {
  const auto& t = detail::tables();
  const auto find = [](const PhoneTable& table, const std::string& key) -> const PhoneMap* {
    const auto it = table.find(key);
    return it == table.end() ? nullptr : &it->second;
  };
  switch (set) {
    case PhoneSet::kArpabet:
      return find(t.arpabet, strip_stress(label));
    case PhoneSet::kEspeak: {
      std::string s = label;
      while (!s.empty() && (s[0] == '\'' || s[0] == ',')) s.erase(0, 1);
      return find(t.espeak_en, s);
    }
    case PhoneSet::kIpa: {
      if (const PhoneMap* m = find(t.ipa, label)) return m;
      return find(t.ipa, strip_ipa(label));
    }
    default:
      return nullptr;
  }
}

bool known(const std::string& label, PhoneSet set) {
  if (set == PhoneSet::kPinyin) return is_pinyin(label);
  return find_phone(label, set) != nullptr;
}

PhoneSet detect_phone_set(const std::vector<Label>& labels) {
  for (PhoneSet s : {PhoneSet::kPinyin, PhoneSet::kArpabet, PhoneSet::kEspeak, PhoneSet::kIpa}) {
    const bool all = std::all_of(labels.begin(), labels.end(), [&](const Label& l) {
      return is_silence(l.text) || known(l.text, s);
    });
    if (all) return s;
  }
  return PhoneSet::kIpa;  // reports the first unknown phone
}

const char* lang_of(PhoneSet s) {
  switch (s) {
    case PhoneSet::kPinyin:
      return "zh";
    case PhoneSet::kArpabet:
      return "arpabet";
    case PhoneSet::kEspeak:
      return "en";
    default:
      return "ipa";
  }
}

VisemeSet resolve_set(const Options& o, bool chinese) {
  return o.set.value_or(chinese ? VisemeSet::kZh15 : VisemeSet::kOculus);
}

void add_visemes(Utterance& u, const PhoneMap& m, Span s) {
  const auto visemes = m.in(u.set);
  const double step =
      (s.end - s.start) / static_cast<double>(std::max<std::size_t>(1, visemes.size()));
  for (std::size_t i = 0; i < visemes.size(); ++i)
    detail::append_viseme(
        u.visemes, visemes[i],
        {s.start + step * static_cast<double>(i), s.start + step * static_cast<double>(i + 1)},
        u.set);
}

}  // namespace

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

json parse_json(std::string_view content, const std::string& source) {
  try {
    return json::parse(content);
  } catch (const json::parse_error& e) {
    throw Error(source + ": invalid JSON at byte " + std::to_string(e.byte));
  } catch (const json::exception&) {  // out_of_range: a number too large for a double
    throw Error(source + ": invalid JSON: a number is out of range");
  }
}

double number(const json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key) || !j.at(key).is_number())
    throw Error(where + ": missing number '" + key + "'");
  const double v = j.at(key).get<double>();
  if (!std::isfinite(v)) throw Error(where + ": '" + key + "' is not finite");
  return v;
}

std::string string_field(const json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw Error(where + ": missing field '" + key + "'");
  const json& v = j.at(key);
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  throw Error(where + ": field '" + key + "' must be a string");
}

void check_span(const Label& l) {
  if (!(l.start >= 0) || !(l.end >= l.start) || !std::isfinite(l.end))
    throw Error(l.where + ": invalid times " + std::to_string(l.start) + " .. " +
                std::to_string(l.end));
}

// Lines of text or NDJSON, with 1-based numbers; blank lines skipped.
std::vector<std::pair<std::size_t, std::string>> lines_of(std::string_view content) {
  std::vector<std::pair<std::size_t, std::string>> out;
  std::istringstream in{std::string(content)};
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") != std::string::npos) out.emplace_back(n, line);
  }
  return out;
}

bool starts_json(std::string_view content) {
  const auto p = content.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  return p != std::string_view::npos && (content[p] == '{' || content[p] == '[');
}

Utterance from_phones(std::vector<Label> phones, std::vector<Label> words, PhoneSet set,
                      const Options& options) {
  for (const auto& l : phones) check_span(l);
  std::vector<Label> spoken;
  for (auto& l : phones)
    if (!is_silence(l.text)) spoken.push_back(l);
  if (set == PhoneSet::kAuto) set = detect_phone_set(spoken);
  Utterance u;
  u.set = resolve_set(options, set == PhoneSet::kPinyin);
  for (const auto& l : spoken) {
    u.duration = std::max(u.duration, l.end);
    if (set == PhoneSet::kPinyin) {
      if (!is_pinyin(l.text))
        throw Error(l.where + ": unknown pinyin syllable '" + l.text + "' at " + fmt_time(l.start));
      const std::string py = numbered_pinyin(l.text);
      const auto plan_phones = detail::chinese_phones(py, l.end - l.start);
      const auto spans = detail::spread(plan_phones, {l.start, l.end});
      for (std::size_t i = 0; i < plan_phones.size(); ++i) {
        u.phones.push_back({plan_phones[i].name, spans[i].start, spans[i].end, "zh"});
        add_visemes(u, plan_phones[i].map, spans[i]);
      }
      u.syllables.push_back({"", py, l.start, l.end});
    } else {
      const PhoneMap* m = find_phone(l.text, set);
      if (!m)
        throw Error(l.where + ": unknown " + lang_of(set) + " phone '" + l.text + "' at " +
                    fmt_time(l.start));
      u.phones.push_back({l.text, l.start, l.end, lang_of(set)});
      add_visemes(u, *m, {l.start, l.end});
    }
  }
  for (const auto& w : words) {
    check_span(w);
    if (!is_silence(w.text)) u.words.push_back({w.text, w.start, w.end});
    u.duration = std::max(u.duration, w.end);
  }
  for (const auto& l : phones) u.duration = std::max(u.duration, l.end);
  return u;
}

Utterance from_visemes(const std::vector<Label>& cues, const PhoneTable& table, const char* engine,
                       const Options& options) {
  Utterance u;
  u.set = resolve_set(options, false);
  for (const auto& c : cues) {
    check_span(c);
    const auto it = table.find(c.text);
    if (it == table.end())
      throw Error(c.where + ": unknown " + engine + " viseme '" + c.text + "' at " +
                  fmt_time(c.start));
    const auto visemes = it->second.in(u.set);
    if (!(visemes.size() == 1 && visemes[0] == detail::silence_viseme(u.set)))
      add_visemes(u, it->second, {c.start, c.end});
    u.duration = std::max(u.duration, c.end);
  }
  return u;
}

void close_spans(std::vector<Label>& cues) {
  std::stable_sort(cues.begin(), cues.end(),
                   [](const Label& a, const Label& b) { return a.start < b.start; });
  for (std::size_t i = 0; i < cues.size(); ++i)
    cues[i].end = i + 1 < cues.size() ? cues[i + 1].start : cues[i].start + kLastEventSeconds;
}

}  // namespace facecast::viseme::detail
