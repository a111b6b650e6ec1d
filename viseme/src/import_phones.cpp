// Phone timestamps: a generic JSON list, and the Montreal Forced Aligner's TextGrid or JSON.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "facecast/core/error.hpp"
#include "import_detail.hpp"

namespace facecast::viseme::detail {

using nlohmann::json;

namespace {

// ----- Praat TextGrid (long or short text format) -----------------------------------------------

// Both formats are the same sequence of values; the long one adds "key =" labels and "[n]".
// Strings keep a leading '"' to tell them from numbers.
struct Tokens {
  std::vector<std::string> values;
  std::vector<std::size_t> lines;  // of each value
  std::size_t last_line = 1;
};

// The string token (its text after '"') whose opening quote is at content[i - 1]; "" is an
// escaped quote. Moves i past the closing quote.
std::string quoted(std::string_view content, std::size_t& i, std::size_t& line,
                   const std::string& src) {
  std::string s = "\"";
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
  if (i >= content.size()) throw Error(src + ":" + std::to_string(line) + ": unterminated string");
  ++i;
  return s;
}

Tokens tokenize_textgrid(std::string_view content, const std::string& src) {
  Tokens t;
  std::size_t& line = t.last_line;
  for (std::size_t i = 0; i < content.size();) {
    const char c = content[i];
    if (c == '\n') ++line;
    if (c == '"') {
      ++i;
      t.values.push_back(quoted(content, i, line, src));
      t.lines.push_back(line);
    } else if (c == '[') {
      while (i < content.size() && content[i] != ']') ++i;
      ++i;
    } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '.') {
      std::size_t j = i;
      while (j < content.size() &&
             (std::isdigit(static_cast<unsigned char>(content[j])) || content[j] == '.' ||
              content[j] == '-' || content[j] == 'e' || content[j] == 'E' || content[j] == '+'))
        ++j;
      t.values.emplace_back(content.substr(i, j - i));
      t.lines.push_back(line);
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
  return t;
}

// Reads the tokens in order; errors name the line of the value at hand.
struct TokenReader {
  const Tokens& t;
  const std::string& src;
  std::size_t k = 0;

  std::string where() const {
    return src + ":" + std::to_string(k < t.lines.size() ? t.lines[k] : t.last_line);
  }
  std::string next_string() {
    if (k >= t.values.size() || t.values[k][0] != '"') throw Error(where() + ": expected a string");
    return t.values[k++].substr(1);
  }
  double next_number() {
    if (k >= t.values.size() || t.values[k][0] == '"') throw Error(where() + ": expected a number");
    try {
      std::size_t used = 0;
      const double v = std::stod(t.values[k], &used);
      if (used != t.values[k].size() || !std::isfinite(v)) throw std::invalid_argument("x");
      ++k;
      return v;
    } catch (const std::exception&) {
      throw Error(where() + ": expected a number, got '" + t.values[k] + "'");
    }
  }
};

struct Tier {
  std::string name;
  std::vector<Label> intervals;
};

std::vector<Tier> parse_textgrid(std::string_view content, const std::string& src) {
  const Tokens tokens = tokenize_textgrid(content, src);
  TokenReader r{tokens, src};
  if (r.next_string() != "ooTextFile" || r.next_string() != "TextGrid")
    throw Error(src +
                ": not a Praat TextGrid (expected File type = \"ooTextFile\", Object class = "
                "\"TextGrid\")");
  r.next_number();
  r.next_number();
  const double count = r.next_number();
  if (count < 0 || count > 1000) throw Error(r.where() + ": implausible tier count");
  std::vector<Tier> tiers;
  for (int t = 0; t < static_cast<int>(count); ++t) {
    const std::string cls = r.next_string();
    Tier tier;
    tier.name = r.next_string();
    r.next_number();
    r.next_number();
    const double n = r.next_number();
    if (n < 0 || n > 1e7) throw Error(r.where() + ": implausible interval count");
    for (int i = 0; i < static_cast<int>(n); ++i) {
      const std::string at = r.where();
      if (cls == "IntervalTier") {
        const double a = r.next_number(), b = r.next_number();
        tier.intervals.push_back({r.next_string(), a, b, at});
      } else {
        const double a = r.next_number();
        tier.intervals.push_back({r.next_string(), a, a, at});
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

}  // namespace

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

}  // namespace facecast::viseme::detail
