// ElevenLabs character alignment: the text front-end's syllables placed in their characters' spans.
#include <algorithm>
#include <cmath>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "import_detail.hpp"
#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme::detail {

using nlohmann::json;

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
      next_code_point(l.text, pos);
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

}  // namespace facecast::viseme::detail
