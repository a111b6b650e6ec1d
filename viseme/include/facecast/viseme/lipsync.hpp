#pragma once
// Lip-sync from speech audio alone, streaming: PCM chunks in, one sound class and loudness per
// 10 ms frame out, with a bounded look-ahead; runs of a class become viseme events whose strength
// follows the loudness (the jaw), for the same coarticulation and mixing as the text path (anim).
// The class templates are learned at build time from espeak-ng speech of English and Mandarin
// (facecast_viseme_lipsyncgen). See docs/algorithms.md#audio-lipsync.
#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/options.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

/// Mouth classes of the audio-only path. kClosure: the lips meet (p b m; a short silence after
/// voicing); kConsonant: other consonants (t d k g n l r ...); vowels by their mouth shape.
/// kLabiodental: f v (the lower lip against the teeth); kFricative: the other fricatives.
enum class SoundClass : int {
  kSilence,
  kClosure,
  kFricative,
  kConsonant,
  kA,
  kE,
  kI,
  kO,
  kU,
  kLabiodental
};
inline constexpr int kSoundClasses = 10;
std::string_view to_string(SoundClass c) noexcept;
/// "sil" | "closure" | "fricative" | "consonant" | "a" | "e" | "i" | "o" | "u" | "labiodental";
/// Error otherwise.
SoundClass parse_sound_class(std::string_view name);

/// Defaults mirror configs/viseme/lipsync.json.
struct LipsyncOptions {
  double adapt_seconds = 3.0;     // speaker normalisation: cumulative mean over this, then running
  double prior_frames = 50;       // weight (frames) of the templates' mean at the stream's start
  double silence_range = 0.35;    // silent: level < floor + this x (speech level - floor) ...
  double silence_max_db = 35;     // ... or more than this below the speech level
  double closure_max = 0.15;      // a silence after voicing shows as a closure this long at most
  double closure_entry_db = -12;  // ... when the sound before it was this loud (dB re speech)
  double murmur_nasal_db = 7;     // nasal murmur: energy at 150..500 Hz over 1..2.2 kHz >= this
  double murmur_dull_db = 5;      // ... and at 150..500 Hz over 2.5..4 kHz at least this
  double murmur_dip_db = 2;       // ... and this far below the loudest frame around it
  double murmur_voicing = 0.5;    // ... and voiced at least this much
  double murmur_openness = 0.5;   // ... and its first-formant openness at most this
  double closure_bias = 60;       // log-likelihood bonus of closure over consonant in a murmur
  double labiodental_max_db = -10;  // f/v: frication at most this loud (dB re speech) ...
  double labiodental_bias = 10;     // ... shows FF unless s/th or a stop leads by this
  double burst_max_db = -8;         // outside a murmur, the closure class only this weak (dB)
  int lookahead_frames = 3;         // class decision waits this many 10 ms frames
  int context_frames = 2;           // ... and sums the log-likelihoods of this many past frames
  double switch_margin = 5.0;       // log-likelihood lead a new class needs (hysteresis)
  double jaw_range_db = 30;         // loudness range (dB below the speech level) mapped to the jaw
  double jaw_min = 0.1;             // strength of a sounding viseme at the bottom of that range
  double jaw_max = 1.0;             // ... and at (or above) the speech level
  double jaw_openness = 0.5;        // share of the vowels' jaw taken from the first formant
  double delay = 0.04;              // live: weights trail the analysed audio by this (anticipation)
  double window = 0.6;              // live: seconds of past events kept for coarticulation
  /// The viseme each class shows, per set, in SoundClass order.
  std::array<std::string, kSoundClasses> oculus = {"sil", "PP", "SS", "DD", "aa",
                                                   "E",   "I",  "O",  "U",  "FF"};
  std::array<std::string, kSoundClasses> zh15 = {"sil", "bpm", "zcs", "dtnl", "a",
                                                 "e",   "i",   "o",   "uv",   "f"};
  std::array<std::string, kSoundClasses> mpeg4 = {"none", "pbm", "sz", "td", "A",
                                                  "e",    "I",   "Q",  "U",  "fv"};
  const std::string& viseme(VisemeSet set, SoundClass c) const;
};

/// configs/viseme/lipsync.json; Error naming the file and key.
LipsyncOptions load_lipsync_options();

/// Per-class diagonal Gaussian mixtures over the frame features, learned at build time.
struct LipsyncTemplates {
  struct Component {
    double log_weight = 0;
    std::vector<float> mean, inv_var;  // dims each
    double log_norm = 0;               // -0.5 (dims log 2pi + sum log var)
  };
  int dims = 0;
  std::vector<float> cepstral_mean;  // speaker-normalisation prior: mean cepstra of the training
  std::array<std::vector<Component>, kSoundClasses> classes;  // kSilence stays empty
  std::array<double, kSoundClasses> log_prior{};
  /// Parses the generator's JSON; Error naming `source` and the field.
  static LipsyncTemplates parse(std::string_view json, std::string_view source);
  /// The build's table: $FACECAST_LIPSYNC_TEMPLATES, else the build tree's, else the installed
  /// one (<prefix>/share/facecast). Loaded once; Error naming the path when missing or bad.
  static const LipsyncTemplates& builtin();
  /// Log-likelihood of each sounding class for feature vector `x` (dims values); kSilence gets
  /// -inf.
  void score(const float* x, std::array<double, kSoundClasses>& out) const;
};

/// One analysed 10 ms frame.
struct LipsyncFrame {
  double time = 0;  // seconds from the stream's start (the frame's centre)
  SoundClass cls = SoundClass::kSilence;
  float loudness = 0;  // 0..1: the jaw's share from the level relative to the speech level
  bool silent = true;  // below the silence threshold (the level decision alone)
  float openness = 0;  // 0..1: the vowel's jaw from the first formant (speaker-normalised)
};

/// The streaming analyser: push mono float at its sample rate in chunks of any size; frames come
/// out `latency()` seconds after their audio. Not thread-safe; one per stream. Cost per 10 ms
/// frame: one 512-point FFT, a 40-lag autocorrelation at 8 kHz and 8 x K Gaussians (about 20 us).
class LipsyncAnalyzer {
 public:
  LipsyncAnalyzer(int sample_rate, const LipsyncOptions& options = {},
                  const LipsyncTemplates& templates = LipsyncTemplates::builtin());
  ~LipsyncAnalyzer();
  LipsyncAnalyzer(LipsyncAnalyzer&&) noexcept;
  LipsyncAnalyzer& operator=(LipsyncAnalyzer&&) noexcept;

  void push(const float* samples, std::size_t n, std::vector<LipsyncFrame>& out);
  /// The end of the stream: the frames still waiting for look-ahead.
  void finish(std::vector<LipsyncFrame>& out);
  /// Seconds from a sample's arrival to its frame's output (half a window + look-ahead).
  double latency() const;
  int sample_rate() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Frames -> viseme events of `set`: runs of one class, strength = jaw_min + (jaw_max - jaw_min)
/// x mean loudness (sounding classes). Appends to `events`, extending its last event when the
/// class continues. `hop` = frame spacing (seconds).
void append_lipsync_events(const std::vector<LipsyncFrame>& frames, VisemeSet set,
                           const LipsyncOptions& options, double hop,
                           std::vector<VisemeEvent>& events);

/// Expression tags "(name,intensity,seconds)@time ..." -> events (ramps as in the text path). A tag
/// without "@time" starts at `now`; with `now` < 0 the time is required. Throws Error naming the
/// tag (malformed, unknown expression, out of range).
std::vector<ExpressionEvent> parse_expression_tags(std::string_view tags, double now = -1);

/// Audio-only lip-sync of a whole signal (the analyser run over it): an Utterance with visemes in
/// options.set (auto: oculus), no phones or words, the audio as pcm. `tags` (optional) holds
/// expression tags with their times, "(smile,40,0.5)@1.2 (smile,0,0.3)@3": ramps as in the text
/// path. Throws Error when the audio holds no speech or a tag is malformed.
Utterance lipsync(const Audio& audio, const Options& options = {},
                  const LipsyncOptions& lipsync_options = {}, std::string_view tags = {});

}  // namespace facecast::viseme
