// facecast_viseme_lexgen OUT: compiles rime's pinyin_simp.dict.yaml and Unihan_Readings from their
// Debian install paths into the Chinese lexicon cache the viseme library loads (run at build time).
#include <chrono>
#include <iostream>

#include "facecast/core/error.hpp"
#include "lexicon.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: facecast_viseme_lexgen OUT\n";
    return 2;
  }
  using Clock = std::chrono::steady_clock;
  namespace d = facecast::viseme::detail;
  try {
    const auto t0 = Clock::now();
    const d::Lexicon lex = d::Lexicon::compile(d::Lexicon::default_sources());
    lex.save(argv[1]);
    const auto t1 = Clock::now();
    (void)d::Lexicon::load(argv[1]);
    const auto t2 = Clock::now();
    std::cerr << "lexicon: " << lex.word_count() << " words, " << lex.char_count()
              << " characters; compiled in "
              << std::chrono::duration<double, std::milli>(t1 - t0).count() << " ms, loads in "
              << std::chrono::duration<double, std::milli>(t2 - t1).count() << " ms\n";
  } catch (const facecast::Error& e) {
    std::cerr << "facecast_viseme_lexgen: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
