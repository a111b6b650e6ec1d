// VisemeSet names and the Utterance <-> JSON conversion.
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/viseme/utterance.hpp"
#include "names.hpp"

namespace facecast::viseme {
namespace {

using nlohmann::json;

constexpr std::pair<std::string_view, VisemeSet> kVisemeSets[] = {
    {"zh15", VisemeSet::kZh15}, {"mpeg4", VisemeSet::kMpeg4}, {"oculus", VisemeSet::kOculus}};

double round_time(double t) {
  return std::round(t * 1e4) / 1e4;
}

template <class T>
T get(const json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw Error(where + ": missing field '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception&) {
    throw Error(where + ": field '" + key + "' has the wrong type");
  }
}

// A JSON array with one object per item, made by `object`.
template <class T, class F>
json array_of(const std::vector<T>& items, F&& object) {
  json out = json::array();
  for (const auto& item : items) out.push_back(object(item));
  return out;
}

// The array `key` of `j` (absent: empty), one item per element made by `f(element, "key[i]")`.
template <class T, class F>
std::vector<T> list(const json& j, const char* key, F&& f) {
  std::vector<T> out;
  if (!j.contains(key)) return out;
  const json& arr = j.at(key);
  if (!arr.is_array()) throw Error(std::string("utterance: '") + key + "' must be an array");
  for (std::size_t i = 0; i < arr.size(); ++i)
    out.push_back(f(arr[i], std::string(key) + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace

std::string_view to_string(VisemeSet set) noexcept {
  return detail::name_of(set, kVisemeSets, "oculus");
}

VisemeSet parse_viseme_set(std::string_view name) {
  return detail::parse_name(name, kVisemeSets, "viseme set");
}

json to_json(const Utterance& u) {
  json j;
  j["text"] = u.text;
  j["duration"] = round_time(u.duration);
  j["set"] = to_string(u.set);
  j["phones"] = array_of(u.phones, [](const Phone& p) {
    return json{{"phone", p.phone},
                {"start", round_time(p.start)},
                {"end", round_time(p.end)},
                {"lang", p.lang}};
  });
  j["syllables"] = array_of(u.syllables, [](const Syllable& s) {
    return json{{"text", s.text},
                {"pinyin", s.pinyin},
                {"start", round_time(s.start)},
                {"end", round_time(s.end)}};
  });
  j["visemes"] = array_of(u.visemes, [](const VisemeEvent& v) {
    json e{{"viseme", v.viseme}, {"start", round_time(v.start)}, {"end", round_time(v.end)}};
    if (v.strength != 1) e["strength"] = std::round(v.strength * 1000) / 1000;
    return e;
  });
  j["expressions"] = array_of(u.expressions, [](const ExpressionEvent& e) {
    return json{{"name", e.name},
                {"intensity", e.intensity},
                {"start", round_time(e.start)},
                {"ramp", round_time(e.ramp)}};
  });
  j["words"] = array_of(u.words, [](const Word& w) {
    return json{{"text", w.text}, {"start", round_time(w.start)}, {"end", round_time(w.end)}};
  });
  if (u.sample_rate > 0) j["sample_rate"] = u.sample_rate;
  return j;
}

Utterance utterance_from_json(const json& j) {
  if (!j.is_object()) throw Error("utterance: expected a JSON object");
  Utterance u;
  u.text = j.value("text", "");
  u.duration = get<double>(j, "duration", "utterance");
  u.set = parse_viseme_set(get<std::string>(j, "set", "utterance"));
  u.phones = list<Phone>(j, "phones", [](const json& e, const std::string& w) {
    return Phone{get<std::string>(e, "phone", w), get<double>(e, "start", w),
                 get<double>(e, "end", w), e.value("lang", "")};
  });
  u.syllables = list<Syllable>(j, "syllables", [](const json& e, const std::string& w) {
    return Syllable{get<std::string>(e, "text", w), get<std::string>(e, "pinyin", w),
                    get<double>(e, "start", w), get<double>(e, "end", w)};
  });
  u.visemes = list<VisemeEvent>(j, "visemes", [](const json& e, const std::string& w) {
    const double strength = e.contains("strength") ? get<double>(e, "strength", w) : 1.0;
    if (!(strength >= 0 && strength <= 1)) throw Error(w + ": strength must be 0..1");
    return VisemeEvent{get<std::string>(e, "viseme", w), get<double>(e, "start", w),
                       get<double>(e, "end", w), strength};
  });
  u.expressions = list<ExpressionEvent>(j, "expressions", [](const json& e, const std::string& w) {
    return ExpressionEvent{get<std::string>(e, "name", w), get<int>(e, "intensity", w),
                           get<double>(e, "start", w), get<double>(e, "ramp", w)};
  });
  u.words = list<Word>(j, "words", [](const json& e, const std::string& w) {
    return Word{get<std::string>(e, "text", w), get<double>(e, "start", w),
                get<double>(e, "end", w)};
  });
  u.sample_rate = j.value("sample_rate", 0);
  return u;
}

}  // namespace facecast::viseme
