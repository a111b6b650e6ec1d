#pragma once
// Phoneme / viseme timestamps from TTS engines and aligners -> the same Utterance as analyze().
// See docs/algorithms.md#timestamp-import.
#include <string>
#include <string_view>

#include "facecast/viseme/options.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::viseme {

enum class TimestampFormat {
  kJson,     // [{phone, start, end}] or {"phones": [...], "words": [...]}, seconds
  kAzure,    // Azure viseme events: [{AudioOffset (100 ns ticks), VisemeId}] or JSON Lines
  kPolly,    // Amazon Polly speech marks, NDJSON: {time (ms), type: viseme|word|sentence, value}
  kMfa,      // Montreal Forced Aligner TextGrid (long or short) or JSON ({tiers: {words, phones}})
  kRhubarb,  // Rhubarb Lip Sync TSV ("0.00\tX") or JSON ({mouthCues: [{start, end, value}]})
  kElevenLabs,  // ElevenLabs character alignment ({characters, character_start_times_seconds, ...})
};

/// Phone sets for kJson / kMfa phones. kAuto picks, per file, the first set that knows every phone:
/// pinyin syllables, ARPAbet, espeak-ng, IPA.
enum class PhoneSet { kAuto, kPinyin, kArpabet, kIpa, kEspeak };

TimestampFormat parse_timestamp_format(
    std::string_view name);                       // json|azure|polly|mfa|rhubarb|elevenlabs
PhoneSet parse_phone_set(std::string_view name);  // auto|pinyin|arpabet|ipa|espeak

/// Guesses the format from the content (and the file name's extension when given): a TextGrid,
/// Rhubarb TSV or mouthCues, Polly NDJSON (a "type" field), Azure (VisemeId), ElevenLabs
/// (characters), MFA JSON (tiers), otherwise the generic JSON list. Throws Error naming `source`
/// when nothing fits.
TimestampFormat detect_timestamp_format(std::string_view content,
                                        std::string_view source = "<input>");

/// Parses `content` (the file's bytes) into timed phones/visemes/words in `options.set` (auto: zh15
/// for pinyin or Chinese text, oculus otherwise). ElevenLabs runs the text front-end on the
/// characters and places each syllable's / word's phones inside its characters' span. Errors name
/// `source`, the line or item, and for unknown phones the phone and its time.
Utterance import_timestamps(TimestampFormat format, std::string_view content,
                            const Options& options = {}, PhoneSet phones = PhoneSet::kAuto,
                            std::string_view source = "<input>");

}  // namespace facecast::viseme
