// Viseme events of TTS engines: Azure, Amazon Polly, Rhubarb Lip Sync.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "facecast/core/error.hpp"
#include "import_detail.hpp"

namespace facecast::viseme::detail {

using nlohmann::json;

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

}  // namespace facecast::viseme::detail
