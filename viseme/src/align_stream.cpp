// Streaming alignment: see align_stream.hpp and docs/algorithms.md#streaming-alignment.
#include "facecast/viseme/align_stream.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "align_hmm.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/audio.hpp"
#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme {
namespace {

constexpr int kRate = 16000, kHop = 160;  // the model's rate and its 10 ms frame
constexpr double kFrame = 0.01;
constexpr long kMaxSearch = 300;            // frames: a longer search restarts at what is decided
constexpr std::size_t kMaxPending = 4096;   // bytes of text waiting for whitespace
constexpr long kMinWord = 5;                // frames a word keeps when its onset moves past silence
constexpr std::size_t kLevelFrames = 3000;  // recent frames the silence threshold is taken from
constexpr std::size_t kContextWords = 3;    // words read around a piece (espeak-ng's context)
constexpr std::size_t kMaxTextAhead = 3000;  // phones of text undecided at most (a few minutes)
constexpr long kMaxAhead = 6000;  // frames of audio kept undecided at most (waiting for text)

// Where the text can be cut: after its last whitespace outside a tag's parentheses (0: nowhere).
std::size_t cut(std::string_view s) {
  std::size_t at = 0;
  int depth = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '(') ++depth;
    if (s[i] == ')' && depth > 0) --depth;
    if (depth == 0 && (s[i] == ' ' || s[i] == '\n' || s[i] == '\t' || s[i] == '\r')) at = i + 1;
  }
  return at;
}

// Whether the text's last word ends a clause (. , ; : ! ? before any closing quotes).
bool ends_clause(std::string_view s) {
  const std::size_t last = s.find_last_not_of(" \t\r\n\"')");
  return last != std::string_view::npos &&
         std::string_view(".,;:!?").find(s[last]) != std::string_view::npos;
}

}  // namespace

struct StreamAligner::Impl {
  Options options;
  AlignOptions align;
  VisemeSet set;
  StreamResampler resampler;
  std::optional<detail::HmmStream> hmm;  // made for the first text without times
  enum class Mode { kNone, kAligned, kTimed } mode = Mode::kNone;
  double timed_end = 0;  // kTimed: the end of the last timed text (seconds)

  // The text so far.
  std::string pending;  // after the last complete word
  bool text_ended = false;
  std::vector<detail::PlanUnit> units;
  struct Tag {
    std::size_t unit;  // takes effect where this unit starts (units.size() at the end: the end)
    ExpressionEvent event;
  };
  std::vector<Tag> tags;  // not yet placed
  struct Entry {          // a grammar phone: a CMU phone of a plan phone of a unit
    std::size_t unit, phone;
    std::string cmu;
    bool first_of_unit;
  };
  std::vector<Entry> entries;

  // The search: entries [base, entries.size()) on the audio since frame `origin`.
  std::size_t base = 0;
  long origin = 0;
  std::vector<std::int16_t> pcm;  // 16 kHz since origin
  bool searching = false, dirty = false;
  bool settled = false;       // the search has run with the stream's own cepstral mean
  std::uint64_t samples = 0;  // 16 kHz samples received
  std::vector<float> energy;  // dB per frame since origin
  std::vector<float> levels;  // dB of recent frames (a ring of kLevelFrames)
  std::size_t levels_at = 0;

  // Decisions.
  std::size_t done = 0;  // entries decided
  long phone_start = 0;  // frame where the plan phone being decided started
  long done_end = 0;     // the last decided entry's end frame
  long decided = 0;      // frames
  bool finished = false;
  std::vector<VisemeEvent> final_visemes, visemes;
  std::vector<Phone> phones;
  std::vector<ExpressionEvent> expressions;

  Impl(int rate, const Options& o, const AlignOptions& a)
      : options(o), align(a), set(o.set.value_or(VisemeSet::kOculus)), resampler(rate, kRate) {
    options.timing = Timing::kTts;
  }

  long lag() const { return std::lround(align.stream_lag / kFrame); }
  long received_frames() const { return static_cast<long>(samples / kHop); }

  // Complete pieces of text are planned as they come, with up to three words before them as
  // context; when the next piece comes the last one is planned again with its first three words
  // after, so its words are read as espeak-ng speaks them in context (weak forms: "a" before a
  // word), as in the whole-file aligner, unless the search has decided some of it already.
  std::deque<std::string> context;  // words before the last piece, untagged (kContextWords)
  struct Last {                     // the last piece, planned without what follows it
    std::string piece;
    std::size_t units = 0, entries = 0;  // sizes before it was planned
  } last;

  // The words of a text, each with the whitespace after it.
  static std::vector<std::string> words(std::string_view s) {
    std::vector<std::string> out;
    for (std::size_t at = s.find_first_not_of(" \t\r\n"); at != std::string_view::npos;) {
      const std::size_t end = s.find_first_of(" \t\r\n", at);
      const std::size_t next =
          end == std::string_view::npos ? end : s.find_first_not_of(" \t\r\n", end);
      out.emplace_back(s.substr(at, (next == std::string_view::npos ? s.size() : next) - at));
      if (end == std::string_view::npos) break;
      at = next;
    }
    return out;
  }

  // The text without its tags (context is only read).
  static std::string untagged(std::string_view s) {
    std::string out;
    int depth = 0;
    for (char c : s) {
      if (c == '(') ++depth;
      if (depth == 0) out += c;
      if (c == ')' && depth > 0) --depth;
    }
    return out;
  }

  void take(std::string piece) {
    if (piece.find_first_not_of(" \t\r\n") == std::string::npos) return;
    if (mode == Mode::kTimed)
      throw Error("audio_text: this stream's text has times; every piece needs start and end");
    if (!hmm) {
      if (!detail::hmm_installed())
        throw Error("streaming alignment needs pocketsphinx's English model (pocketsphinx-en-us)",
                    ErrorCode::kInternal);
      hmm.emplace();
      mode = Mode::kAligned;
    }
    // espeak-ng reads a clause by itself: a piece that ends one reads the same whatever follows
    // (checked on 290 clauses of prose), so only a piece cut inside a clause is read again.
    if (!last.piece.empty() && !ends_clause(untagged(last.piece))) {
      std::string after;
      const auto next = words(untagged(piece));
      for (std::size_t i = 0; i < next.size() && i < kContextWords; ++i) after += next[i];
      replan(after);
    }
    for (std::string& w : words(untagged(last.piece))) context.push_back(std::move(w));
    while (context.size() > kContextWords) context.pop_front();
    last = {piece, units.size(), entries.size()};
    plan(piece, {});
  }

  // The last piece again with `after` after it, unless that changes phones already decided (its
  // tags stay as first planned: they may have been placed).
  void replan(const std::string& after) {
    const auto from = static_cast<std::ptrdiff_t>(last.entries);
    std::vector<Entry> old_entries(entries.begin() + from, entries.end());
    std::vector<detail::PlanUnit> old_units(units.begin() + static_cast<std::ptrdiff_t>(last.units),
                                            units.end());
    const std::size_t tag_count = tags.size();
    units.resize(last.units);
    entries.resize(last.entries);
    plan(last.piece, after);
    tags.resize(tag_count);
    bool same = entries.size() >= done;
    for (std::size_t e = last.entries; same && e < done; ++e) {
      const Entry& a = entries[e];
      const Entry& b = old_entries[e - last.entries];
      same = a.unit == b.unit && a.phone == b.phone && a.cmu == b.cmu;
    }
    if (same) return;
    entries.resize(last.entries);
    entries.insert(entries.end(), old_entries.begin(), old_entries.end());
    units.resize(last.units);
    units.insert(units.end(), old_units.begin(), old_units.end());
  }

  // Plans `target` between the context and `after`, appending its units, grammar phones and tags.
  void plan(const std::string& target, const std::string& after) {
    if (entries.size() > done + kMaxTextAhead)
      throw Error("audio_text: more than " + std::to_string(kMaxTextAhead) +
                  " phones of text ahead of the audio");
    std::string before;
    for (const std::string& l : context) before += l;
    detail::Plan p = detail::make_plan(before + target + after, options);
    for (const detail::PlanUnit& u : p.units)
      if (u.lang != detail::Lang::kEn)
        throw Error(
            "audio_text: streaming alignment takes English text; '" + u.text +
            "' is not (send Chinese with its times, align whole files, or stream the audio alone)");
    // The target's units: those after the context's (words are cut at whitespace, so the plan of
    // a prefix is a prefix of the plan).
    const std::size_t a = before.empty() ? 0 : detail::make_plan(before, options).units.size();
    const std::size_t b = a + detail::make_plan(target, options).units.size();
    if (b > p.units.size()) throw Error("audio_text: cannot read '" + target + "'");
    if (b > a) detail::time_by_tts(p, options);  // the phones espeak-ng speaks in context
    // A tag takes effect where the next unit starts (one of a later piece when none follows here).
    const std::size_t offset = units.size();
    std::size_t placed = tags.size();
    for (const detail::PlanItem& item : p.items) {
      if (item.kind == detail::PlanItem::Kind::kTag)
        tags.push_back({offset + (b - a), {item.name, item.intensity, 0, item.ramp}});
      if (item.kind == detail::PlanItem::Kind::kUnit && item.unit >= a)
        for (; placed < tags.size(); ++placed)
          tags[placed].unit = offset + std::min(item.unit, b) - a;
    }
    for (std::size_t i = a; i < b; ++i) {
      const auto groups = detail::hmm_phone_groups(p.units[i]);
      bool first = true;
      for (std::size_t k = 0; k < groups.size(); ++k)
        for (const std::string& cmu : groups[k]) {
          entries.push_back({offset + i - a, k, cmu, first});
          first = false;
        }
      units.push_back(std::move(p.units[i]));
    }
    dirty = true;
  }

  // Text spoken over [start, end] of the audio (a TTS's word or character timestamps): no search;
  // its units share the span by their model lengths, their phones by the model's proportions.
  void timed(std::string_view text, double start, double end) {
    if (mode == Mode::kAligned)
      throw Error("audio_text: this stream's text came without times; send none with them");
    mode = Mode::kTimed;
    if (!(start >= 0 && end >= start && end - start <= 60))
      throw Error(
          "audio_text: start and end must be seconds of the stream with 0 <= start <= "
          "end <= start + 60");
    if (start + 1e-6 < timed_end)
      throw Error("audio_text: start " + std::to_string(start) + " is before the end of the " +
                  "last piece (" + std::to_string(timed_end) + "); pieces come in order");
    const detail::Plan p = detail::make_plan(text, options);
    double total = 0;
    for (const auto& u : p.units) total += u.seconds();
    double t = start;
    for (const detail::PlanItem& item : p.items) {
      if (item.kind == detail::PlanItem::Kind::kTag)
        expressions.push_back({item.name, item.intensity, t, item.ramp});
      if (item.kind != detail::PlanItem::Kind::kUnit) continue;
      const detail::PlanUnit& u = p.units[item.unit];
      const double share = total > 0 ? u.seconds() / total : 1.0 / p.units.size();
      const detail::Span span{t, std::min(end, t + share * (end - start))};
      const std::vector<detail::Span> spans = detail::spread(u.phones, span);
      for (std::size_t k = 0; k < u.phones.size(); ++k) {
        phones.push_back({u.phones[k].name, spans[k].start, spans[k].end,
                          u.lang == detail::Lang::kZh ? "zh" : "en"});
        detail::append_phone_visemes(final_visemes, u.phones[k].map, spans[k], set);
      }
      t = span.end;
    }
    timed_end = end;
    update_timed();
  }

  void update_timed() {
    const long until =
        finished ? received_frames() : std::min(received_frames(), std::lround(timed_end / kFrame));
    decided = std::max(decided, until);
    const double keep = static_cast<double>(decided) * kFrame - keep_seconds;
    std::erase_if(final_visemes, [&](const VisemeEvent& v) { return v.end < keep; });
    visemes = final_visemes;
  }

  // A new search over the undecided entries, from the end of the last decided one (or on a search
  // grown too long, to bound its memory).
  void restart() {
    const long at = done > 0 ? std::max(done_end, origin) : origin;
    const auto drop = static_cast<std::size_t>(at - origin) * kHop;
    pcm.erase(pcm.begin(), pcm.begin() + static_cast<std::ptrdiff_t>(std::min(drop, pcm.size())));
    energy.erase(energy.begin(),
                 energy.begin() + std::min<std::ptrdiff_t>(
                                      at - origin, static_cast<std::ptrdiff_t>(energy.size())));
    origin = at;
    base = done;
    dirty = false;
    searching = base < entries.size();
    if (!searching) return;
    std::vector<std::string> grammar;
    for (std::size_t e = base; e < entries.size(); ++e) grammar.push_back(entries[e].cmu);
    hmm->restart(grammar, pcm.data(), pcm.size());
  }

  // The silence threshold of the audio so far (as the whole-file aligner's, on recent frames).
  float silence_threshold() {
    std::vector<float> v = levels;
    if (v.empty()) return -std::numeric_limits<float>::infinity();
    const auto nth = [&](std::size_t pct) {
      auto it = v.begin() + static_cast<std::ptrdiff_t>(v.size() * pct / 100);
      std::nth_element(v.begin(), it, v.end());
      return *it;
    };
    const float floor = nth(10), loud = nth(95);
    return static_cast<float>(std::max(floor + align.silence_range * (loud - floor),
                                       static_cast<double>(loud) - align.silence_max_db));
  }

  void add_phone(const detail::PlanUnit& u, std::size_t k, long first, long end,
                 std::vector<VisemeEvent>& track, bool final) {
    const double s = static_cast<double>(first) * kFrame, e = static_cast<double>(end) * kFrame;
    if (final) phones.push_back({u.phones[k].name, s, e, "en"});
    detail::append_phone_visemes(track, u.phones[k].map, {s, e}, set);
  }

  bool last_of_phone(std::size_t e) const {
    return e + 1 == entries.size() || entries[e + 1].unit != entries[e].unit ||
           entries[e + 1].phone != entries[e].phone;
  }

  // Decides what the best path puts more than the lag behind the search (all of it at the end),
  // and rebuilds the events after it from the path.
  void update() {
    std::vector<detail::HmmStream::Segment> path;
    if (searching) path = hmm->path();
    for (auto& g : path) {
      if (g.phone >= 0) g.phone += static_cast<int>(base);
      g.first += static_cast<int>(origin);
      g.last += static_cast<int>(origin);
    }
    long until = finished ? std::numeric_limits<long>::max()
                          : (searching ? origin + hmm->frames() : received_frames()) - lag();
    // The text so far ends in its last phone: the search stretches that phone (or silence and
    // noise after it) over words still to come. Its end is known once the path has left it for
    // silence or noise; nothing after that is decided until more text (or its end) comes.
    if (!text_ended && !finished && !entries.empty())
      for (std::size_t i = path.size(); i-- > 0;)
        if (path[i].phone >= 0) {
          if (static_cast<std::size_t>(path[i].phone) + 1 == entries.size())
            until = std::min<long>(until, i + 1 == path.size() ? path[i].first : path[i].last + 1);
          break;
        }
    // Until the cepstral mean has enough speech, only the silence before the first phone is
    // decided (the search starts again once it has; see feed()).
    if (!settled && !finished)
      for (const auto& g : path)
        if (g.phone >= 0) {
          until = std::min<long>(until, g.first);
          break;
        }
    // With no text undecided, nothing after it is decided until more text (or its end) comes.
    if ((!searching || done == entries.size()) && !text_ended && !finished)
      until = std::min(until, done_end);
    float threshold = 0;
    bool have_threshold = false;
    // The path's grammar phones (silence and noise between them left out).
    std::vector<const detail::HmmStream::Segment*> on;
    for (const auto& g : path)
      if (g.phone >= 0) on.push_back(&g);
    for (std::size_t i = 0; i < on.size(); ++i) {
      const auto& g = *on[i];
      if (static_cast<std::size_t>(g.phone) != done) continue;
      const Entry& en = entries[done];
      long first = g.first;
      // Inside a word the phones follow on (as the whole-file aligner's word spans make them): a
      // pause the path puts inside a word belongs to the phone before it.
      const bool word_goes_on = done + 1 < entries.size() && entries[done + 1].unit == en.unit;
      if (word_goes_on && i + 1 == on.size()) break;
      const long end = word_goes_on ? on[i + 1]->first : g.last + 1;
      if (end > until) break;
      if (en.first_of_unit) {
        // A word's onset moves past the silence at its start (as in the whole-file aligner).
        if (!have_threshold) threshold = silence_threshold(), have_threshold = true;
        while (first - origin < static_cast<long>(energy.size()) &&
               energy[static_cast<std::size_t>(first - origin)] < threshold &&
               first + 1 < end - kMinWord)
          ++first;
        for (auto it = tags.begin(); it != tags.end();)
          if (it->unit <= en.unit) {
            it->event.start = static_cast<double>(first) * kFrame;
            expressions.push_back(it->event);
            it = tags.erase(it);
          } else {
            ++it;
          }
      }
      if (en.first_of_unit || done == 0 || entries[done - 1].unit != en.unit ||
          entries[done - 1].phone != en.phone)
        phone_start = first;
      if (last_of_phone(done))
        add_phone(units[en.unit], en.phone, phone_start, end, final_visemes, true);
      done_end = end;
      ++done;
    }
    if (finished) {
      until = received_frames();
      for (auto& t : tags) {
        t.event.start = static_cast<double>(until) * kFrame;
        expressions.push_back(t.event);
      }
      tags.clear();
    }
    decided = std::max(decided, std::min(until, received_frames()));
    const double keep = static_cast<double>(decided) * kFrame - keep_seconds;
    std::erase_if(final_visemes, [&](const VisemeEvent& v) { return v.end < keep; });
    // After the decided part: the path's guess.
    visemes = final_visemes;
    long start = 0;
    for (std::size_t i = 0; i < on.size(); ++i) {
      const auto e = static_cast<std::size_t>(on[i]->phone);
      if (e < done) continue;
      const bool continues = e > 0 && entries[e - 1].unit == entries[e].unit &&
                             entries[e - 1].phone == entries[e].phone;
      if (!continues)
        start = on[i]->first;
      else if (e == done)
        start = phone_start;  // a phone whose first CMU phones are decided
      const bool next_in_word = i + 1 < on.size() && entries[e + 1].unit == entries[e].unit;
      if (last_of_phone(e) || i + 1 == on.size())
        add_phone(units[entries[e].unit], entries[e].phone, start,
                  next_in_word ? on[i + 1]->first : on[i]->last + 1, visemes, false);
    }
  }

  void feed(const float* s, std::size_t n) {
    std::vector<float> out;
    resampler.push(s, n, out);
    if (mode == Mode::kTimed) {
      samples += out.size();
      if (received_frames() - std::lround(timed_end / kFrame) > kMaxAhead)
        throw Error("audio_text: the audio is more than " + std::to_string(kMaxAhead / 100) +
                    " s ahead of its text");
      update_timed();
      return;
    }
    const std::vector<std::int16_t> p = to_pcm16(out);
    const std::size_t before = pcm.size();
    pcm.insert(pcm.end(), p.begin(), p.end());
    samples += p.size();
    // Frame energies (dB) of the frames this chunk completes.
    for (std::size_t f = energy.size(); (f + 1) * kHop <= pcm.size(); ++f) {
      double sum = 0;
      for (std::size_t i = f * kHop; i < (f + 1) * kHop; ++i)
        sum += static_cast<double>(pcm[i]) * static_cast<double>(pcm[i]);
      const auto db = static_cast<float>(10 * std::log10(sum / kHop + 1.0));
      energy.push_back(db);
      if (levels.size() < kLevelFrames)
        levels.push_back(db);
      else
        levels[levels_at++ % kLevelFrames] = db;
    }
    if (received_frames() - origin > kMaxAhead)
      throw Error("audio_text: the audio is more than " + std::to_string(kMaxAhead / 100) +
                  " s ahead of its text");
    if (dirty || (searching && received_frames() - origin > kMaxSearch && done > base)) {
      restart();  // the search reads the whole buffer, this chunk included
    } else if (searching) {
      hmm->feed(pcm.data() + before, p.size());
      if (!settled && hmm->settled()) restart();  // again, with the stream's own mean throughout
    }
    settled = settled || (hmm && hmm->settled());
    update();
  }
};

StreamAligner::StreamAligner(int sample_rate, const Options& options,
                             const AlignOptions& align_options) {
  if (sample_rate < 8000 || sample_rate > 48000)
    throw Error("streaming alignment: sample rate " + std::to_string(sample_rate) +
                " outside 8000..48000");
  impl_ = std::make_unique<Impl>(sample_rate, options, align_options);
}

StreamAligner::~StreamAligner() = default;
StreamAligner::StreamAligner(StreamAligner&&) noexcept = default;
StreamAligner& StreamAligner::operator=(StreamAligner&&) noexcept = default;

void StreamAligner::add_text(std::string_view piece) {
  Impl& m = *impl_;
  if (m.text_ended) throw Error("audio_text: the text has ended");
  m.pending.append(piece);
  const std::size_t at = cut(m.pending);
  if (at == 0 && m.pending.size() > kMaxPending)
    throw Error("audio_text: more than " + std::to_string(kMaxPending) +
                " bytes without a space between words");
  if (at == 0) return;
  std::string whole = m.pending.substr(0, at);
  m.pending.erase(0, at);
  m.take(std::move(whole));
}

void StreamAligner::add_timed_text(std::string_view text, double start, double end) {
  if (impl_->text_ended) throw Error("audio_text: the text has ended");
  impl_->timed(text, start, end);
}

void StreamAligner::end_text() {
  Impl& m = *impl_;
  if (m.text_ended) return;
  m.text_ended = true;
  m.take(std::exchange(m.pending, {}));
}

void StreamAligner::add_audio(const float* samples, std::size_t n) {
  if (impl_->finished) throw Error("streaming alignment: the audio has ended");
  impl_->feed(samples, n);
}

void StreamAligner::finish() {
  Impl& m = *impl_;
  if (m.finished) return;
  end_text();
  if (m.dirty) m.restart();
  if (m.searching) m.hmm->finish();
  m.finished = true;
  if (m.mode == Impl::Mode::kTimed)
    m.update_timed();
  else
    m.update();
}

double StreamAligner::decided() const {
  return static_cast<double>(impl_->decided) * kFrame;
}
double StreamAligner::received() const {
  return static_cast<double>(impl_->samples) / kRate;
}
const std::vector<VisemeEvent>& StreamAligner::visemes() const {
  return impl_->visemes;
}
const std::vector<Phone>& StreamAligner::phones() const {
  return impl_->phones;
}
std::vector<ExpressionEvent> StreamAligner::take_expressions() {
  return std::exchange(impl_->expressions, {});
}
VisemeSet StreamAligner::set() const {
  return impl_->set;
}

}  // namespace facecast::viseme
