#pragma once
// Text (with expression tags) -> Utterance. A pure function of (text, options) apart from the
// shared, read-only tables it loads once (configs/viseme/ and the Chinese lexicon cache).
//
// Thread safety: analyze() may run concurrently for different utterances. espeak-ng is NOT
// thread-safe; every espeak-ng call in Facecast goes through one process-wide mutex in
// viseme/src/espeak.cpp (phonemization and synthesis alike), so English text and Timing::kTts
// serialize there while everything else runs in parallel.
#include <string_view>

#include "facecast/viseme/options.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

/// Steps: tags and pauses -> language runs -> Chinese: numbers normalized, max-probability word
/// segmentation over rime's pinyin_simp, tones from Unihan, syllables split into
/// initial/medial/nucleus/coda; English: espeak-ng phonemes -> timing (duration model or espeak-ng
/// synthesis, which also fills `pcm`) -> visemes in one set, expressions at their tag positions.
/// Throws Error for malformed tags or unknown expression names (with the character offset).
Utterance analyze(std::string_view text, const Options& options = {});

}  // namespace facecast::viseme
