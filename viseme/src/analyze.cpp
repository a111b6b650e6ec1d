#include "facecast/viseme/analyze.hpp"

#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme {

Utterance analyze(std::string_view text, const Options& options) {
  detail::Plan plan = detail::make_plan(text, options);
  const detail::Timeline timeline = options.timing == Timing::kTts
                                        ? detail::time_by_tts(plan, options)
                                        : detail::time_by_model(plan);
  const VisemeSet set = options.set.value_or(plan.has_zh ? VisemeSet::kZh15 : VisemeSet::kOculus);
  return detail::assemble(plan, timeline, std::string(text), set);
}

}  // namespace facecast::viseme
