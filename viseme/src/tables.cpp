#include "tables.hpp"

#include <algorithm>
#include <sstream>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "utf8.hpp"

namespace facecast::viseme::detail {
namespace {

using nlohmann::json;

std::vector<std::string> split_words(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

json load(const char* name) {
  return load_json(config_path(std::string("viseme/") + name));
}

template <class T>
T field(const json& j, const char* key, const char* file) {
  if (!j.contains(key))
    throw Error(std::string("configs/viseme/") + file + ": missing '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception&) {
    throw Error(std::string("configs/viseme/") + file + ": '" + key + "' has the wrong type");
  }
}

// {"name": [oculus, zh15, (class)]} -> PhoneTable
PhoneTable phone_table(const json& j, const char* file) {
  PhoneTable table;
  for (const auto& [name, v] : j.items()) {
    if (!v.is_array() || v.size() < 2)
      throw Error(std::string("configs/viseme/") + file + ": entry '" + name +
                  "' must be [oculus, zh15, ...]");
    PhoneMap m;
    m.oculus = split_words(v[0].get<std::string>());
    m.zh15 = split_words(v[1].get<std::string>());
    if (v.size() > 2) m.duration_class = v[2].get<std::string>();
    table.emplace(name, std::move(m));
  }
  return table;
}

void check_names(const PhoneTable& t, const Tables& tb, const char* file) {
  for (const auto& [name, m] : t) {
    for (const auto& v : m.oculus)
      if (std::find(tb.oculus_names.begin(), tb.oculus_names.end(), v) == tb.oculus_names.end())
        throw Error(std::string("configs/viseme/") + file + ": '" + name +
                    "' maps to unknown Oculus viseme '" + v + "'");
    for (const auto& v : m.zh15)
      if (std::find(tb.zh15_names.begin(), tb.zh15_names.end(), v) == tb.zh15_names.end())
        throw Error(std::string("configs/viseme/") + file + ": '" + name +
                    "' maps to unknown zh15 class '" + v + "'");
  }
}

std::u32string chars_of(const json& j, const char* key) {
  std::u32string out;
  if (j.contains(key))
    for (const auto& s : j.at(key)) out += to_u32(s.get<std::string>());
  return out;
}

Tables load_tables() {
  Tables t;
  t.expressions =
      field<std::vector<std::string>>(load("expressions.json"), "expressions", "expressions.json");

  const json punct = load("punctuation.json");
  const json pauses = field<json>(punct, "pauses", "punctuation.json");
  for (const auto& [mark, sec] : pauses.items()) {
    if (mark == "newline")
      t.newline_pause = sec.get<double>();
    else
      t.pauses[mark] = sec.get<double>();
  }
  t.abbreviations = field<std::vector<std::string>>(punct, "abbreviations", "punctuation.json");

  const json sets = load("viseme_sets.json");
  t.zh15_names = field<std::vector<std::string>>(sets, "zh15", "viseme_sets.json");
  t.oculus_names = field<std::vector<std::string>>(sets, "oculus", "viseme_sets.json");
  t.mpeg4_from_oculus = field<std::unordered_map<std::string, std::string>>(
      sets, "mpeg4_from_oculus", "viseme_sets.json");

  const json py = load("pinyin.json");
  t.initials = field<std::vector<std::string>>(py, "initials", "pinyin.json");
  t.finals = field<std::unordered_map<std::string, std::array<std::string, 3>>>(py, "finals",
                                                                                "pinyin.json");
  t.syllabic_initials = field<std::vector<std::string>>(py, "syllabic_initials", "pinyin.json");
  const json units = field<json>(py, "units", "pinyin.json");
  for (const auto& [unit, v] : units.items()) {
    PhoneMap m;
    m.zh15 = {v.at(0).get<std::string>()};
    m.oculus = {v.at(1).get<std::string>()};
    t.pinyin_units.emplace(unit, std::move(m));
  }
  const auto yr = field<std::array<std::string, 2>>(py, "y_rounded", "pinyin.json");
  t.y_rounded.zh15 = {yr[0]};
  t.y_rounded.oculus = {yr[1]};
  t.apical_after = field<std::vector<std::string>>(py, "apical_after", "pinyin.json");
  const json dur = field<json>(py, "durations", "pinyin.json");
  t.initial_weight = dur.at("initial").get<std::unordered_map<std::string, double>>();
  t.medial_weight = dur.at("medial").get<std::unordered_map<std::string, double>>();
  for (const auto& [k, w] : dur.at("nucleus").items()) {
    if (k == "default")
      t.nucleus_default_weight = w.get<double>();
    else
      t.nucleus_weight[k] = w.get<double>();
  }
  t.coda_weight = dur.at("coda").get<double>();

  t.espeak_en =
      phone_table(field<json>(load("phones_espeak_en.json"), "phones", "phones_espeak_en.json"),
                  "phones_espeak_en.json");
  t.arpabet = phone_table(field<json>(load("phones_arpabet.json"), "phones", "phones_arpabet.json"),
                          "phones_arpabet.json");
  t.ipa = phone_table(field<json>(load("phones_ipa.json"), "phones", "phones_ipa.json"),
                      "phones_ipa.json");
  const json ext = load("visemes_external.json");
  t.azure =
      phone_table(field<json>(ext, "azure", "visemes_external.json"), "visemes_external.json");
  t.polly =
      phone_table(field<json>(ext, "polly", "visemes_external.json"), "visemes_external.json");
  t.rhubarb =
      phone_table(field<json>(ext, "rhubarb", "visemes_external.json"), "visemes_external.json");
  for (const auto* table :
       {&t.pinyin_units, &t.espeak_en, &t.arpabet, &t.ipa, &t.azure, &t.polly, &t.rhubarb})
    check_names(*table, t, "phone tables");

  const json den = load("durations_en.json");
  t.en_reference_rate = field<double>(den, "reference_rate", "durations_en.json");
  t.en_stress_factor = field<double>(den, "stress_factor", "durations_en.json");
  t.en_class_seconds =
      field<std::unordered_map<std::string, double>>(den, "classes", "durations_en.json");
  for (const auto& [name, m] : t.espeak_en)
    if (!t.en_class_seconds.count(m.duration_class))
      throw Error("configs/viseme/phones_espeak_en.json: '" + name + "' has unknown class '" +
                  m.duration_class + "'");

  const json num = load("numbers_zh.json");
  const char* nf = "numbers_zh.json";
  t.numbers.digits = field<std::array<std::string, 10>>(num, "digits", nf);
  t.numbers.point = field<std::string>(num, "point", nf);
  t.numbers.percent_prefix = field<std::string>(num, "percent_prefix", nf);
  t.numbers.negative = field<std::string>(num, "negative", nf);
  t.numbers.range = field<std::string>(num, "range", nf);
  t.numbers.fraction = field<std::string>(num, "fraction", nf);
  t.numbers.hour = field<std::string>(num, "hour", nf);
  t.numbers.minute = field<std::string>(num, "minute", nf);
  t.numbers.second = field<std::string>(num, "second", nf);
  t.numbers.half = field<std::string>(num, "half", nf);
  t.numbers.year = field<std::string>(num, "year", nf);
  t.numbers.month = field<std::string>(num, "month", nf);
  t.numbers.day = field<std::string>(num, "day", nf);
  t.numbers.liang_before_bai = field<bool>(num, "liang_before_bai", nf);
  t.numbers.digit_string_min_length = field<std::size_t>(num, "digit_string_min_length", nf);
  const json currency = field<json>(num, "currency_prefix", nf);
  for (const auto& [sym, name] : currency.items())
    t.numbers.currency_prefix.emplace_back(sym, name.get<std::string>());
  std::sort(t.numbers.currency_prefix.begin(), t.numbers.currency_prefix.end(),
            [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
  t.numbers.measure_words = field<std::vector<std::string>>(num, "measure_words", nf);

  const json rules = field<json>(load("polyphones_zh.json"), "rules", "polyphones_zh.json");
  for (const auto& r : rules) {
    const std::u32string ch = to_u32(r.at("char").get<std::string>());
    if (ch.size() != 1)
      throw Error("configs/viseme/polyphones_zh.json: 'char' must be one character");
    PolyphoneRule rule;
    rule.reading = r.at("reading").get<std::string>();
    rule.prev = chars_of(r, "prev");
    rule.next = chars_of(r, "next");
    rule.prev_repeated = r.value("prev_repeated", false);
    rule.at_end = r.value("at_end", false);
    t.polyphones[ch[0]].push_back(std::move(rule));
  }
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
