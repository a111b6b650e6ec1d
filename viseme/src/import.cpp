// Phoneme / viseme timestamps from TTS engines and aligners -> Utterance.
#include "facecast/viseme/import.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "facecast/core/error.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "pinyin_detail.hpp"
#include "plan.hpp"
#include "tables.hpp"
#include "timeline.hpp"
#include "utf8.hpp"

namespace facecast::viseme {
namespace {

using detail::PhoneMap;
using detail::PhoneTable;
using detail::Span;
using nlohmann::json;

constexpr double kLastEventSeconds = 0.1;  // length given to a final event that has no end

// A timed label from a file, and where it came from (for error messages).
struct Label {
  std::string text;
  double start = 0, end = 0;
  std::string where;
};

std::string fmt_time(double t) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << t << " s";
  return s.str();
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_silence(const std::string& label) {
  static const char* kSilence[] = {"",    "sil", "sp", "spn",   "<eps>",
                                   "pau", "_",   "#",  "<sil>", "silence"};
  const std::string l = lower(label);
  return std::any_of(std::begin(kSilence), std::end(kSilence),
                     [&](const char* s) { return l == s; });
}

json parse_json(std::string_view content, const std::string& source) {
  try {
    return json::parse(content);
  } catch (const json::parse_error& e) {
    throw Error(source + ": invalid JSON at byte " + std::to_string(e.byte));
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

// ----- phone sets -------------------------------------------------------------------------------

std::string strip_stress(std::string s) {
  while (!s.empty() && std::isdigit(static_cast<unsigned char>(s.back()))) s.pop_back();
  return lower(s);
}

// IPA without length, tone letters, digits and modifier/combining marks.
std::string strip_ipa(const std::string& s) {
  std::string out;
  for (std::size_t pos = 0; pos < s.size();) {
    const char32_t c = detail::next_code_point(s, pos, false);
    const bool mark =
        (c >= 0x0300 && c <= 0x036F) || (c >= 0x02B0 && c <= 0x02FF) || (c >= '0' && c <= '9');
    if (!mark) detail::append_utf8(out, c);
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

// ----- building the utterance -------------------------------------------------------------------

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

// Viseme labels of another engine (table from visemes_external.json).
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

// Point events (start only) -> spans ending at the next event.
void close_spans(std::vector<Label>& cues) {
  std::stable_sort(cues.begin(), cues.end(),
                   [](const Label& a, const Label& b) { return a.start < b.start; });
  for (std::size_t i = 0; i < cues.size(); ++i)
    cues[i].end = i + 1 < cues.size() ? cues[i + 1].start : cues[i].start + kLastEventSeconds;
}

// ----- formats ----------------------------------------------------------------------------------

Utterance import_json(std::string_view content, const Options& o, PhoneSet set,
                      const std::string& src) {
  const json j = parse_json(content, src);
  const json* list = &j;
  if (j.is_object()) {
    if (!j.contains("phones"))
      throw Error(src + ": expected a list of {phone, start, end} or {\"phones\": [...]}");
    list = &j.at("phones");
  }
  if (!list->is_array()) throw Error(src + ": 'phones' must be an array");
  std::vector<Label> phones, words;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const std::string where = src + ": phones[" + std::to_string(i) + "]";
    const json& e = (*list)[i];
    phones.push_back({string_field(e, "phone", where), number(e, "start", where),
                      number(e, "end", where), where});
  }
  if (j.is_object() && j.contains("words") && j.at("words").is_array()) {
    const json& w = j.at("words");
    for (std::size_t i = 0; i < w.size(); ++i) {
      const std::string where = src + ": words[" + std::to_string(i) + "]";
      const char* key = w[i].contains("word") ? "word" : "text";
      words.push_back({string_field(w[i], key, where), number(w[i], "start", where),
                       number(w[i], "end", where), where});
    }
  }
  Utterance u = from_phones(std::move(phones), std::move(words), set, o);
  if (j.is_object()) u.text = j.value("text", "");
  return u;
}

Utterance import_azure(std::string_view content, const Options& o, const std::string& src) {
  std::vector<std::pair<std::string, json>> events;  // where, event
  if (starts_json(content) && content.find_first_not_of(" \t\r\n") != std::string_view::npos &&
      content[content.find_first_not_of(" \t\r\n")] == '[') {
    const json j = parse_json(content, src);
    for (std::size_t i = 0; i < j.size(); ++i)
      events.emplace_back(src + ": item " + std::to_string(i), j[i]);
  } else {
    for (const auto& [n, line] : lines_of(content))
      events.emplace_back(src + ":" + std::to_string(n),
                          parse_json(line, src + ":" + std::to_string(n)));
  }
  std::vector<Label> cues;
  for (const auto& [where, e] : events) {
    const char* offset = e.contains("AudioOffset") ? "AudioOffset" : "audioOffset";
    const char* id = e.contains("VisemeId") ? "VisemeId" : "visemeId";
    const double ticks = number(e, offset, where);
    cues.push_back({string_field(e, id, where), ticks / 1e7, 0, where});  // 100 ns ticks
  }
  close_spans(cues);
  return from_visemes(cues, detail::tables().azure, "Azure", o);
}

Utterance import_polly(std::string_view content, const Options& o, const std::string& src) {
  std::vector<Label> visemes, words;
  for (const auto& [n, line] : lines_of(content)) {
    const std::string where = src + ":" + std::to_string(n);
    const json e = parse_json(line, where);
    const std::string type = string_field(e, "type", where);
    const double t = number(e, "time", where) / 1000.0;  // milliseconds
    if (type == "viseme") visemes.push_back({string_field(e, "value", where), t, 0, where});
    if (type == "word") words.push_back({string_field(e, "value", where), t, 0, where});
  }
  close_spans(visemes);
  // A word lasts until the next word starts, or to the end of the last viseme.
  const double end = visemes.empty() ? 0 : visemes.back().start;
  std::stable_sort(words.begin(), words.end(),
                   [](const Label& a, const Label& b) { return a.start < b.start; });
  for (std::size_t i = 0; i < words.size(); ++i)
    words[i].end = i + 1 < words.size() ? words[i + 1].start : std::max(words[i].start, end);
  // Trailing silence marks end the speech: the last event gets no extra length when it is "sil".
  if (!visemes.empty() && visemes.back().text == "sil") visemes.back().end = visemes.back().start;
  Utterance u = from_visemes(visemes, detail::tables().polly, "Polly", o);
  for (const auto& w : words) u.words.push_back({w.text, w.start, w.end});
  return u;
}

// Praat TextGrid (long or short text format) -> tiers of labels.
struct Tier {
  std::string name;
  std::vector<Label> intervals;
};

std::vector<Tier> parse_textgrid(std::string_view content, const std::string& src) {
  // Both formats are the same sequence of values; the long one adds "key =" labels and "[n]".
  std::vector<std::string> tokens;
  std::vector<std::size_t> token_line;
  std::size_t line = 1;
  for (std::size_t i = 0; i < content.size();) {
    const char c = content[i];
    if (c == '\n') ++line;
    if (c == '"') {
      std::string s;
      ++i;
      while (i < content.size()) {
        if (content[i] == '"') {
          if (i + 1 < content.size() && content[i + 1] == '"') {
            s += '"';
            i += 2;
            continue;
          }
          break;
        }
        if (content[i] == '\n') ++line;
        s += content[i++];
      }
      if (i >= content.size())
        throw Error(src + ":" + std::to_string(line) + ": unterminated string");
      ++i;
      tokens.push_back("\"" + s);
      token_line.push_back(line);
    } else if (c == '[') {
      while (i < content.size() && content[i] != ']') ++i;
      ++i;
    } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '.') {
      std::size_t j = i;
      while (j < content.size() &&
             (std::isdigit(static_cast<unsigned char>(content[j])) || content[j] == '.' ||
              content[j] == '-' || content[j] == 'e' || content[j] == 'E' || content[j] == '+'))
        ++j;
      tokens.emplace_back(content.substr(i, j - i));
      token_line.push_back(line);
      i = j;
    } else if (c == '!') {  // comment to end of line
      while (i < content.size() && content[i] != '\n') ++i;
    } else if (std::isalpha(static_cast<unsigned char>(c))) {  // labels such as xmin =
      while (i < content.size() &&
             (std::isalnum(static_cast<unsigned char>(content[i])) || content[i] == '_'))
        ++i;
    } else if (c == '<') {  // <exists>
      while (i < content.size() && content[i] != '>') ++i;
      ++i;
    } else {
      ++i;
    }
  }
  std::size_t k = 0;
  const auto where = [&] {
    return src + ":" + std::to_string(k < token_line.size() ? token_line[k] : line);
  };
  const auto next_string = [&]() -> std::string {
    if (k >= tokens.size() || tokens[k][0] != '"') throw Error(where() + ": expected a string");
    return tokens[k++].substr(1);
  };
  const auto next_number = [&]() -> double {
    if (k >= tokens.size() || tokens[k][0] == '"') throw Error(where() + ": expected a number");
    try {
      std::size_t used = 0;
      const double v = std::stod(tokens[k], &used);
      if (used != tokens[k].size() || !std::isfinite(v)) throw std::invalid_argument("x");
      ++k;
      return v;
    } catch (const std::exception&) {
      throw Error(where() + ": expected a number, got '" + tokens[k] + "'");
    }
  };
  if (next_string() != "ooTextFile" || next_string() != "TextGrid")
    throw Error(src +
                ": not a Praat TextGrid (expected File type = \"ooTextFile\", Object class = "
                "\"TextGrid\")");
  next_number();
  next_number();
  const double count = next_number();
  if (count < 0 || count > 1000) throw Error(where() + ": implausible tier count");
  std::vector<Tier> tiers;
  for (int t = 0; t < static_cast<int>(count); ++t) {
    const std::string cls = next_string();
    Tier tier;
    tier.name = next_string();
    next_number();
    next_number();
    const double n = next_number();
    if (n < 0 || n > 1e7) throw Error(where() + ": implausible interval count");
    for (int i = 0; i < static_cast<int>(n); ++i) {
      const std::string at = where();
      if (cls == "IntervalTier") {
        const double a = next_number(), b = next_number();
        tier.intervals.push_back({next_string(), a, b, at});
      } else {
        const double a = next_number();
        tier.intervals.push_back({next_string(), a, a, at});
      }
    }
    tiers.push_back(std::move(tier));
  }
  return tiers;
}

bool ends_with(const std::string& s, std::string_view suffix) {
  const std::string l = lower(s);
  return l.size() >= suffix.size() &&
         l.compare(l.size() - suffix.size(), suffix.size(), suffix) == 0;
}

Utterance import_mfa(std::string_view content, const Options& o, PhoneSet set,
                     const std::string& src) {
  std::vector<Tier> tiers;
  if (starts_json(content)) {  // MFA 2/3 JSON: {"tiers": {"words": {"entries": [[s, e, label]]}}}
    const json j = parse_json(content, src);
    if (!j.is_object() || !j.contains("tiers") || !j.at("tiers").is_object())
      throw Error(src + ": MFA JSON needs a 'tiers' object");
    for (const auto& [name, tier] : j.at("tiers").items()) {
      Tier t;
      t.name = name;
      if (!tier.contains("entries") || !tier.at("entries").is_array())
        throw Error(src + ": tier '" + name + "' has no 'entries' array");
      const json& entries = tier.at("entries");
      for (std::size_t i = 0; i < entries.size(); ++i) {
        const std::string where = src + ": tiers." + name + ".entries[" + std::to_string(i) + "]";
        const json& e = entries[i];
        if (!e.is_array() || e.size() < 3 || !e[0].is_number() || !e[1].is_number() ||
            !e[2].is_string())
          throw Error(where + ": expected [start, end, label]");
        t.intervals.push_back(
            {e[2].get<std::string>(), e[0].get<double>(), e[1].get<double>(), where});
      }
      tiers.push_back(std::move(t));
    }
  } else {
    tiers = parse_textgrid(content, src);
  }
  const Tier* phones = nullptr;
  const Tier* words = nullptr;
  for (const auto& t : tiers) {
    if (!phones && ends_with(t.name, "phones")) phones = &t;
    if (!words && ends_with(t.name, "words")) words = &t;
  }
  if (!phones) throw Error(src + ": no 'phones' tier");
  return from_phones(phones->intervals, words ? words->intervals : std::vector<Label>{}, set, o);
}

Utterance import_rhubarb(std::string_view content, const Options& o, const std::string& src) {
  std::vector<Label> cues;
  if (starts_json(content)) {
    const json j = parse_json(content, src);
    if (!j.is_object() || !j.contains("mouthCues") || !j.at("mouthCues").is_array())
      throw Error(src + ": Rhubarb JSON needs a 'mouthCues' array");
    const json& list = j.at("mouthCues");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string where = src + ": mouthCues[" + std::to_string(i) + "]";
      cues.push_back({string_field(list[i], "value", where), number(list[i], "start", where),
                      number(list[i], "end", where), where});
    }
  } else {  // TSV: "0.00\tX"
    for (const auto& [n, line] : lines_of(content)) {
      const std::string where = src + ":" + std::to_string(n);
      std::istringstream in(line);
      double t = 0;
      std::string shape;
      if (!(in >> t >> shape) || !std::isfinite(t))
        throw Error(where + ": expected '<seconds>\\t<mouth shape>'");
      cues.push_back({shape, t, 0, where});
    }
    close_spans(cues);
    if (!cues.empty() && cues.back().text == "X") cues.back().end = cues.back().start;
  }
  return from_visemes(cues, detail::tables().rhubarb, "Rhubarb", o);
}

Utterance import_elevenlabs(std::string_view content, const Options& o, const std::string& src) {
  const json root = parse_json(content, src);
  const json* j = &root;
  for (const char* key : {"alignment", "normalized_alignment"})
    if (root.is_object() && root.contains(key) && root.at(key).is_object()) {
      j = &root.at(key);
      break;
    }
  for (const char* key :
       {"characters", "character_start_times_seconds", "character_end_times_seconds"})
    if (!j->is_object() || !j->contains(key) || !j->at(key).is_array())
      throw Error(src + ": ElevenLabs alignment needs the array '" + key + "'");
  const json& chars = j->at("characters");
  const json& starts = j->at("character_start_times_seconds");
  const json& ends = j->at("character_end_times_seconds");
  if (starts.size() != chars.size() || ends.size() != chars.size())
    throw Error(src + ": characters and their start/end times differ in length");
  // The text, and for each of its code points the time span of its character entry.
  std::string text;
  std::vector<Span> cp_span;
  for (std::size_t i = 0; i < chars.size(); ++i) {
    const std::string where = src + ": characters[" + std::to_string(i) + "]";
    if (!chars[i].is_string() || !starts[i].is_number() || !ends[i].is_number())
      throw Error(where + ": expected a string with numeric start and end times");
    const Label l{chars[i].get<std::string>(), starts[i].get<double>(), ends[i].get<double>(),
                  where};
    check_span(l);
    text += l.text;
    for (std::size_t pos = 0; pos < l.text.size();) {
      detail::next_code_point(l.text, pos);
      cp_span.push_back({l.start, l.end});
    }
  }
  Options model = o;
  model.timing = Timing::kModel;
  detail::Plan plan = detail::make_plan(text, model);
  std::vector<Span> spans;
  for (const auto& unit : plan.units) {
    if (unit.src_begin >= cp_span.size() || unit.src_end == 0 || unit.src_end > cp_span.size())
      throw Error(src + ": character alignment does not cover '" + unit.text + "'");
    spans.push_back({cp_span[unit.src_begin].start, cp_span[unit.src_end - 1].end});
  }
  // Characters that share one number ("2024") share its span: split it between their syllables.
  for (std::size_t i = 0; i < spans.size();) {
    std::size_t next = i + 1;
    while (next < spans.size() && plan.units[next].src_begin == plan.units[i].src_begin) ++next;
    const Span whole = spans[i];
    const double step = (whole.end - whole.start) / static_cast<double>(next - i);
    for (std::size_t k = i; k < next; ++k)
      spans[k] = {whole.start + step * static_cast<double>(k - i),
                  whole.start + step * static_cast<double>(k - i + 1)};
    i = next;
  }
  const detail::Timeline tl = detail::time_by_spans(plan, spans);
  const VisemeSet set = o.set.value_or(plan.has_zh ? VisemeSet::kZh15 : VisemeSet::kOculus);
  Utterance u = detail::assemble(plan, tl, text, set);
  if (!cp_span.empty()) u.duration = std::max(u.duration, cp_span.back().end);
  return u;
}

}  // namespace

TimestampFormat parse_timestamp_format(std::string_view name) {
  if (name == "json") return TimestampFormat::kJson;
  if (name == "azure") return TimestampFormat::kAzure;
  if (name == "polly") return TimestampFormat::kPolly;
  if (name == "mfa") return TimestampFormat::kMfa;
  if (name == "rhubarb") return TimestampFormat::kRhubarb;
  if (name == "elevenlabs") return TimestampFormat::kElevenLabs;
  throw Error("unknown timestamp format '" + std::string(name) +
              "' (json, azure, polly, mfa, rhubarb or elevenlabs)");
}

TimestampFormat detect_timestamp_format(std::string_view content, std::string_view source) {
  const auto has = [&](std::string_view needle) {
    return content.find(needle) != std::string_view::npos;
  };
  const std::string_view src = source;
  if (src.ends_with(".TextGrid") || src.ends_with(".textgrid") || has("ooTextFile"))
    return TimestampFormat::kMfa;
  const auto first = content.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  if (first == std::string_view::npos) throw Error(std::string(source) + ": empty timestamps");
  if (content[first] != '{' && content[first] != '[') {
    if (src.ends_with(".tsv") || (content[first] >= '0' && content[first] <= '9'))
      return TimestampFormat::kRhubarb;
    throw Error(std::string(source) + ": cannot tell the timestamp format (give it explicitly)");
  }
  if (has("\"mouthCues\"")) return TimestampFormat::kRhubarb;
  if (has("VisemeId") || has("AudioOffset")) return TimestampFormat::kAzure;
  if (has("\"characters\"")) return TimestampFormat::kElevenLabs;
  if (has("\"tiers\"")) return TimestampFormat::kMfa;
  if (has("\"type\"") && has("\"time\"")) return TimestampFormat::kPolly;
  return TimestampFormat::kJson;
}

PhoneSet parse_phone_set(std::string_view name) {
  if (name == "auto") return PhoneSet::kAuto;
  if (name == "pinyin") return PhoneSet::kPinyin;
  if (name == "arpabet") return PhoneSet::kArpabet;
  if (name == "ipa") return PhoneSet::kIpa;
  if (name == "espeak") return PhoneSet::kEspeak;
  throw Error("unknown phone set '" + std::string(name) +
              "' (auto, pinyin, arpabet, ipa or espeak)");
}

Utterance import_timestamps(TimestampFormat format, std::string_view content,
                            const Options& options, PhoneSet phones, std::string_view source) {
  const std::string src(source);
  Utterance u;
  switch (format) {
    case TimestampFormat::kJson:
      u = import_json(content, options, phones, src);
      break;
    case TimestampFormat::kAzure:
      u = import_azure(content, options, src);
      break;
    case TimestampFormat::kPolly:
      u = import_polly(content, options, src);
      break;
    case TimestampFormat::kMfa:
      u = import_mfa(content, options, phones, src);
      break;
    case TimestampFormat::kRhubarb:
      u = import_rhubarb(content, options, src);
      break;
    case TimestampFormat::kElevenLabs:
      u = import_elevenlabs(content, options, src);
      break;
  }
  if (u.text.empty()) {
    for (const auto& w : u.words) u.text += (u.text.empty() ? "" : " ") + w.text;
  }
  return u;
}

}  // namespace facecast::viseme
