#pragma once
// Mandarin syllables: numbered pinyin split into initial, medial, nucleus, coda and mapped to
// visemes (tables in configs/viseme/pinyin.json), and text -> pinyin with word context.
// See docs/algorithms.md#viseme-sets and #chinese-reading.
#include <string>
#include <string_view>
#include <vector>

#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

struct PinyinParts {
  std::string initial;  // "" | b p m f d t n l g k h j q x zh ch sh r z c s y w
  std::string medial;   // "" | i u v
  std::string nucleus;  // "" | a ai ao o ou e ei er i -i u v
  std::string coda;     // "" | -n -ng
  int tone = 5;         // 1..5
  /// The non-empty parts in order: the syllable's phones.
  std::vector<std::string> phones() const;
};

/// "zhuang1" -> {zh, u, a, -ng, 1}. Accepts v, u: or ü for u-umlaut and a missing tone (= 5).
/// Throws Error naming the syllable when it is not Mandarin pinyin.
PinyinParts split_pinyin(std::string_view syllable);

/// True if `syllable` is a numbered pinyin syllable split_pinyin accepts.
bool is_pinyin(std::string_view syllable);

/// The syllable's viseme sequence, consecutive repeats merged: zhuang1 -> zhchsh uv a ng (zh15),
/// CH U aa kk (oculus).
std::vector<std::string> syllable_visemes(const PinyinParts& parts, VisemeSet set);

/// "hǎo" / "lüè" (tone marks) -> "hao3" / "lve4"; numbered input is returned normalized.
std::string numbered_pinyin(std::string_view marked);

/// Chinese text (numbers normalized, other scripts skipped) -> numbered pinyin per Han character,
/// read in word context: max-probability segmentation over rime's pinyin_simp, tones from Unihan.
/// See docs/algorithms.md#chinese-reading.
std::vector<std::string> to_pinyin(std::string_view text);

}  // namespace facecast::viseme
