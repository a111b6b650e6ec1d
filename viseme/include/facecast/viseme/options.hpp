#pragma once
// Options of the viseme engine. Defaults here mirror configs/viseme/options.json (a test checks
// that they agree); load_options() reads that file, which is what the CLI starts from.
#include <optional>
#include <string>

#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

/// Which language runs the text holds: split automatically (Han script -> Chinese, Latin ->
/// English, digits follow their neighbours), or force every run to one language.
enum class LangMode { kAuto, kZh, kEn };

/// Where times come from: the duration model (no audio, deterministic, fast) or espeak-ng synthesis
/// (audio + phoneme events; English through `en_voice`, Chinese as numbered pinyin through
/// `zh_voice`).
enum class Timing { kModel, kTts };

/// Mixed Chinese/English text in ONE viseme set: every phone is mapped straight into the chosen set
/// through the config tables, so a mixed utterance never mixes vocabularies (see
/// docs/algorithms.md#viseme-sets):
///  - zh15: Chinese syllables phone by phone through the "units" table of
///    configs/viseme/pinyin.json; English espeak-ng phones through the "zh15" column of
///    configs/viseme/phones_espeak_en.json (p b m -> bpm, s z -> zcs, aI -> a i, ...).
///  - oculus / mpeg4: English phones through the "oculus" column; Chinese initials, medials,
///    nuclei and codas through the "units" table (zh ch sh -> CH, -ng -> kk ...); MPEG-4 names are
///    the Oculus visemes renamed (configs/viseme/viseme_sets.json).
/// `set` unset ("auto") means: zh15 when the utterance has any Chinese, oculus otherwise.
struct Options {
  LangMode lang = LangMode::kAuto;
  std::optional<VisemeSet> set;  // nullopt = auto
  Timing timing = Timing::kModel;
  // rate, phrase_final_lengthening, neutral_tone_factor: docs/algorithms.md#duration-model.
  double rate = 4.5;  // speech rate of the duration model, syllables per second
  std::string en_voice = "en-us";
  // English words the CMU dictionary lists are spoken with its phones (with an American en_voice);
  // others by espeak-ng's letter-to-sound rules: docs/algorithms.md#english-reading.
  bool english_lexicon = true;
  std::string zh_voice = "cmn-latn-pinyin";
  int espeak_speed = 175;                 // espeak-ng words per minute for Timing::kTts
  double phrase_final_lengthening = 1.3;  // last syllable before a pause, duration model
  double neutral_tone_factor = 0.7;       // neutral-tone syllables, duration model
};

/// Options from configs/viseme/options.json; throws Error naming the file and field when invalid.
Options load_options();

LangMode parse_lang_mode(std::string_view name);  // auto | zh | en
Timing parse_timing(std::string_view name);       // model | tts
/// "auto" gives nullopt.
std::optional<VisemeSet> parse_set_option(std::string_view name);

}  // namespace facecast::viseme
