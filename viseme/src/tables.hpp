#pragma once
// Every data table of the viseme engine, read once from configs/viseme/ (thread-safe lazy load).
#include <array>
#include <string>
#include <unordered_map>
#include <vector>

#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme::detail {

/// A phone's visemes: one or more Oculus visemes and zh15 classes (possibly none), and for English
/// espeak-ng phones the duration class.
struct PhoneMap {
  std::vector<std::string> oculus;
  std::vector<std::string> zh15;
  std::string duration_class;
  /// The visemes in `set` (MPEG-4 renamed from Oculus).
  std::vector<std::string> in(VisemeSet set) const;
};
using PhoneTable = std::unordered_map<std::string, PhoneMap>;

/// A context rule of phones_espeak_en.json: the phone `phone` with the given stress ('1' primary,
/// '2' secondary, '0' none, 0 any), after one of `prev` and before one of `next` (empty: any;
/// "#" the word's edge), takes the visemes of `as` (its duration class stays).
struct EnContextRule {
  std::string phone;
  char stress = 0;
  std::vector<std::string> prev, next;
  PhoneMap as;
};

struct PolyphoneRule {
  std::string reading;  // toneless, or numbered (that tone)
  std::u32string prev, next;
  bool prev_repeated = false;
  bool at_end = false;
  bool in_words = false;  // also inside longer words (a numbered reading: the tone only)
};

struct NumbersZh {
  std::array<std::string, 10> digits;
  std::string point, percent_prefix, negative, range, fraction, hour, minute, second, half, year,
      month, day;
  bool liang_before_bai = true;
  std::size_t digit_string_min_length = 10;
  std::vector<std::pair<std::string, std::string>> currency_prefix;  // longest symbol first
  std::vector<std::string> measure_words;
};

struct Tables {
  std::vector<std::string> expressions;
  std::unordered_map<std::string, double> pauses;  // UTF-8 mark -> seconds
  double newline_pause = 0.4;
  std::vector<std::string> abbreviations;

  std::vector<std::string> zh15_names, oculus_names;
  std::unordered_map<std::string, std::string> mpeg4_from_oculus;

  // pinyin.json
  std::vector<std::string> initials;
  std::unordered_map<std::string, std::array<std::string, 3>> finals;  // medial, nucleus, coda
  std::vector<std::string> syllabic_initials;
  PhoneTable pinyin_units;
  PhoneMap y_rounded;
  std::vector<std::string> apical_after;
  std::unordered_map<std::string, double> initial_weight, medial_weight, nucleus_weight;
  double nucleus_default_weight = 1.2, coda_weight = 0.7;

  PhoneTable espeak_en, arpabet, ipa, azure, polly, rhubarb;
  std::vector<EnContextRule> espeak_en_context;  // first match wins
  double en_reference_rate = 4.5, en_stress_factor = 1.2;
  std::unordered_map<std::string, double> en_class_seconds;

  // phones_espeak_cmu.json: espeak-ng phone -> the CMU phones it stands for ("phones"); CMU phones
  // (one, or a pair joined by a space: "AA R") -> the espeak-ng phone that speaks them
  // ("from_cmu"), and for unstressed vowels ("from_cmu_unstressed").
  std::unordered_map<std::string, std::vector<std::string>> espeak_cmu;
  std::unordered_map<std::string, std::string> cmu_espeak, cmu_espeak_unstressed;

  NumbersZh numbers;
  std::unordered_map<char32_t, std::vector<PolyphoneRule>> polyphones;
};

const Tables& tables();

/// The pause viseme of a set: "sil" or "none".
std::string silence_viseme(VisemeSet set);

}  // namespace facecast::viseme::detail
