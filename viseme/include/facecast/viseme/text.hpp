#pragma once
// The tagged-text parser: expression tags "(name, intensity, seconds)" (ASCII or full-width
// parentheses and commas) and punctuation pauses, as character-offset items. What a tag does to
// the face: docs/algorithms.md#expression-transitions.
#include <string>
#include <string_view>
#include <vector>

namespace facecast::viseme {

struct TextPiece {
  enum class Kind { kText, kTag, kPause };
  Kind kind = Kind::kText;
  std::string text;        // kText: the run; kPause: the mark(s)
  std::size_t offset = 0;  // character (code point) offset in the input, 0-based
  std::size_t length = 0;  // characters
  // kTag
  std::string name;
  int intensity = 0;
  double ramp = 0;
  // kPause
  double pause = 0;  // seconds
};

/// Splits `text` into runs of text, expression tags and pauses. A "(" starts a tag when a known
/// expression name follows, or any name followed by a comma and a number; otherwise it is ordinary
/// punctuation. Errors: "character 12: expression tag: intensity 80 is outside 0..63" and the
/// like, for malformed tags, unknown names and invalid UTF-8.
std::vector<TextPiece> parse_text(std::string_view text);

}  // namespace facecast::viseme
