#pragma once
// The English HMM backend of forced alignment: Debian's pocketsphinx with its en-us acoustic model
// (pocketsphinx-en-us) decodes the audio with a grammar that is exactly the transcript (optional
// silence between words); words missing from its CMU dictionary are spoken through espeak-ng's
// phones mapped to CMU phones (configs/viseme/phones_espeak_cmu.json). See
// docs/algorithms.md#forced-alignment.
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

/// Viterbi decoding of `audio` with a grammar that is exactly `words` in order (optional silence
/// between them); fills each word's span. False when the search did not reach the grammar's end
/// (the caller falls back to DTW). Thread-safe: each call takes a decoder from a guarded pool.
/// Throws Error when the model cannot be loaded.
bool hmm_decode(std::vector<HmmWord>& words, const Audio& audio);

/// The timeline of `plan` on `audio` by the HMM: each unit in its word's span; the phones inside
/// by options.hmm_phones: espeak-ng's timing (`synth`) stretched onto the span, or a second HMM
/// pass over the plan's own phones (mapped to CMU). nullopt when the search failed.
std::optional<Timeline> align_hmm(const Plan& plan, const Timeline& synth, const Audio& audio,
                                  const AlignOptions& options);

/// Decoders created since start-up and the seconds the last creation took (for the benchmark).
struct HmmPoolStats {
  int created = 0;
  double last_load_seconds = 0;
};
HmmPoolStats hmm_pool_stats();

}  // namespace facecast::viseme::detail
