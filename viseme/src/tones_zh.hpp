#pragma once
// Chinese tones in word context: word readings and neutral-tone rules (lexical tones, what the
// JSON shows) and tone sandhi (what espeak-ng speaks). See docs/algorithms.md#chinese-tones.
#include <string>
#include <vector>

namespace facecast::viseme::detail {

/// One Han character of a run with its reading and segmentation word.
struct ZhSyllable {
  char32_t c = 0;
  std::string pinyin;    // numbered, lexical tone; "" when nobody knows how to read it
  std::size_t word = 0;  // index of its segmentation word in the run (non-decreasing)
};

/// Lexical tones from word context (configs/viseme/tones_zh.json): words of the table found in the
/// segmentation (alone, inside a word or as whole consecutive words) take the table's tones where
/// the toneless reading agrees; other syllables keep a full tone unless they are particles or 子;
/// AA of a reduplicating character reads the second A neutral, A一A reads 一 neutral.
void word_tones(std::vector<ZhSyllable>& run);

/// The tones spoken, syllable by syllable (lexical pinyin with the tone digit changed):
/// 一 (yi1) -> yi2 before tone 4 or the neutral tone, yi4 before tones 1-3, unchanged when it ends
/// its word or touches a digit or 第; 不 (bu4) -> bu2 before tone 4; a run of third tones inside a
/// prosodic word (segmentation words, one-syllable words joined to a neighbour up to three
/// syllables) -> second tones but the last, except 1+2 (小|老虎: 3 2 3).
std::vector<std::string> spoken_tones(const std::vector<ZhSyllable>& run);

}  // namespace facecast::viseme::detail
