// Timing sources: duration model, espeak-ng synthesis, given spans.
#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>

#include "espeak.hpp"
#include "facecast/core/utf8.hpp"
#include "timeline.hpp"

namespace facecast::viseme::detail {
namespace {

bool is_pause_phoneme(const std::string& p) {
  return !p.empty() && p[0] == '_';
}

// A phrase: consecutive unit items of one language with no pause between (tags do not split).
struct Phrase {
  Lang lang = Lang::kZh;
  std::vector<std::size_t> units;
  double pause_before = 0;
};

std::vector<Phrase> phrases_of(const Plan& plan) {
  std::vector<Phrase> out;
  double pause = 0;
  bool broken = true;
  for (const auto& item : plan.items) {
    if (item.kind == PlanItem::Kind::kPause) {
      pause = std::max(pause, item.pause);
      broken = true;
    } else if (item.kind == PlanItem::Kind::kUnit) {
      const Lang lang = plan.units[item.unit].lang;
      if (broken || out.empty() || out.back().lang != lang) {
        out.push_back({lang, {}, out.empty() ? 0.0 : pause});
        pause = 0;
        broken = false;
      }
      out.back().units.push_back(item.unit);
    }
  }
  return out;
}

// The text espeak-ng speaks for a phrase, and each unit's 1-based character position in it.
std::string phrase_text(const Plan& plan, const Phrase& ph, std::vector<int>& positions) {
  std::string text;
  int chars = 0;
  for (std::size_t u : ph.units) {
    if (!text.empty()) {
      text += ' ';
      ++chars;
    }
    positions.push_back(chars + 1);
    const PlanUnit& unit = plan.units[u];
    const std::string& s = unit.spoken.empty() ? unit.text : unit.spoken;
    text += s;
    chars += utf8_length(s);
  }
  return text;
}

// Whether an espeak-ng English phone name (the table's) is a vowel.
bool vowel_name(const std::string& n) {
  return !n.empty() && std::string_view("aAeEiIoOuUV03@").find(n[0]) != std::string_view::npos;
}

// Edit distance between phones a[from, to) and b; a vowel for another vowel or a consonant for
// another consonant costs half (a reduced reading: "t@" for "tu:").
double reading_distance(const std::vector<PlanPhone>& a, std::size_t from, std::size_t to,
                        const std::vector<PlanPhone>& b) {
  const std::size_t n = to - from, m = b.size();
  std::vector<double> row(m + 1), next(m + 1);
  for (std::size_t j = 0; j <= m; ++j) row[j] = static_cast<double>(j);
  for (std::size_t i = 1; i <= n; ++i) {
    next[0] = static_cast<double>(i);
    for (std::size_t j = 1; j <= m; ++j) {
      const std::string& x = a[from + i - 1].name;
      const std::string& y = b[j - 1].name;
      const double sub = x == y ? 0 : vowel_name(x) == vowel_name(y) ? 0.5 : 1;
      next[j] = std::min({row[j] + 1, next[j - 1] + 1, row[j - 1] + sub});
    }
    std::swap(row, next);
  }
  return row[m];
}

// Where the phones `joined` of words that espeak-ng read as one split among them: phones cut[j] ..
// cut[j + 1] are word j's, the cuts that make each word's share differ least from its own reading
// `own[j]`, every word keeping at least one phone while there are enough.
std::vector<std::size_t> split_joined(const std::vector<PlanPhone>& joined,
                                      const std::vector<const std::vector<PlanPhone>*>& own) {
  const std::size_t n = joined.size(), words = own.size();
  const std::size_t least = n >= words ? 1 : 0;  // phones each word keeps at least
  constexpr double kNone = 1e30;
  // cost[j][c]: the first j words take the first c phones.
  std::vector<std::vector<double>> cost(words + 1, std::vector<double>(n + 1, kNone));
  std::vector<std::vector<std::size_t>> from(words + 1, std::vector<std::size_t>(n + 1, 0));
  cost[0][0] = 0;
  for (std::size_t j = 1; j <= words; ++j)
    for (std::size_t c = 0; c <= n; ++c)
      for (std::size_t b = 0; b + least <= c; ++b) {
        if (cost[j - 1][b] >= kNone) continue;
        const double v = cost[j - 1][b] + reading_distance(joined, b, c, *own[j - 1]);
        if (v < cost[j][c]) cost[j][c] = v, from[j][c] = b;
      }
  std::vector<std::size_t> cut(words + 1, n);
  for (std::size_t j = words; j > 0; --j) cut[j - 1] = from[j][cut[j]];
  return cut;
}

// Times of one synthesized phrase, relative to its start; returns the end of speech.
double time_phrase(Plan& plan, const Phrase& ph, const espeak::Synthesis& syn,
                   const std::vector<int>& positions, const Options& options,
                   std::vector<UnitTime>& times) {
  const auto unit_at = [&](int text_position) {
    std::size_t k = 0;
    while (k + 1 < positions.size() && positions[k + 1] <= text_position) ++k;
    return k;
  };
  // Speech ends at the first pause/end event after the last spoken phoneme.
  double speech_end = static_cast<double>(syn.pcm.size()) / syn.sample_rate;
  std::size_t last_real = syn.events.size();
  for (std::size_t e = 0; e < syn.events.size(); ++e)
    if (syn.events[e].kind == espeak::Event::Kind::kPhoneme &&
        !is_pause_phoneme(syn.events[e].phoneme))
      last_real = e;
  if (last_real < syn.events.size()) {
    for (std::size_t e = last_real + 1; e < syn.events.size(); ++e) {
      if (syn.events[e].kind != espeak::Event::Kind::kWord) {
        speech_end = std::min(speech_end, syn.events[e].time);
        break;
      }
    }
  }
  // Walk the events: word events switch the current unit; phonemes end at the next event.
  std::vector<std::vector<std::pair<std::string, Span>>> spoken(ph.units.size());
  std::vector<double> word_time(ph.units.size(), -1);
  std::size_t current = 0;
  for (std::size_t e = 0; e < syn.events.size(); ++e) {
    const auto& ev = syn.events[e];
    if (ev.kind == espeak::Event::Kind::kWord) {
      current = unit_at(ev.text_position);
      if (word_time[current] < 0) word_time[current] = ev.time;
    } else if (ev.kind == espeak::Event::Kind::kPhoneme) {
      double end = speech_end;
      for (std::size_t f = e + 1; f < syn.events.size(); ++f)
        if (syn.events[f].kind != espeak::Event::Kind::kWord) {
          end = std::min(speech_end, syn.events[f].time);
          break;
        }
      if (ev.time < speech_end)
        spoken[current].push_back({ev.phoneme, {ev.time, std::max(ev.time, end)}});
    }
  }
  // English: each unit's spoken phones (the table's names) with their spans.
  std::vector<std::vector<PlanPhone>> en_phones(ph.units.size());
  std::vector<std::vector<Span>> en_spans(ph.units.size());
  if (ph.lang == Lang::kEn) {
    for (std::size_t k = 0; k < ph.units.size(); ++k) {
      const PlanUnit& unit = plan.units[ph.units[k]];
      std::vector<std::pair<std::string, Span>> real;
      for (const auto& p : spoken[k])
        if (!is_pause_phoneme(p.first)) real.push_back(p);
      std::vector<std::string> names;
      for (const auto& p : real) names.push_back(p.first);
      std::vector<PlanPhone> phones = english_phones(names, options, unit.spoken.empty());
      // english_phones drops unknown phones: keep the spans of the ones it kept.
      std::vector<Span> spans;
      for (std::size_t i = 0, j = 0; i < real.size() && j < phones.size(); ++i) {
        std::string n = real[i].first;
        while (!n.empty() && (n[0] == '\'' || n[0] == ',')) n.erase(0, 1);
        if (n == phones[j].name) {
          spans.push_back(real[i].second);
          ++j;
        }
      }
      phones.resize(spans.size());
      en_phones[k] = std::move(phones);
      en_spans[k] = std::move(spans);
    }
    // espeak-ng reads some word pairs as one word ("to be", "I am", "at once") and reports one
    // word event: the first unit gets all the phones, the rest none. A unit without phones has
    // no length in any timeline made from this one (the aligners' "be" of no length, issue 36),
    // so the joined phones are shared back among the words by their own readings.
    for (std::size_t k = 0; k < ph.units.size(); ++k) {
      std::size_t m = k + 1;
      while (m < ph.units.size() && en_phones[m].empty() && !plan.units[ph.units[m]].phones.empty())
        ++m;
      if (m == k + 1 || en_phones[k].empty()) continue;
      std::vector<const std::vector<PlanPhone>*> own;
      for (std::size_t j = k; j < m; ++j) own.push_back(&plan.units[ph.units[j]].phones);
      const std::vector<PlanPhone> joined = std::move(en_phones[k]);
      const std::vector<Span> joined_spans = std::move(en_spans[k]);
      const std::vector<std::size_t> cut = split_joined(joined, own);
      for (std::size_t j = k; j < m; ++j) {
        const auto from = static_cast<std::ptrdiff_t>(cut[j - k]);
        const auto to = static_cast<std::ptrdiff_t>(cut[j - k + 1]);
        en_phones[j].assign(joined.begin() + from, joined.begin() + to);
        en_spans[j].assign(joined_spans.begin() + from, joined_spans.begin() + to);
      }
      k = m - 1;
    }
  }
  double cursor = 0;
  for (std::size_t k = 0; k < ph.units.size(); ++k) {
    PlanUnit& unit = plan.units[ph.units[k]];
    UnitTime& ut = times[ph.units[k]];
    if (unit.lang == Lang::kEn) {
      std::vector<PlanPhone>& phones = en_phones[k];
      const std::vector<Span>& spans = en_spans[k];
      for (std::size_t i = 0; i < phones.size(); ++i)
        phones[i].seconds = spans[i].end - spans[i].start;
      unit.phones = std::move(phones);
      ut.phones = spans;
      ut.span = spans.empty() ? Span{cursor, cursor} : Span{spans.front().start, spans.back().end};
    } else {
      std::vector<std::pair<std::string, Span>> real;
      for (const auto& p : spoken[k])
        if (!is_pause_phoneme(p.first)) real.push_back(p);
      const double start = word_time[k] >= 0 ? word_time[k] : cursor;
      const double end = real.empty() ? start : std::max(start, real.back().second.end);
      ut.span = {std::max(start, cursor), end};
      ut.phones = spread(unit.phones, ut.span);
    }
    cursor = std::max(cursor, ut.span.end);
  }
  return speech_end;
}

}  // namespace

std::vector<Span> spread(const std::vector<PlanPhone>& phones, Span span) {
  double total = 0;
  for (const auto& p : phones) total += p.seconds;
  std::vector<Span> out;
  double t = span.start;
  for (const auto& p : phones) {
    const double share = total > 0 ? p.seconds / total : 1.0 / static_cast<double>(phones.size());
    const double end = t + share * (span.end - span.start);
    out.push_back({t, end});
    t = end;
  }
  if (!out.empty()) out.back().end = span.end;
  return out;
}

Timeline time_by_model(const Plan& plan) {
  Timeline tl;
  tl.units.resize(plan.units.size());
  double cursor = 0, pending = 0;
  bool started = false;
  for (const auto& item : plan.items) {
    if (item.kind == PlanItem::Kind::kPause) {
      if (started) pending = std::max(pending, item.pause);
    } else if (item.kind == PlanItem::Kind::kUnit) {
      cursor += pending;
      pending = 0;
      const PlanUnit& u = plan.units[item.unit];
      UnitTime& ut = tl.units[item.unit];
      ut.span = {cursor, cursor + u.seconds()};
      ut.phones = spread(u.phones, ut.span);
      cursor = ut.span.end;
      started = true;
    }
  }
  tl.duration = cursor;
  return tl;
}

Timeline time_by_tts(Plan& plan, const Options& options) {
  Timeline tl;
  tl.units.resize(plan.units.size());
  tl.sample_rate = espeak::sample_rate();
  const double rate = tl.sample_rate;
  for (const Phrase& ph : phrases_of(plan)) {
    tl.pcm.resize(tl.pcm.size() + static_cast<std::size_t>(std::lround(ph.pause_before * rate)), 0);
    const double offset = static_cast<double>(tl.pcm.size()) / rate;
    std::vector<int> positions;
    const std::string text = phrase_text(plan, ph, positions);
    const std::string& voice = ph.lang == Lang::kZh ? options.zh_voice : options.en_voice;
    const espeak::Synthesis syn =
        espeak::synthesize(text, voice, options.espeak_speed, ph.lang == Lang::kEn);
    const double end = time_phrase(plan, ph, syn, positions, options, tl.units);
    const auto keep = std::min(syn.pcm.size(), static_cast<std::size_t>(std::lround(end * rate)));
    tl.pcm.insert(tl.pcm.end(), syn.pcm.begin(),
                  syn.pcm.begin() + static_cast<std::ptrdiff_t>(keep));
    // Times end where the kept audio does (a phrase's end rounds to a whole sample).
    const double last = static_cast<double>(tl.pcm.size()) / rate;
    const auto place = [&](Span& s) {
      s.start = std::min(s.start + offset, last);
      s.end = std::min(s.end + offset, last);
    };
    for (std::size_t u : ph.units) {
      UnitTime& ut = tl.units[u];
      place(ut.span);
      for (auto& s : ut.phones) place(s);
    }
  }
  tl.duration = static_cast<double>(tl.pcm.size()) / rate;
  return tl;
}

Timeline time_by_spans(const Plan& plan, const std::vector<Span>& spans) {
  Timeline tl;
  tl.units.resize(plan.units.size());
  for (std::size_t i = 0; i < plan.units.size() && i < spans.size(); ++i) {
    tl.units[i].span = spans[i];
    tl.units[i].phones = spread(plan.units[i].phones, spans[i]);
    tl.duration = std::max(tl.duration, spans[i].end);
  }
  return tl;
}

}  // namespace facecast::viseme::detail
