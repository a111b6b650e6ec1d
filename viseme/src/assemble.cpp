// A timed plan -> Utterance.
#include <algorithm>
#include <cmath>

#include "timeline.hpp"

namespace facecast::viseme::detail {
namespace {

constexpr double kMinPause = 0.02;  // shorter gaps are closed, longer ones become pause visemes

}  // namespace

void append_viseme(std::vector<VisemeEvent>& track, const std::string& viseme, Span span,
                   VisemeSet set) {
  if (span.end <= span.start) return;
  if (!track.empty()) {
    VisemeEvent& last = track.back();
    const double gap = span.start - last.end;
    if (gap > kMinPause) {
      const std::string sil = silence_viseme(set);
      if (last.viseme == sil)
        last.end = span.start;
      else
        track.push_back({sil, last.end, span.start});
    } else if (gap > 0) {
      track.back().end = span.start;
    }
    if (track.back().viseme == viseme && std::abs(track.back().end - span.start) < 1e-9) {
      track.back().end = std::max(track.back().end, span.end);
      return;
    }
  }
  track.push_back({viseme, span.start, span.end});
}

void append_phone_visemes(std::vector<VisemeEvent>& track, const PhoneMap& map, Span span,
                          VisemeSet set) {
  const auto visemes = map.in(set);
  const double step =
      (span.end - span.start) / static_cast<double>(std::max<std::size_t>(1, visemes.size()));
  for (std::size_t v = 0; v < visemes.size(); ++v)
    append_viseme(track, visemes[v],
                  {span.start + step * static_cast<double>(v),
                   span.start + step * static_cast<double>(v + 1)},
                  set);
}

Utterance assemble(const Plan& plan, const Timeline& tl, std::string text, VisemeSet set) {
  Utterance u;
  u.text = std::move(text);
  u.set = set;
  u.duration = tl.duration;
  u.pcm = tl.pcm;
  u.sample_rate = tl.sample_rate;
  for (std::size_t i = 0; i < plan.units.size(); ++i) {
    const PlanUnit& unit = plan.units[i];
    const UnitTime& t = tl.units[i];
    const char* lang = unit.lang == Lang::kZh ? "zh" : "en";
    for (std::size_t k = 0; k < unit.phones.size() && k < t.phones.size(); ++k) {
      const Span s = t.phones[k];
      u.phones.push_back({unit.phones[k].name, s.start, s.end, lang});
      append_phone_visemes(u.visemes, unit.phones[k].map, s, set);
    }
    if (unit.lang == Lang::kZh)
      u.syllables.push_back({unit.text, unit.pinyin, t.span.start, t.span.end});
  }
  for (const auto& w : plan.words)
    u.words.push_back({w.text, tl.units[w.first].span.start, tl.units[w.last - 1].span.end});
  // Tags take effect where the speech after them starts.
  std::vector<const PlanItem*> pending;
  const auto flush = [&](double at) {
    for (const PlanItem* tag : pending)
      u.expressions.push_back({tag->name, tag->intensity, at, tag->ramp});
    pending.clear();
  };
  for (const auto& item : plan.items) {
    if (item.kind == PlanItem::Kind::kTag) pending.push_back(&item);
    if (item.kind == PlanItem::Kind::kUnit) flush(tl.units[item.unit].span.start);
  }
  flush(u.duration);
  return u;
}

}  // namespace facecast::viseme::detail
