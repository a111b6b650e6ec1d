#pragma once
// The frame features of the audio-only lip-sync, shared by the analyser and the build-time
// template generator (so both see exactly the same numbers). See docs/algorithms.md#audio-lipsync.
#include <array>
#include <cstddef>
#include <deque>
#include <memory>
#include <vector>

#include "facecast/viseme/lipsync.hpp"
#include "features.hpp"

namespace facecast::viseme::detail {

inline constexpr int kLipsyncCepstra = 12;  // c1..c12
/// Feature vector: cepstra (speaker-normalised), their deltas, relative level / 10, its delta,
/// voicing, zero-crossing rate x 4, first-formant openness (0..1), nasality (bass - mid dB) / 20.
inline constexpr int kLipsyncDims = 2 * kLipsyncCepstra + 6;

/// A frame before look-ahead: what one window alone gives.
struct RawFrame {
  double time = 0;
  float level_db = 0;  // 10 log10(mean square)
  float voicing = 0;   // peak normalised autocorrelation at 60..400 Hz lags (8 kHz), 0..1
  float zcr = 0;       // zero crossings per sample
  std::array<float, kLipsyncCepstra> cep{};
  float bass_db = 0;    // energy of the mel bands centred at 150..500 Hz, dB
  float mid_db = 0;     // ... at 1000..2200 Hz
  float treble_db = 0;  // ... at 2500..4000 Hz
  float f1_hz = 0;      // first-formant proxy: power^2-weighted centre of the bands at 250..1000 Hz
};

/// A frame ready for classification.
struct FeatureFrame {
  double time = 0;
  bool silent = true;
  bool settled = false;  // the speech level has 10 voiced frames behind it
  float loudness = 0;    // 0..1, see LipsyncOptions::jaw_range_db
  float level = 0;       // dB relative to the speech level
  float voicing = 0;     // see RawFrame
  float dull = 0;        // bass_db - treble_db: high for nasal murmur, low for /i/ (F2, F3 high)
  float nasal = 0;       // bass_db - mid_db: high for nasal murmur (weak F2/F3), lower for r l w
  float openness = 0;    // 0..1 from the first-formant proxy (the vowel's jaw), speaker-normalised
  std::array<float, kLipsyncDims> x{};
};

/// PCM -> FeatureFrames, one frame of look-ahead (deltas). Speaker normalisation: the cepstral
/// mean over speech frames and the speech level adapt over the first adapt_seconds (cumulative,
/// started from the templates' mean with prior_frames of weight), then follow an exponential mean
/// of that length. The silence floor follows the quietest frames (rising 2 dB/s).
class FeatureStream {
 public:
  FeatureStream(int sample_rate, const LipsyncOptions& options,
                const std::vector<float>& cep_prior);
  void push(const float* samples, std::size_t n, std::vector<FeatureFrame>& out);
  void finish(std::vector<FeatureFrame>& out);
  double hop_seconds() const { return hop_seconds_; }
  double window_seconds() const { return window_seconds_; }

 private:
  RawFrame analyze(const float* frame);
  FeatureFrame complete(const RawFrame& prev, const RawFrame& cur, const RawFrame& next);
  void adapt(const RawFrame& f);

  LipsyncOptions options_;
  std::unique_ptr<MfccAnalyzer> mfcc_;
  std::vector<float> buffer_;  // samples not yet consumed by a frame
  std::size_t frames_ = 0;
  double hop_seconds_ = 0.01, window_seconds_ = 0.025;
  int rate_ = 0;
  std::deque<RawFrame> pending_;  // raw frames awaiting their successor
  RawFrame previous_{};
  bool has_previous_ = false;
  // Speaker normalisation state.
  std::array<double, kLipsyncCepstra> cep_mean_{};
  double cep_weight_ = 0;
  double speech_db_ = -26, speech_weight_ = 0;
  double floor_db_ = 0;
  bool started_ = false;
  // Mel band ranges of RawFrame's band energies, and the speaker's first-formant range.
  int bass0_ = 0, bass1_ = 0, mid0_ = 0, mid1_ = 0, f10_ = 0, f11_ = 0, tr0_ = 0, tr1_ = 0;
  std::vector<float> centre_hz_;
  double f1_lo_ = 350, f1_hi_ = 750;
};

}  // namespace facecast::viseme::detail
