#pragma once
// The ONE gate to espeak-ng. espeak-ng keeps global state and is not thread-safe, so every call
// into it in Facecast goes through these functions, which hold one process-wide mutex for the
// whole call (voice selection, phonemization, synthesis). Nothing else may include espeak headers.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::viseme::detail::espeak {

/// espeak-ng phoneme mnemonics of one word or short text, with stress marks (' ,) kept as a
/// prefix of the stressed vowel: "hello" -> {"h", "@", "l", "'oU"}.
std::vector<std::string> phonemize(std::string_view text, const std::string& voice);

struct Event {
  enum class Kind { kWord, kPhoneme, kEnd };
  Kind kind = Kind::kWord;
  double time = 0;        // seconds from the start of this synthesis
  int text_position = 0;  // kWord: 1-based character position in the text
  std::string phoneme;    // kPhoneme: mnemonic ("_" ... for pauses)
};

struct Synthesis {
  std::vector<int16_t> pcm;
  int sample_rate = 0;
  std::vector<Event> events;
};

/// Speaks `text` with `voice` at `speed` words per minute; audio and events together. With
/// `phoneme_input`, text within [[ ]] is espeak-ng phonemes (the English lexicon's words; the
/// callers' text never holds brackets otherwise).
Synthesis synthesize(std::string_view text, const std::string& voice, int speed,
                     bool phoneme_input = false);

/// The sample rate espeak-ng produces (initializes it).
int sample_rate();

}  // namespace facecast::viseme::detail::espeak
