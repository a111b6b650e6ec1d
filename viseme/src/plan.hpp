#pragma once
// The text front-end's output: what will be said, in order, before any timing.
//   items:  units (a Chinese syllable or an English word), pauses and expression tags, in order
//   units:  each with its phones, their viseme maps and duration-model seconds
//   words:  Chinese segmentation words and English words, as ranges of units
#include <string>
#include <string_view>
#include <vector>

#include "facecast/viseme/options.hpp"
#include "tables.hpp"

namespace facecast::viseme::detail {

enum class Lang { kZh, kEn };

struct PlanPhone {
  std::string name;
  double seconds = 0;  // duration-model length at Options::rate
  PhoneMap map;
};

struct PlanUnit {
  Lang lang = Lang::kZh;
  std::string text;                        // zh: the character; en: the word as written
  std::string pinyin;                      // zh: numbered pinyin, lexical tones (the JSON's)
  std::string spoken;                      // zh: the pinyin espeak-ng speaks (tone sandhi);
                                           // en: the lexicon's phones as espeak-ng phoneme input
                                           // ("[[...]]"), empty when espeak-ng reads the word
  std::size_t src_begin = 0, src_end = 0;  // characters of the input text it came from
  std::size_t word = 0;                    // index into Plan::words
  std::vector<PlanPhone> phones;
  double seconds() const;
};

struct PlanWord {
  std::string text;
  std::size_t first = 0, last = 0;  // units [first, last)
};

struct PlanItem {
  enum class Kind { kUnit, kPause, kTag };
  Kind kind = Kind::kUnit;
  std::size_t unit = 0;  // kUnit
  double pause = 0;      // kPause, seconds
  std::string name;      // kTag
  int intensity = 0;
  double ramp = 0;
};

struct Plan {
  std::vector<PlanUnit> units;
  std::vector<PlanWord> words;
  std::vector<PlanItem> items;
  bool has_zh = false;
};

/// Text with tags -> plan (tags, pauses, language runs, Chinese reading, English phonemes,
/// duration-model seconds). Throws Error for tag errors.
Plan make_plan(std::string_view text, const Options& options);

// The duration model: see docs/algorithms.md#duration-model.

/// English phones of a word (espeak-ng's), mapped through phones_espeak_en.json, with
/// duration-model seconds (stress lengthens vowels). Phones missing from the table are dropped.
/// The table's context rules (learned on espeak-ng's letter-to-sound readings) apply when
/// `context_rules`; a word read from the lexicon goes without them.
std::vector<PlanPhone> english_phones(const std::vector<std::string>& espeak_phones,
                                      const Options& options, bool context_rules = true);

/// Chinese phones of a numbered pinyin syllable with duration-model seconds for a syllable of
/// `syllable_seconds`.
std::vector<PlanPhone> chinese_phones(const std::string& pinyin, double syllable_seconds);

/// The duration-model length of a Chinese syllable (neutral tone and phrase-final factors).
double chinese_syllable_seconds(const std::string& pinyin, bool phrase_final, const Options& o);

}  // namespace facecast::viseme::detail
