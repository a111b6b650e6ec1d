// Forced alignment of English through pocketsphinx's HMM: see docs/algorithms.md#forced-alignment.
#include "align_hmm.hpp"

#include <pocketsphinx.h>
#include <sphinxbase/cmn.h>
#include <sphinxbase/err.h>
#include <sphinxbase/feat.h>
#include <sphinxbase/fsg_model.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string_view>

#include "dtw.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "features.hpp"

#ifndef FACECAST_PS_HMM
#define FACECAST_PS_HMM "/usr/share/pocketsphinx/model/en-us/en-us"
#endif
#ifndef FACECAST_PS_DICT
#define FACECAST_PS_DICT "/usr/share/pocketsphinx/model/en-us/cmudict-en-us.dict"
#endif

namespace facecast::viseme::detail {
namespace {

constexpr int kRate = 16000;              // the model's sample rate
constexpr double kFrame = 0.01;           // its frame shift, seconds
constexpr std::size_t kPoolMax = 8;       // idle decoders kept
constexpr std::size_t kLivePoolMax = 16;  // ... of streams (smaller: phones only)
constexpr int kMaxAddedWords = 2000;      // a pooled decoder whose dictionary grew more is dropped
constexpr double kMinPhone = 0.01;        // seconds every phone of a word keeps

struct Decoder {
  ps_decoder_t* ps = nullptr;
  int added = 0;                     // words added to its dictionary
  std::vector<mfcc_t> initial_mean;  // the model's cepstral mean (cmninit) as loaded
  ~Decoder() {
    if (ps) ps_free(ps);
  }
};

// Decoders of one kind: batch cepstral mean (whole files) or live (streams).
class Pool {
 public:
  explicit Pool(bool live) : live_(live) {}
  std::unique_ptr<Decoder> take() {
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        auto d = std::move(idle_.back());
        idle_.pop_back();
        return d;
      }
    }
    return create();
  }
  void give(std::unique_ptr<Decoder> d) {
    if (d->added > kMaxAddedWords) return;
    std::lock_guard lock(mutex_);
    if (idle_.size() < (live_ ? kLivePoolMax : kPoolMax)) idle_.push_back(std::move(d));
  }
  HmmPoolStats stats() {
    std::lock_guard lock(mutex_);
    return stats_;
  }

 private:
  std::unique_ptr<Decoder> create() {
    // pocketsphinx logs to stderr by default; its log goes nowhere (process-wide, set once).
    static std::once_flag quiet;
    std::call_once(quiet, [] { err_set_logfp(nullptr); });
    const auto t0 = std::chrono::steady_clock::now();
    // A stream's grammar is phones only: its decoder loads a dictionary of the CMU phones alone
    // (configs/viseme/cmu_phones.dict; 13 ms and 6 MB against 86 ms and 28 MB with the whole one).
    const std::string dict =
        live_ ? config_path("viseme/cmu_phones.dict").string() : std::string(FACECAST_PS_DICT);
    // Wide beams (a one-path grammar is cheap to search), no silence removal (frame times must be
    // the audio's); batch CMN over the whole utterance, or live for streams (HmmStream sets its
    // mean).
    // Streams evaluate 2 Gaussians per codebook, not 4: 20 % less time per frame, 98.5 % against
    // 98.6 % of frames as the whole-file alignment has them (test_viseme "[stream]").
    cmd_ln_t* config =
        cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", FACECAST_PS_HMM, "-dict", dict.c_str(),
                    "-samprate", "16000", "-beam", "1e-80", "-wbeam", "1e-60", "-pbeam", "1e-80",
                    "-remove_silence", "no", "-topn", live_ ? "2" : "4", "-cmn",
                    live_ ? "live" : "batch", "-bestpath", "no", "-logfn", "/dev/null", nullptr);
    if (!config) throw Error("alignment: cannot configure pocketsphinx", ErrorCode::kInternal);
    auto d = std::make_unique<Decoder>();
    d->ps = ps_init(config);
    cmd_ln_free_r(config);  // the decoder holds its own reference
    if (!d->ps)
      throw Error("alignment: cannot load pocketsphinx's model " FACECAST_PS_HMM,
                  ErrorCode::kInternal);
    const cmn_t& cmn = *ps_get_feat(d->ps)->cmn_struct;
    d->initial_mean.assign(cmn.cmn_mean, cmn.cmn_mean + cmn.veclen);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::lock_guard lock(mutex_);
    ++stats_.created;
    stats_.last_load_seconds = seconds;
    return d;
  }

  const bool live_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<Decoder>> idle_;
  HmmPoolStats stats_;
};

Pool& pool(bool live = false) {
  static Pool batch(false), stream(true);
  return live ? stream : batch;
}

// A dictionary-safe word name: lower-case ASCII letters, digits and apostrophes.
std::string dict_name(const std::string& text) {
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '\'')
      out += static_cast<char>(std::tolower(c));
    else
      return {};
  }
  return out;
}

}  // namespace

std::vector<std::vector<std::string>> hmm_phone_groups(const PlanUnit& u) {
  std::vector<std::vector<std::string>> out;
  for (const PlanPhone& p : u.phones) {
    const auto it = tables().espeak_cmu.find(p.name);
    out.push_back(it != tables().espeak_cmu.end() ? it->second : std::vector<std::string>());
  }
  return out;
}

namespace {

std::string joined(const std::vector<std::vector<std::string>>& groups) {
  std::string s;
  for (const auto& g : groups)
    for (const auto& p : g) s += (s.empty() ? "" : " ") + p;
  return s;
}

std::vector<int16_t> pcm16_at_16k(const Audio& audio) {
  const std::vector<float> s = audio.sample_rate == kRate
                                   ? audio.samples
                                   : resample(audio.samples, audio.sample_rate, kRate);
  return to_pcm16(s);
}

// Segments of the last decode that are grammar words (not silence or noise), "(2)" variants
// stripped, with their frames.
struct Segment {
  std::string word;
  int first = 0, last = 0;
};

std::vector<Segment> segments(ps_decoder_t* ps) {
  std::vector<Segment> out;
  for (ps_seg_t* s = ps_seg_iter(ps); s; s = ps_seg_next(s)) {
    std::string w = ps_seg_word(s);
    if (w.empty() || w[0] == '<' || w[0] == '[') continue;  // <sil>, <s>, [NOISE]
    if (const auto paren = w.find('('); paren != std::string::npos && paren > 0) w.resize(paren);
    int a = 0, b = 0;
    ps_seg_frames(s, &a, &b);
    out.push_back({w, a, b});
  }
  return out;
}

// The decoder's search becomes a grammar that is exactly `words` in order (optional silence and
// noise between them); words missing from its dictionary are added with their phones (and have
// `phones` cleared when the dictionary has them).
void set_grammar(Decoder& d, std::vector<HmmWord>& words) {
  ps_decoder_t* ps = d.ps;
  fsg_model_t* fsg = fsg_model_init("facecast_align", ps_get_logmath(ps), 1.0f,
                                    static_cast<int>(words.size()) + 1);
  fsg->start_state = 0;
  fsg->final_state = static_cast<int>(words.size());
  for (std::size_t i = 0; i < words.size(); ++i) {
    HmmWord& w = words[i];
    if (char* known = ps_lookup_word(ps, w.name.c_str())) {
      ckd_free(known);
      w.phones.clear();  // the dictionary's pronunciations (all variants) serve
    } else if (!w.phones.empty()) {
      if (ps_add_word(ps, w.name.c_str(), w.phones.c_str(), FALSE) < 0) {
        fsg_model_free(fsg);
        throw Error("alignment: pocketsphinx refused the pronunciation '" + w.phones + "' of '" +
                    w.name + "'");
      }
      ++d.added;
    } else {
      // No CMU phones for it (only a glottal stop): the word gets the shortest vowel.
      w.phones = "AH";
      ps_add_word(ps, w.name.c_str(), w.phones.c_str(), FALSE);
      ++d.added;
    }
    const int wid = fsg_model_word_add(fsg, w.name.c_str());
    fsg_model_trans_add(fsg, static_cast<int>(i), static_cast<int>(i) + 1, 0, wid);
  }
  const bool set =
      ps_set_fsg(ps, "facecast_align", fsg) == 0 && ps_set_search(ps, "facecast_align") == 0;
  fsg_model_free(fsg);  // the search holds its own reference
  if (!set) throw Error("alignment: pocketsphinx refused the transcript grammar");
}

}  // namespace

bool hmm_installed() {
  std::error_code ec;
  return std::filesystem::exists(std::filesystem::path(FACECAST_PS_HMM) / "mdef", ec) &&
         std::filesystem::exists(FACECAST_PS_DICT, ec);
}

bool hmm_applies(const Plan& plan) {
  bool any = false;
  for (const PlanUnit& u : plan.units) {
    if (u.lang != Lang::kEn) return false;
    any = any || !u.phones.empty();
  }
  return any;
}

std::vector<HmmWord> hmm_words(const Plan& plan) {
  std::vector<HmmWord> out;
  for (std::size_t i = 0; i < plan.units.size(); ++i) {
    const PlanUnit& u = plan.units[i];
    if (u.phones.empty()) continue;
    HmmWord w;
    w.name = dict_name(u.text);
    // Whether the dictionary has it is known only to a decoder: hmm_decode adds it when missing.
    w.phones = joined(hmm_phone_groups(u));
    // A word the dictionary cannot name is named by its phones: a pooled decoder keeps the words
    // added to it, so one name must never stand for two pronunciations.
    if (w.name.empty()) {
      w.name = "facecast_word";
      for (const char c : w.phones) w.name += c == ' ' ? '_' : c;
    }
    out.push_back(std::move(w));
  }
  return out;
}

namespace {

// Viterbi decoding of pcm[first, last) (16 kHz) with a grammar that is exactly `words` in order
// (optional silence between them); fills each word's span (seconds of the whole pcm). False when
// the search did not reach the grammar's end (the caller falls back to DTW). Thread-safe: each call
// takes a decoder from a guarded pool.
bool hmm_decode(std::vector<HmmWord>& words, const std::vector<int16_t>& pcm, std::size_t first,
                std::size_t last) {
  if (words.empty()) return false;
  std::unique_ptr<Decoder> d = pool().take();
  ps_decoder_t* ps = d->ps;
  set_grammar(*d, words);
  if (ps_start_utt(ps) < 0)
    throw Error("alignment: pocketsphinx cannot start", ErrorCode::kInternal);
  ps_process_raw(ps, pcm.data() + first, last - first, FALSE, TRUE);
  ps_end_utt(ps);
  const std::vector<Segment> segs = segments(ps);
  const double offset = static_cast<double>(first) / 16000;
  bool complete = segs.size() == words.size();
  for (std::size_t i = 0; complete && i < segs.size(); ++i) {
    complete = segs[i].word == words[i].name;
    words[i].span = {offset + segs[i].first * kFrame, offset + (segs[i].last + 1) * kFrame};
  }
  pool().give(std::move(d));
  return complete;
}

// The samples pocketsphinx reads: the speech and kSilenceKept of what is silent around it. Its
// cepstral mean is the utterance's, so long silence before or after the speech would pull it
// towards silence (one second of it moved a word 80 ms).
std::pair<std::size_t, std::size_t> speech_samples(const std::vector<bool>& silent,
                                                   const Features& f, std::size_t samples) {
  constexpr double kSilenceKept = 0.3;
  const auto speech = std::find(silent.begin(), silent.end(), false);
  if (speech == silent.end()) return {0, samples};
  const auto end = std::find(silent.rbegin(), silent.rend(), false);
  const double a = f.time(static_cast<std::size_t>(speech - silent.begin())) - kSilenceKept;
  const double b =
      f.time(silent.size() - 1 - static_cast<std::size_t>(end - silent.rbegin())) + kSilenceKept;
  const auto at = [&](double t) {
    return std::min(samples, static_cast<std::size_t>(std::max(0.0, t) * 16000));
  };
  return {at(a), std::max(at(a), at(b))};
}

}  // namespace

std::optional<Timeline> align_hmm(const Plan& plan, const Timeline& synth, const Audio& audio,
                                  const AlignOptions& ao) {
  std::vector<HmmWord> words = hmm_words(plan);
  const Features f = compute_features(audio.samples, audio.sample_rate);
  const std::vector<int16_t> pcm = pcm16_at_16k(audio);
  const auto [first, last] =
      speech_samples(silent_frames(f, ao.silence_range, ao.silence_max_db), f, pcm.size());
  if (!hmm_decode(words, pcm, first, last)) return std::nullopt;
  // A word after a pause (or at the start) that begins with a stop takes the silence before it as
  // the stop's closure: its onset moves to the first frame that is not silent by the DTW path's
  // silence test (its levels taken where pocketsphinx listened, so silence around the speech does
  // not lower them), leaving it at least kMinWord.
  constexpr double kMinWord = 0.05;
  std::vector<bool> silent(f.frames(), true);
  {
    const auto frame = [&](std::size_t sample) {
      return std::min(f.frames(), static_cast<std::size_t>(sample / 16000.0 / f.hop_seconds));
    };
    const std::size_t a = frame(first), b = std::min(f.frames(), std::max(a + 1, frame(last)));
    Features heard;
    heard.energy_db.assign(f.energy_db.begin() + static_cast<std::ptrdiff_t>(a),
                           f.energy_db.begin() + static_cast<std::ptrdiff_t>(b));
    const std::vector<bool> s = silent_frames(heard, ao.silence_range, ao.silence_max_db);
    std::copy(s.begin(), s.end(), silent.begin() + static_cast<std::ptrdiff_t>(a));
  }
  for (HmmWord& w : words) {
    auto k = static_cast<std::size_t>(std::max(0.0, std::floor(w.span.start / f.hop_seconds)));
    bool moved = false;
    while (k < silent.size() && silent[k] && f.time(k + 1) < w.span.end - kMinWord)
      ++k, moved = true;
    if (moved) w.span.start = std::max(w.span.start, f.time(k) - f.frame_seconds / 2);
  }
  Timeline tl;
  tl.duration = audio.seconds();
  tl.units.resize(plan.units.size());
  // HMM phone pass: one grammar word per CMU phone of the plan's own (espeak-ng) phones.
  std::vector<HmmWord> phones;
  std::vector<std::vector<std::size_t>> phone_count;  // per unit, per plan phone: CMU phones
  bool phone_pass = ao.hmm_phones == AlignOptions::HmmPhones::kHmm;
  if (phone_pass) {
    for (const PlanUnit& u : plan.units) {
      phone_count.emplace_back();
      for (const auto& g : hmm_phone_groups(u)) {
        phone_count.back().push_back(g.size());
        for (const auto& p : g) phones.push_back({"facecast_phone_" + p, p, {}});
      }
    }
    phone_pass = hmm_decode(phones, pcm, first, last);
  }
  std::size_t w = 0, ph = 0;
  double previous = 0;
  for (std::size_t i = 0; i < plan.units.size(); ++i) {
    const PlanUnit& u = plan.units[i];
    UnitTime& tu = tl.units[i];
    if (u.phones.empty()) {
      tu.span = {previous, previous};
      continue;
    }
    const Span span = words[w++].span;
    tu.span = span;
    if (phone_pass) {
      // Each plan phone spans its CMU phones, clamped into the word; a phone without any starts
      // where the next one does.
      double t = span.start;
      for (std::size_t k = 0; k < u.phones.size(); ++k) {
        const std::size_t n = phone_count[i][k];
        Span p{t, t};
        if (n > 0) {
          p = {std::clamp(phones[ph].span.start, t, span.end),
               std::clamp(phones[ph + n - 1].span.end, t, span.end)};
          ph += n;
        }
        if (k == 0) p.start = span.start;
        tu.phones.push_back(p);
        t = p.end;
      }
      for (std::size_t k = 0; k + 1 < tu.phones.size(); ++k)
        tu.phones[k].end = tu.phones[k + 1].start;
      tu.phones.back().end = span.end;
    } else {
      // espeak-ng's timing of the word's phones, stretched onto the word's span.
      const UnitTime& su = synth.units[i];
      const double s0 = su.phones.front().start, s1 = su.phones.back().end;
      const double scale = s1 > s0 ? (span.end - span.start) / (s1 - s0) : 0;
      for (const Span& p : su.phones)
        tu.phones.push_back(
            {span.start + (p.start - s0) * scale, span.start + (p.end - s0) * scale});
    }
    // Every phone keeps at least kMinPhone (or an equal share of a shorter word).
    const double n = static_cast<double>(tu.phones.size());
    const double min_phone = std::min(kMinPhone, (span.end - span.start) / n);
    for (std::size_t k = 0; k < tu.phones.size(); ++k) {
      Span& p = tu.phones[k];
      p.start = std::max(p.start, k > 0 ? tu.phones[k - 1].end : span.start);
      p.end = std::max(p.end, p.start + min_phone);
    }
    for (std::size_t k = tu.phones.size(); k-- > 0;) {
      Span& p = tu.phones[k];
      p.end = std::min(p.end, k + 1 < tu.phones.size() ? tu.phones[k + 1].start : span.end);
      p.start = std::min(p.start, p.end - min_phone);
    }
    previous = span.end;
  }
  return tl;
}

struct HmmStream::Impl {
  std::unique_ptr<Decoder> d;
  bool started = false;              // a search is running
  bool fresh = true;                 // no audio yet: the cepstral mean starts over
  std::vector<std::string> grammar;  // word names of the grammar's phones

  cmn_t& cmn() const { return *ps_get_feat(d->ps)->cmn_struct; }
  // The live mean becomes the mean of the stream's frames so far once there are enough of them
  // (pocketsphinx would update it only every 800 frames).
  static constexpr int kMinFrames = 30;
  void update_mean() {
    cmn_t& c = cmn();
    if (c.nframe < kMinFrames) return;
    for (int j = 0; j < c.veclen; ++j) c.cmn_mean[j] = c.sum[j] / static_cast<mfcc_t>(c.nframe);
  }
};

HmmStream::HmmStream() : impl_(std::make_unique<Impl>()) {
  impl_->d = pool(true).take();
}

HmmStream::~HmmStream() {
  if (impl_->started) ps_end_utt(impl_->d->ps);
  pool(true).give(std::move(impl_->d));
}

void HmmStream::restart(const std::vector<std::string>& phones, const std::int16_t* pcm,
                        std::size_t n) {
  ps_decoder_t* ps = impl_->d->ps;
  if (impl_->started) ps_end_utt(ps);
  impl_->started = false;
  std::vector<HmmWord> words;
  for (const std::string& p : phones) words.push_back({"facecast_phone_" + p, p, {}});
  set_grammar(*impl_->d, words);
  if (impl_->fresh) {
    cmn_t& c = impl_->cmn();
    std::copy(impl_->d->initial_mean.begin(), impl_->d->initial_mean.end(), c.cmn_mean);
    std::fill(c.sum, c.sum + c.veclen, mfcc_t{0});
    c.nframe = 0;
  }
  // Frame numbers count from the stream's start: each search starts one.
  if (ps_start_stream(ps) < 0 || ps_start_utt(ps) < 0)
    throw Error("alignment: pocketsphinx cannot start", ErrorCode::kInternal);
  impl_->started = true;
  feed(pcm, n);
}

void HmmStream::feed(const std::int16_t* pcm, std::size_t n) {
  if (!impl_->started || n == 0) return;
  impl_->fresh = false;
  ps_process_raw(impl_->d->ps, pcm, n, FALSE, FALSE);
  impl_->update_mean();
}

void HmmStream::finish() {
  if (impl_->started) ps_end_utt(impl_->d->ps);
  impl_->started = false;
}

bool HmmStream::settled() const {
  return !impl_->fresh && impl_->cmn().nframe >= Impl::kMinFrames;
}

int HmmStream::frames() const {
  return ps_get_n_frames(impl_->d->ps);
}

std::vector<HmmStream::Segment> HmmStream::path() const {
  std::vector<Segment> out;
  std::size_t k = 0;
  for (ps_seg_t* s = ps_seg_iter(impl_->d->ps); s; s = ps_seg_next(s)) {
    Segment g;
    ps_seg_frames(s, &g.first, &g.last);
    // The grammar's phones are its only non-filler words, and the grammar is linear: the k-th
    // of them on the path is phone k.
    if (std::string_view(ps_seg_word(s)).starts_with("facecast_phone_"))
      g.phone = static_cast<int>(k++);
    out.push_back(g);
  }
  return out;
}

HmmPoolStats hmm_pool_stats() {
  return pool().stats();
}

}  // namespace facecast::viseme::detail
