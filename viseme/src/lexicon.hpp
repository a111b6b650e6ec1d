#pragma once
// The Chinese lexicon: rime's pinyin_simp.dict.yaml (words, toneless pinyin, frequencies) and
// Unihan_Readings (per-character readings with tones), compiled into one compact text cache.
// See docs/algorithms.md#chinese-reading.
//
// The cache is generated at BUILD time by facecast_viseme_lexgen (viseme/tools/) into the build
// folder, and found at run time through $FACECAST_ZH_LEXICON or the path compiled in. If it is
// missing or was made from different source files (sizes differ), Lexicon::get() compiles it from
// the Debian install paths in memory instead (about 1 s) — nothing is downloaded.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace facecast::viseme::detail {

struct StringHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view s) const noexcept {
    return std::hash<std::string_view>{}(s);
  }
};

/// The text of `path`, decompressed when its name ends in .bz2 (Unihan_Readings.txt.bz2).
std::string read_maybe_bz2(const std::filesystem::path& path);

class Lexicon {
 public:
  struct Sources {
    std::filesystem::path rime_dict;        // pinyin_simp.dict.yaml
    std::filesystem::path unihan_readings;  // Unihan_Readings.txt or .txt.bz2
  };
  /// A word of the segmentation: [begin, end) in the run, one toneless syllable per character.
  struct Segment {
    std::size_t begin = 0, end = 0;
    std::vector<std::string> toneless;
  };

  /// The process-wide lexicon (cache or sources, loaded once, thread-safe).
  static const Lexicon& get();
  /// The Debian install paths (overridable with $FACECAST_RIME_DICT / $FACECAST_UNIHAN_READINGS).
  static Sources default_sources();
  /// The compiled-in cache path (overridable with $FACECAST_ZH_LEXICON).
  static std::filesystem::path default_cache();

  static Lexicon compile(const Sources& sources);
  /// Throws Error when the file is not a lexicon cache.
  static Lexicon load(const std::filesystem::path& cache);
  void save(const std::filesystem::path& cache) const;
  /// True when the cache was compiled from files of the sizes `sources` have now.
  bool matches(const Sources& sources) const;

  /// Maximum-probability segmentation of a run of Han characters (unknown characters are
  /// one-character words with their most common reading, or an empty reading if Unihan has none).
  std::vector<Segment> segment(std::u32string_view run) const;

  /// The numbered reading of `c` whose toneless form is `toneless`, most frequent first (Unihan
  /// kHanyuPinlu, then kMandarin, kTGHZ2013, kXHC1983, kHanyuPinyin). The neutral tone is skipped
  /// unless `allow_neutral` or nothing else matches; "<toneless>5" when no reading matches.
  std::string tone(char32_t c, std::string_view toneless, bool allow_neutral) const;
  /// Numbered readings of `c` in preference order (empty if unknown).
  const std::vector<std::string>& readings(char32_t c) const;
  /// True when rime or Unihan knows `toneless` as a reading of `c`.
  bool has_reading(char32_t c, std::string_view toneless) const;

  std::size_t word_count() const { return words_.size(); }
  std::size_t char_count() const { return readings_.size(); }

 private:
  struct Entry {
    float cost = 0;               // -log P(word)
    std::vector<std::string> py;  // toneless, one per character
  };
  std::unordered_map<std::string, Entry, StringHash, std::equal_to<>> words_;
  std::unordered_map<char32_t, std::vector<std::string>> readings_;
  float unknown_cost_ = 20;
  std::size_t max_len_ = 1;
  std::uintmax_t rime_size_ = 0, unihan_size_ = 0;
};

}  // namespace facecast::viseme::detail
