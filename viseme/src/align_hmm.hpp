#pragma once
// The English HMM backend of forced alignment: Debian's pocketsphinx with its en-us acoustic model
// (pocketsphinx-en-us) decodes the audio with a grammar that is exactly the transcript (optional
// silence between words); words missing from its CMU dictionary are spoken through espeak-ng's
// phones mapped to CMU phones (configs/viseme/phones_espeak_cmu.json). See
// docs/algorithms.md#forced-alignment.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"
#include "plan.hpp"
#include "timeline.hpp"

namespace facecast::viseme::detail {

/// Whether pocketsphinx-en-us's model and dictionary are installed.
bool hmm_installed();

/// Whether the plan is one the HMM serves: English units only (and at least one with phones).
bool hmm_applies(const Plan& plan);

/// A word of the HMM grammar and where it landed in the audio.
struct HmmWord {
  std::string name;    // the dictionary entry (the word, or a name given to an added one)
  std::string phones;  // CMU phones when added from espeak-ng's (empty: from the dictionary)
  Span span;           // seconds of the audio (frames of 10 ms)
};

/// The grammar's words for the plan's units (one per unit with phones, in order; CMU dictionary
/// pronunciations where the word is listed, espeak-ng's phones mapped to CMU otherwise).
std::vector<HmmWord> hmm_words(const Plan& plan);

/// The timeline of `plan` on `audio` by the HMM: each unit in its word's span; the phones inside
/// by options.hmm_phones: espeak-ng's timing (`synth`) stretched onto the span, or a second HMM
/// pass over the plan's own phones (mapped to CMU). nullopt when the search failed.
std::optional<Timeline> align_hmm(const Plan& plan, const Timeline& synth, const Audio& audio,
                                  const AlignOptions& options);

/// The unit's phones as CMU phones (configs/viseme/phones_espeak_cmu.json): one group per plan
/// phone, possibly empty.
std::vector<std::vector<std::string>> hmm_phone_groups(const PlanUnit& unit);

/// One live stream's decoder: a pooled pocketsphinx decoder with a live cepstral mean (the running
/// mean of the stream's own frames, set after every chunk), searching a grammar of CMU phones that
/// is replaced as text arrives by restarting on the audio since a point. Not thread-safe.
class HmmStream {
 public:
  HmmStream();  // Error when the model cannot be loaded
  ~HmmStream();
  HmmStream(const HmmStream&) = delete;
  HmmStream& operator=(const HmmStream&) = delete;

  /// A new search with the grammar `phones` (CMU phone names in order, optional silence between
  /// them), then `n` samples of 16 kHz PCM from its start.
  void restart(const std::vector<std::string>& phones, const std::int16_t* pcm, std::size_t n);
  /// More audio of the current search.
  void feed(const std::int16_t* pcm, std::size_t n);
  /// Ends the search: path() becomes the best path that ends the grammar (or the best partial).
  void finish();
  /// Whether the stream has had enough speech frames for its own cepstral mean.
  bool settled() const;
  /// 10 ms frames searched since the restart (a few behind the audio fed: feature context).
  int frames() const;
  /// The best path so far: `phone` indexes the grammar, -1 is silence or noise; frames since the
  /// restart, inclusive.
  struct Segment {
    int phone = -1;
    int first = 0, last = 0;
  };
  std::vector<Segment> path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Decoders created since start-up and the seconds the last creation took (for the benchmark).
struct HmmPoolStats {
  int created = 0;
  double last_load_seconds = 0;
};
HmmPoolStats hmm_pool_stats();

}  // namespace facecast::viseme::detail
