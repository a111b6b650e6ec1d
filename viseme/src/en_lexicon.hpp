#pragma once
// The English lexicon: pocketsphinx-en-us's CMU dictionary (cmudict-en-us.dict, CMUdict 0.7-era
// ARPAbet without stress marks, variants written "word(2)"), the file the HMM aligner also reads.
// It is loaded once, on first use, into a compact sorted table; a missing or unreadable file gives
// an empty lexicon, and espeak-ng's letter-to-sound rules read every word. A word is spoken with
// the dictionary's phones turned into espeak-ng's, carrying espeak-ng's stress: see
// docs/algorithms.md#english-reading.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/viseme/options.hpp"

namespace facecast::viseme::detail {

class EnglishLexicon {
 public:
  /// Bounds on what is read: larger files are refused; longer entries are skipped.
  static constexpr std::uintmax_t kMaxFileBytes = 32u << 20;
  static constexpr std::size_t kMaxWordBytes = 64, kMaxPhones = 32, kMaxEntries = 1u << 20;

  /// The process-wide lexicon from default_path(): loaded on first use (thread-safe), empty when
  /// the file is missing or cannot be read.
  static const EnglishLexicon& get();
  /// $FACECAST_EN_LEXICON, or pocketsphinx-en-us's install path.
  static std::filesystem::path default_path();
  /// Reads a dictionary of cmudict-en-us.dict's form ("word(2) P H O N E S", one a line). Lines
  /// whose word or phone count is over the bounds, or with a phone that
  /// configs/viseme/phones_espeak_cmu.json cannot speak, are skipped. Throws Error when the file
  /// cannot be read or is over kMaxFileBytes.
  static EnglishLexicon load(const std::filesystem::path& path);

  /// The CMU phones (upper case, no stress) of each pronunciation of `word` (ASCII, any case), in
  /// the dictionary's order; empty when the word is not listed.
  std::vector<std::vector<std::string>> pronunciations(std::string_view word) const;
  bool contains(std::string_view word) const;
  std::size_t size() const { return entries_.size(); }  // pronunciations
  std::size_t memory_bytes() const;

 private:
  struct Entry {
    std::uint32_t word = 0, phones = 0;  // offsets into words_ and phones_
    std::uint8_t word_size = 0, phone_count = 0;
  };
  std::string_view word_of(const Entry& e) const { return {words_.data() + e.word, e.word_size}; }
  std::pair<const Entry*, const Entry*> find(std::string_view word) const;

  std::string words_;                   // the words, back to back
  std::string phones_;                  // one byte per phone: an index into inventory_
  std::vector<Entry> entries_;          // by word; a word's pronunciations in file order
  std::vector<std::string> inventory_;  // the CMU phones
};

/// Whether the options read English words with the lexicon: `english_lexicon` and an American
/// English voice (its name starts with "en-us"; the CMU dictionary is American English).
bool english_lexicon_applies(const Options& options);

/// The espeak-ng phones of `word` from the lexicon, stress marks (' ,) prefixed to vowels as
/// espeak::phonemize gives them, or nullopt when the lexicon lacks the word or espeak-ng's own
/// reading `espeak_phones` has no primary stress (a function word, which espeak-ng reduces in
/// context). Of several pronunciations, the one closest to espeak-ng's reading; each vowel takes
/// the stress of the vowel of espeak-ng's reading it aligns with.
std::optional<std::vector<std::string>> lexicon_phones(
    const EnglishLexicon& lexicon, std::string_view word,
    const std::vector<std::string>& espeak_phones);

/// espeak-ng's phoneme input for `phones`: "[[p|h|'oU|n]]" ('|' keeps phones that would read as one
/// apart: a|I is not aI).
std::string espeak_phoneme_input(const std::vector<std::string>& phones);

}  // namespace facecast::viseme::detail
