#include "facecast/viseme/options.hpp"

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"

namespace facecast::viseme {

LangMode parse_lang_mode(std::string_view name) {
  if (name == "auto") return LangMode::kAuto;
  if (name == "zh") return LangMode::kZh;
  if (name == "en") return LangMode::kEn;
  throw Error("unknown language '" + std::string(name) + "' (auto, zh or en)");
}

Timing parse_timing(std::string_view name) {
  if (name == "model") return Timing::kModel;
  if (name == "tts") return Timing::kTts;
  throw Error("unknown timing '" + std::string(name) + "' (model or tts)");
}

std::optional<VisemeSet> parse_set_option(std::string_view name) {
  if (name == "auto") return std::nullopt;
  return parse_viseme_set(name);
}

Options load_options() {
  const auto path = config_path("viseme/options.json");
  const nlohmann::json j = load_json(path);
  const auto where = [&](const char* key) { return path.string() + ": field '" + key + "'"; };
  Options o;
  try {
    o.lang = parse_lang_mode(j.at("lang").get<std::string>());
    o.set = parse_set_option(j.at("set").get<std::string>());
    o.timing = parse_timing(j.at("timing").get<std::string>());
    o.rate = j.at("rate").get<double>();
    o.en_voice = j.at("en_voice").get<std::string>();
    o.zh_voice = j.at("zh_voice").get<std::string>();
    o.espeak_speed = j.at("espeak_speed").get<int>();
    o.phrase_final_lengthening = j.at("phrase_final_lengthening").get<double>();
    o.neutral_tone_factor = j.at("neutral_tone_factor").get<double>();
  } catch (const nlohmann::json::out_of_range& e) {
    throw Error(path.string() + ": " + e.what());
  } catch (const nlohmann::json::type_error& e) {
    throw Error(path.string() + ": " + e.what());
  } catch (const Error& e) {
    throw Error(where("") + " " + e.what());
  }
  return o;
}

}  // namespace facecast::viseme
