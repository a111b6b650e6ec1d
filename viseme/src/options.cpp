#include "facecast/viseme/options.hpp"

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "names.hpp"

namespace facecast::viseme {
namespace {

constexpr std::pair<std::string_view, LangMode> kLangModes[] = {
    {"auto", LangMode::kAuto}, {"zh", LangMode::kZh}, {"en", LangMode::kEn}};
constexpr std::pair<std::string_view, Timing> kTimings[] = {{"model", Timing::kModel},
                                                            {"tts", Timing::kTts}};

// An enum option read by its parse function, so the names are listed once (there).
template <class T>
void read_named(ConfigReader& c, std::string_view key, T& value, T (*parse)(std::string_view)) {
  if (!c.has(key)) return;
  std::string name;
  c.read(key, name);
  try {
    value = parse(name);
  } catch (const Error& e) {
    c.fail(key, e.what());
  }
}

}  // namespace

LangMode parse_lang_mode(std::string_view name) {
  return detail::parse_name(name, kLangModes, "language");
}

Timing parse_timing(std::string_view name) {
  return detail::parse_name(name, kTimings, "timing");
}

std::optional<VisemeSet> parse_set_option(std::string_view name) {
  if (name == "auto") return std::nullopt;
  return parse_viseme_set(name);
}

Options load_options() {
  ConfigReader c = ConfigReader::open(config_path("viseme/options.json"));
  Options o;
  read_named(c, "lang", o.lang, parse_lang_mode);
  read_named(c, "set", o.set, parse_set_option);
  read_named(c, "timing", o.timing, parse_timing);
  c.read("rate", o.rate)
      .read("en_voice", o.en_voice)
      .read("english_lexicon", o.english_lexicon)
      .read("zh_voice", o.zh_voice)
      .read("espeak_speed", o.espeak_speed)
      .read("phrase_final_lengthening", o.phrase_final_lengthening)
      .read("neutral_tone_factor", o.neutral_tone_factor);
  c.reject_unknown();
  return o;
}

}  // namespace facecast::viseme
