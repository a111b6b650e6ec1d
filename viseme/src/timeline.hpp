#pragma once
// Times for a plan: the duration model, espeak-ng synthesis, or given spans (ElevenLabs), and the
// assembly of a timed plan into an Utterance. See docs/algorithms.md#duration-model.
#include <cstdint>
#include <utility>
#include <vector>

#include "facecast/viseme/utterance.hpp"
#include "plan.hpp"

namespace facecast::viseme::detail {

struct Span {
  double start = 0, end = 0;
};

struct UnitTime {
  Span span;
  std::vector<Span> phones;  // one per PlanUnit::phones
};

struct Timeline {
  std::vector<UnitTime> units;  // one per Plan::units
  double duration = 0;
  std::vector<int16_t> pcm;
  int sample_rate = 0;
};

/// Units back to back at their model lengths, pauses between them (none before the first unit or
/// after the last).
Timeline time_by_model(const Plan& plan);

/// espeak-ng synthesis phrase by phrase (a phrase: units of one language between pauses):
/// English through options.en_voice with its phoneme events (the unit's phones are replaced by
/// the phones espeak-ng spoke), Chinese as numbered pinyin through options.zh_voice with each
/// syllable's span from its word event, split over its phones by the model's proportions.
/// Configured pauses are inserted as silence; espeak-ng's own trailing silence is trimmed.
Timeline time_by_tts(Plan& plan, const Options& options);

/// Each unit placed in the given span (one per unit), its phones by the model's proportions.
Timeline time_by_spans(const Plan& plan, const std::vector<Span>& spans);

/// Phones split over [start, end] in proportion to their model seconds.
std::vector<Span> spread(const std::vector<PlanPhone>& phones, Span span);

/// The Utterance of a timed plan in `set` (visemes merged where consecutive ones are equal, "sil"
/// for pauses longer than 20 ms, expressions at the start of the first unit after their tag).
Utterance assemble(const Plan& plan, const Timeline& timeline, std::string text, VisemeSet set);

/// Appends a viseme event, merging with the previous one when equal and adjacent; a gap longer
/// than 20 ms becomes a pause viseme, a shorter one is closed by extending the previous event.
void append_viseme(std::vector<VisemeEvent>& track, const std::string& viseme, Span span,
                   VisemeSet set);

/// Appends a phone's visemes in `set` (its map's, splitting its span evenly) by append_viseme.
void append_phone_visemes(std::vector<VisemeEvent>& track, const PhoneMap& map, Span span,
                          VisemeSet set);

}  // namespace facecast::viseme::detail
