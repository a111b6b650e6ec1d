// Phoneme / viseme timestamps from TTS engines and aligners -> Utterance: format names, format
// detection and the dispatch to the importers (import_detail.hpp).
#include "facecast/viseme/import.hpp"

#include "facecast/core/error.hpp"
#include "import_detail.hpp"
#include "names.hpp"

namespace facecast::viseme {

namespace {

constexpr std::pair<std::string_view, TimestampFormat> kFormats[] = {
    {"json", TimestampFormat::kJson},       {"azure", TimestampFormat::kAzure},
    {"polly", TimestampFormat::kPolly},     {"mfa", TimestampFormat::kMfa},
    {"rhubarb", TimestampFormat::kRhubarb}, {"elevenlabs", TimestampFormat::kElevenLabs}};
constexpr std::pair<std::string_view, PhoneSet> kPhoneSets[] = {{"auto", PhoneSet::kAuto},
                                                                {"pinyin", PhoneSet::kPinyin},
                                                                {"arpabet", PhoneSet::kArpabet},
                                                                {"ipa", PhoneSet::kIpa},
                                                                {"espeak", PhoneSet::kEspeak}};

}  // namespace

TimestampFormat parse_timestamp_format(std::string_view name) {
  return detail::parse_name(name, kFormats, "timestamp format");
}

PhoneSet parse_phone_set(std::string_view name) {
  return detail::parse_name(name, kPhoneSets, "phone set");
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

Utterance import_timestamps(TimestampFormat format, std::string_view content,
                            const Options& options, PhoneSet phones, std::string_view source) {
  const std::string src(source);
  Utterance u;
  switch (format) {
    case TimestampFormat::kJson:
      u = detail::import_json(content, options, phones, src);
      break;
    case TimestampFormat::kAzure:
      u = detail::import_azure(content, options, src);
      break;
    case TimestampFormat::kPolly:
      u = detail::import_polly(content, options, src);
      break;
    case TimestampFormat::kMfa:
      u = detail::import_mfa(content, options, phones, src);
      break;
    case TimestampFormat::kRhubarb:
      u = detail::import_rhubarb(content, options, src);
      break;
    case TimestampFormat::kElevenLabs:
      u = detail::import_elevenlabs(content, options, src);
      break;
  }
  if (u.text.empty()) {
    for (const auto& w : u.words) u.text += (u.text.empty() ? "" : " ") + w.text;
  }
  return u;
}

}  // namespace facecast::viseme