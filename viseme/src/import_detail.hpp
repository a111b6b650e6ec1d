#pragma once
// What the timestamp importers share: timed labels read from a file, the small readers of their
// fields, and the two ways a list of labels becomes an Utterance (phones, or another engine's
// visemes). One importer per format family:
//   import_phones.cpp      generic JSON phone lists, Montreal Forced Aligner (TextGrid or JSON)
//   import_visemes.cpp     Azure viseme events, Amazon Polly speech marks, Rhubarb Lip Sync
//   import_elevenlabs.cpp  ElevenLabs character alignment
// See docs/algorithms.md#timestamp-import.
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/viseme/import.hpp"
#include "tables.hpp"

namespace facecast::viseme::detail {

/// A timed label from a file (seconds), and where it came from (for error messages).
struct Label {
  std::string text;
  double start = 0, end = 0;
  std::string where;
};

/// Parses JSON; errors name `source` and the byte.
nlohmann::json parse_json(std::string_view content, const std::string& source);
/// The finite number `key` of the object `j`; errors name `where` and the key.
double number(const nlohmann::json& j, const char* key, const std::string& where);
/// The string `key` of `j` (an integer is taken as its digits, e.g. Azure's VisemeId).
std::string string_field(const nlohmann::json& j, const char* key, const std::string& where);
/// Throws naming `l.where` unless 0 <= start <= end (finite).
void check_span(const Label& l);
/// The non-blank lines of text or NDJSON with their 1-based numbers.
std::vector<std::pair<std::size_t, std::string>> lines_of(std::string_view content);
/// Whether the content starts with '{' or '[' (after spaces and a UTF-8 byte order mark).
bool starts_json(std::string_view content);
std::string lower(std::string s);

/// Sorts point events (start only) and ends each at the next one's start; the last gets 0.1 s.
void close_spans(std::vector<Label>& cues);

/// Timed phones (and words) in `set` (kAuto: the first set that knows every phone) -> Utterance.
/// Silence labels ("", sil, sp, spn, <eps>, ...) are pauses.
Utterance from_phones(std::vector<Label> phones, std::vector<Label> words, PhoneSet set,
                      const Options& options);
/// Another engine's viseme labels through its table of configs/viseme/visemes_external.json.
Utterance from_visemes(const std::vector<Label>& cues, const PhoneTable& table, const char* engine,
                       const Options& options);

Utterance import_json(std::string_view content, const Options& o, PhoneSet set,
                      const std::string& src);
Utterance import_mfa(std::string_view content, const Options& o, PhoneSet set,
                     const std::string& src);
Utterance import_azure(std::string_view content, const Options& o, const std::string& src);
Utterance import_polly(std::string_view content, const Options& o, const std::string& src);
Utterance import_rhubarb(std::string_view content, const Options& o, const std::string& src);
Utterance import_elevenlabs(std::string_view content, const Options& o, const std::string& src);

}  // namespace facecast::viseme::detail
