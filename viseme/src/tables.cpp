#include "tables.hpp"

#include <algorithm>
#include <sstream>

#include "chars.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"

namespace facecast::viseme::detail {
namespace {

using nlohmann::json;

std::filesystem::path file(const char* name) {
  return config_path(std::string("viseme/") + name);
}

std::vector<std::string> split_words(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

// The object `key` (required) as name -> T; each value is type-checked, errors name "key.name".
template <class T>
std::unordered_map<std::string, T> read_map(ConfigReader& c, std::string_view key) {
  json object;
  c.require(key, object);
  ConfigReader& entries = c.section(key);
  std::unordered_map<std::string, T> out;
  for (const auto& [name, value] : object.items()) entries.read(name, out[name]);
  return out;
}

// Takes `name` out of `map` into `value` when it is there (a map's "default" / "newline" entry).
void take(std::unordered_map<std::string, double>& map, const char* name, double& value) {
  const auto it = map.find(name);
  if (it == map.end()) return;
  value = it->second;
  map.erase(it);
}

bool listed(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

// Every viseme a phone maps to must be a name of its set.
void check_names(ConfigReader& c, std::string_view key, const PhoneTable& table, const Tables& t) {
  for (const auto& [name, m] : table) {
    const std::string entry = std::string(key) + "." + name;
    for (const auto& v : m.oculus)
      if (!listed(t.oculus_names, v)) c.fail(entry, "unknown Oculus viseme '" + v + "'");
    for (const auto& v : m.zh15)
      if (!listed(t.zh15_names, v)) c.fail(entry, "unknown zh15 class '" + v + "'");
  }
}

// {"name": ["oculus visemes", "zh15 classes", (duration class)]} -> PhoneTable
PhoneTable phone_table(ConfigReader& c, std::string_view key, const Tables& t) {
  PhoneTable table;
  for (const auto& [name, v] : read_map<std::vector<std::string>>(c, key)) {
    if (v.size() < 2) c.fail(std::string(key) + "." + name, "expected [oculus, zh15, ...]");
    PhoneMap m;
    m.oculus = split_words(v[0]);
    m.zh15 = split_words(v[1]);
    if (v.size() > 2) m.duration_class = v[2];
    table.emplace(name, std::move(m));
  }
  check_names(c, key, table, t);
  return table;
}

void read_expressions(Tables& t) {
  ConfigReader c = ConfigReader::open(file("expressions.json"));
  c.require("expressions", t.expressions);
  c.reject_unknown();
}

void read_punctuation(Tables& t) {
  ConfigReader c = ConfigReader::open(file("punctuation.json"));
  t.pauses = read_map<double>(c, "pauses");
  take(t.pauses, "newline", t.newline_pause);
  c.require("abbreviations", t.abbreviations);
  c.reject_unknown();
}

void read_viseme_sets(Tables& t) {
  ConfigReader c = ConfigReader::open(file("viseme_sets.json"));
  c.require("zh15", t.zh15_names).require("oculus", t.oculus_names);
  t.mpeg4_from_oculus = read_map<std::string>(c, "mpeg4_from_oculus");
  c.reject_unknown();
}

void read_pinyin(Tables& t) {
  ConfigReader c = ConfigReader::open(file("pinyin.json"));
  c.require("initials", t.initials);
  t.finals = read_map<std::array<std::string, 3>>(c, "finals");
  c.require("syllabic_initials", t.syllabic_initials);
  for (const auto& [unit, v] : read_map<std::array<std::string, 2>>(c, "units")) {
    PhoneMap m;
    m.zh15 = {v[0]};
    m.oculus = {v[1]};
    t.pinyin_units.emplace(unit, std::move(m));
  }
  check_names(c, "units", t.pinyin_units, t);
  std::array<std::string, 2> y_rounded;
  c.require("y_rounded", y_rounded);
  t.y_rounded.zh15 = {y_rounded[0]};
  t.y_rounded.oculus = {y_rounded[1]};
  c.require("apical_after", t.apical_after);
  ConfigReader& durations = c.section("durations");
  t.initial_weight = read_map<double>(durations, "initial");
  t.medial_weight = read_map<double>(durations, "medial");
  t.nucleus_weight = read_map<double>(durations, "nucleus");
  take(t.nucleus_weight, "default", t.nucleus_default_weight);
  durations.read("coda", t.coda_weight);
  c.reject_unknown();
}

// phones_espeak_en.json "context": [{"phone", "stress", "prev", "next", "as": [oculus, zh15]}].
void read_en_context(ConfigReader& c, Tables& t) {
  std::vector<json> rules;
  c.read("context", rules);
  const std::string where = file("phones_espeak_en.json").string() + ": context[";
  for (std::size_t i = 0; i < rules.size(); ++i) {
    ConfigReader r(rules[i], where + std::to_string(i) + "]");
    EnContextRule rule;
    std::string stress;
    std::array<std::string, 2> as;
    r.require("phone", rule.phone)
        .read("stress", stress)
        .read("prev", rule.prev)
        .read("next", rule.next)
        .require("as", as);
    r.reject_unknown();
    if (!t.espeak_en.count(rule.phone)) r.fail("phone", "not in phones: " + rule.phone);
    if (stress == "primary")
      rule.stress = '1';
    else if (stress == "secondary")
      rule.stress = '2';
    else if (stress == "none")
      rule.stress = '0';
    else if (!stress.empty())
      r.fail("stress", "expected primary, secondary or none");
    rule.as.oculus = split_words(as[0]);
    rule.as.zh15 = split_words(as[1]);
    t.espeak_en_context.push_back(std::move(rule));
  }
}

void read_phone_tables(Tables& t) {
  for (auto [name, table] :
       {std::pair{"phones_espeak_en.json", &t.espeak_en},
        std::pair{"phones_arpabet.json", &t.arpabet}, std::pair{"phones_ipa.json", &t.ipa}}) {
    ConfigReader c = ConfigReader::open(file(name));
    *table = phone_table(c, "phones", t);
    if (table == &t.espeak_en) read_en_context(c, t);
    c.reject_unknown();
  }
  ConfigReader c = ConfigReader::open(file("visemes_external.json"));
  t.azure = phone_table(c, "azure", t);
  t.polly = phone_table(c, "polly", t);
  t.rhubarb = phone_table(c, "rhubarb", t);
  c.reject_unknown();
}

// After read_phone_tables: every English phone's duration class must have a duration.
void read_durations_en(Tables& t) {
  ConfigReader c = ConfigReader::open(file("durations_en.json"));
  c.read("reference_rate", t.en_reference_rate).read("stress_factor", t.en_stress_factor);
  t.en_class_seconds = read_map<double>(c, "classes");
  c.reject_unknown();
  for (const auto& [name, m] : t.espeak_en)
    if (!t.en_class_seconds.count(m.duration_class))
      throw Error(file("phones_espeak_en.json").string() + ": phones." + name +
                  ": unknown duration class '" + m.duration_class + "'");
}

// After read_phone_tables: every phone of "from_cmu" must be an English phone with visemes.
void read_espeak_cmu(Tables& t) {
  ConfigReader c = ConfigReader::open(file("phones_espeak_cmu.json"));
  for (const auto& [name, cmu] : read_map<std::string>(c, "phones"))
    t.espeak_cmu[name] = split_words(cmu);
  const auto inverse = [&](std::string_view key,
                           std::unordered_map<std::string, std::string>& out) {
    std::vector<std::string> list;
    c.require(key, list);
    for (const auto& phone : list) {
      const auto it = t.espeak_cmu.find(phone);
      if (it == t.espeak_cmu.end() || it->second.empty() || it->second.size() > 2)
        c.fail(key, "'" + phone + "' stands for no CMU phone or pair in phones");
      if (!t.espeak_en.count(phone)) c.fail(key, "'" + phone + "' is not in phones_espeak_en.json");
      const std::string cmu =
          it->second.size() == 1 ? it->second[0] : it->second[0] + " " + it->second[1];
      if (!out.emplace(cmu, phone).second) c.fail(key, "two phones stand for " + cmu);
    }
  };
  inverse("from_cmu", t.cmu_espeak);
  inverse("from_cmu_unstressed", t.cmu_espeak_unstressed);
  for (const auto& [cmu, phone] : t.cmu_espeak_unstressed)
    if (!t.cmu_espeak.count(cmu))
      c.fail("from_cmu_unstressed", "'" + phone + "' stands for " + cmu + ", which from_cmu lacks");
  for (const auto& [name, cmu] : t.espeak_cmu)
    for (const auto& p : cmu)
      if (!t.cmu_espeak.count(p)) c.fail("from_cmu", "no phone speaks the CMU phone " + p);
  c.reject_unknown();
}

void read_numbers(NumbersZh& n) {
  ConfigReader c = ConfigReader::open(file("numbers_zh.json"));
  c.require("digits", n.digits)
      .require("point", n.point)
      .require("percent_prefix", n.percent_prefix)
      .require("negative", n.negative)
      .require("range", n.range)
      .require("fraction", n.fraction)
      .require("hour", n.hour)
      .require("minute", n.minute)
      .require("second", n.second)
      .require("half", n.half)
      .require("year", n.year)
      .require("month", n.month)
      .require("day", n.day)
      .read("liang_before_bai", n.liang_before_bai)
      .read("digit_string_min_length", n.digit_string_min_length)
      .require("measure_words", n.measure_words);
  for (auto& [symbol, name] : read_map<std::string>(c, "currency_prefix"))
    n.currency_prefix.emplace_back(symbol, std::move(name));
  std::sort(n.currency_prefix.begin(), n.currency_prefix.end(),
            [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
  c.reject_unknown();
}

std::u32string chars_of(const std::vector<std::string>& list) {
  std::u32string out;
  for (const auto& s : list) out += to_u32(s);
  return out;
}

void read_polyphones(Tables& t) {
  const auto path = file("polyphones_zh.json");
  ConfigReader c = ConfigReader::open(path);
  std::vector<json> rules;
  c.require("rules", rules);
  c.reject_unknown();
  for (std::size_t i = 0; i < rules.size(); ++i) {
    ConfigReader r(rules[i], path.string() + ": rules[" + std::to_string(i) + "]");
    std::string ch;
    std::vector<std::string> prev, next;
    PolyphoneRule rule;
    r.require("char", ch)
        .require("reading", rule.reading)
        .read("prev", prev)
        .read("next", next)
        .read("prev_repeated", rule.prev_repeated)
        .read("at_end", rule.at_end)
        .read("in_words", rule.in_words);
    r.reject_unknown();
    const std::u32string code_points = to_u32(ch);
    if (code_points.size() != 1) r.fail("char", "must be one character");
    rule.prev = chars_of(prev);
    rule.next = chars_of(next);
    t.polyphones[code_points[0]].push_back(std::move(rule));
  }
}

Tables load_tables() {
  Tables t;
  read_expressions(t);
  read_punctuation(t);
  read_viseme_sets(t);
  read_pinyin(t);
  read_phone_tables(t);
  read_durations_en(t);
  read_espeak_cmu(t);
  read_numbers(t.numbers);
  read_polyphones(t);
  return t;
}

}  // namespace

std::vector<std::string> PhoneMap::in(VisemeSet set) const {
  switch (set) {
    case VisemeSet::kZh15:
      return zh15;
    case VisemeSet::kOculus:
      return oculus;
    case VisemeSet::kMpeg4: {
      std::vector<std::string> out;
      for (const auto& v : oculus) out.push_back(tables().mpeg4_from_oculus.at(v));
      return out;
    }
  }
  return {};
}

const Tables& tables() {
  static const Tables t = load_tables();
  return t;
}

std::string silence_viseme(VisemeSet set) {
  return set == VisemeSet::kMpeg4 ? "none" : "sil";
}

}  // namespace facecast::viseme::detail
