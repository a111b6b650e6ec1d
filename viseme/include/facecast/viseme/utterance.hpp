#pragma once
// The value a speech analysis produces: timed phones, syllables, visemes, expressions and words for
// one utterance, plus optional PCM audio. Times are seconds from the start of the utterance's
// audio.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace facecast::viseme {

/// The viseme vocabulary of an utterance (one per utterance; see options.hpp for mixed text).
/// See docs/algorithms.md#viseme-sets.
///  zh15:   15 Chinese classes a bpm dtnl e f gkh i jqx o r uv zcs zhchsh n ng
///  mpeg4:  MPEG-4 FAP1 visemes 1-14: pbm fv TD td kg tSdZS sz nl r A e I Q U
///  oculus: Oculus/ARKit-style 15: PP FF TH DD kk CH SS nn RR aa E I O U (+ sil)
/// Every set also has a pause viseme: "sil" (zh15, oculus) / "none" (mpeg4).
enum class VisemeSet { kZh15, kMpeg4, kOculus };

std::string_view to_string(VisemeSet set) noexcept;
/// "zh15" | "mpeg4" | "oculus"; throws Error naming the value otherwise.
VisemeSet parse_viseme_set(std::string_view name);

struct Phone {
  std::string
      phone;  // zh: pinyin units (zh, u, a, -ng ...); en: espeak-ng mnemonics; imports: as given
  double start = 0, end = 0;
  std::string lang;  // "zh" | "en" | the import's phone set
};

struct Syllable {
  std::string text;    // the Chinese character (after number normalization)
  std::string pinyin;  // numbered, v for u-umlaut, 5 for the neutral tone: "lv4", "de5"
  double start = 0, end = 0;
};

struct VisemeEvent {
  std::string viseme;  // a name of the utterance's set
  double start = 0, end = 0;
  /// Scales the viseme's channel in its coarticulation key (1 from text; the audio-only lip-sync
  /// sets it from the loudness, so the jaw follows it). JSON: "strength", only when not 1.
  double strength = 1;
};

/// An expression tag "(name, intensity, seconds)" at its place in the speech; the animation ramps
/// to it. See docs/algorithms.md#expression-transitions.
struct ExpressionEvent {
  std::string name;   // from configs/viseme/expressions.json
  int intensity = 0;  // 0..63 as in the tag; 0 resets
  double start = 0;   // when the ramp starts
  double ramp = 0;    // seconds to reach `intensity`; it then holds until the next tag of that name
};

struct Word {
  std::string text;
  double start = 0, end = 0;
};

struct Utterance {
  std::string text;     // the input text (tags included)
  double duration = 0;  // seconds; equals the audio length when there is audio
  VisemeSet set = VisemeSet::kOculus;
  std::vector<Phone> phones;
  std::vector<Syllable> syllables;  // Chinese syllables only
  std::vector<VisemeEvent> visemes;
  std::vector<ExpressionEvent> expressions;
  std::vector<Word> words;
  std::vector<int16_t> pcm;  // mono PCM16 when synthesized, else empty
  int sample_rate = 0;       // of `pcm`; 0 without audio
};

/// The JSON of `facecast visemes`: {text, duration, set, phones, syllables, visemes, expressions,
/// words} (+ sample_rate when there is audio; PCM is never put in JSON). Times rounded to 0.1 ms.
nlohmann::json to_json(const Utterance& u);
/// The inverse of to_json (PCM excepted); throws Error naming the missing or wrong field.
Utterance utterance_from_json(const nlohmann::json& j);

}  // namespace facecast::viseme
