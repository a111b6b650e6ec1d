#pragma once
// Forced alignment of text to speech audio. English text goes through an HMM aligner when Debian's
// pocketsphinx-en-us model is installed (Viterbi decoding with a grammar that is exactly the
// transcript). Chinese and other text (or English with `english: dtw`) is aligned without acoustic
// models: the text's phones are spoken by espeak-ng (times known), both signals become MFCCs, DTW
// with slope constraints maps one onto the other, the phone boundaries go through the path and are
// refined locally on spectral change and energy; pauses in the audio become rest. See
// docs/algorithms.md#forced-alignment.
#include <string_view>
#include <vector>

#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/options.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

/// Defaults mirror configs/viseme/align.json.
struct AlignOptions {
  enum class Backend { kHmm, kDtw };
  /// English text: pocketsphinx's HMM (when pocketsphinx-en-us is installed; DTW otherwise, and
  /// when its search fails) or DTW. Other text always takes DTW.
  Backend english = Backend::kHmm;
  enum class HmmPhones { kEspeak, kHmm };
  /// The phones inside an HMM-aligned word: espeak-ng's timing stretched onto the word, or a
  /// second HMM pass over the plan's phones.
  HmmPhones hmm_phones = HmmPhones::kHmm;
  int min_speed = 80, max_speed = 450;  // espeak-ng words/minute when matching the audio's pace
  double band = 0.25;  // DTW search band, fraction of the longer sequence (+ band_frames)
  int band_frames = 50;
  double refine_seconds = 0.03;  // boundary refinement searches +- this far
  double refine_weight = 1.0;    // distance penalty of the refinement (per window)
  double min_pause = 0.15;       // silences at least this long become rest
  double silence_range = 0.30;   // silence threshold: floor + this x (loud - floor), in dB
  double silence_max_db = 40;    // ... and at most this far below the loud level
  double hold_penalty = 2.0;     // DTW: cost of holding one side where only the other is silent
  bool deltas = true;            // MFCC first differences in the DTW distance
  bool refine = true;            // boundary refinement on spectral change and energy
  /// Longer audio is refused (DTW memory grows with length x band: about 80 MB at 120 s).
  double max_seconds = 120;
  /// Streaming alignment (StreamAligner): the audio this far behind the newest searched frame is
  /// decided from the best path so far.
  double stream_lag = 0.05;
  /// Frequency warps tried on the audio's filterbank (vocal tract length normalisation).
  std::vector<double> warps = {0.8, 0.86, 0.92, 1.0, 1.06, 1.13, 1.2, 1.27};
};

/// configs/viseme/align.json; Error naming the file and key.
AlignOptions load_align_options();

/// The Utterance of `text` timed on `audio` (its times are seconds of `audio`; pcm = the audio at
/// its working rate). Text, tags and the viseme set work as in analyze(). Throws Error when the
/// text has nothing to say or the audio holds no speech.
Utterance align(std::string_view text, const Audio& audio, const Options& options = {},
                const AlignOptions& align_options = {});

}  // namespace facecast::viseme
