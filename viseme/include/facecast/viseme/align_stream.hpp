#pragma once
// Streaming alignment: TTS audio and its text as both arrive (a TTS that streams audio chunks with
// its text beside them), aligned with a bounded look-ahead. English text, through the same
// pocketsphinx model as the whole-file aligner: the grammar is the text's phones so far, searched
// frame by frame; everything more than `AlignOptions::stream_lag` seconds behind the newest frame
// is taken from the best path and never changes. See docs/algorithms.md#streaming-alignment.
#include <cstddef>
#include <memory>
#include <string_view>
#include <vector>

#include "facecast/viseme/align.hpp"
#include "facecast/viseme/options.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

class StreamAligner {
 public:
  /// `sample_rate`: the audio's (8000..48000). Text without times needs pocketsphinx-en-us (an
  /// Error at the first such text when it is missing).
  explicit StreamAligner(int sample_rate, const Options& options = {},
                         const AlignOptions& align_options = {});
  ~StreamAligner();
  StreamAligner(StreamAligner&&) noexcept;
  StreamAligner& operator=(StreamAligner&&) noexcept;

  /// More of the text, in pieces of any size (a word is taken once whitespace follows it, or at
  /// end_text()); expression tags work as in analyze(). Throws Error for text other than English
  /// or a malformed tag.
  void add_text(std::string_view piece);
  /// Text with its time instead (a TTS's word or character timestamps, as ElevenLabs and Azure
  /// stream them): `text` is spoken over [start, end] seconds of the audio; no search is made, and
  /// any language the text path reads is taken. Pieces come in order; a stream takes either timed
  /// text or text without times. Throws Error for a bad span or mixing the two.
  void add_timed_text(std::string_view text, double start, double end);
  /// No more text: the last word is taken.
  void end_text();
  /// More audio (mono, at the constructor's rate).
  void add_audio(const float* samples, std::size_t n);
  /// The audio has ended (and with it the text): everything is decided.
  void finish();

  /// Seconds of audio decided: the events before it are final. Frames wait for text: audio past
  /// the last word that has arrived is not decided until the next word (or end_text()) comes.
  double decided() const;
  /// Seconds of audio received.
  double received() const;
  /// The viseme events: final before decided(); after it the best path so far (it may change), so
  /// an animation sampled up to decided() sees the coming phones. Events that ended more than
  /// `keep_seconds` before decided() are dropped as the stream goes on.
  const std::vector<VisemeEvent>& visemes() const;
  /// Phones decided so far (final), for comparison with the whole-file alignment.
  const std::vector<Phone>& phones() const;
  /// Expression tags of the text whose place (the next word's start) has been decided since the
  /// last call.
  std::vector<ExpressionEvent> take_expressions();
  VisemeSet set() const;

  static constexpr double keep_seconds = 5.0;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecast::viseme
