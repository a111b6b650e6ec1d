#pragma once
// UTF-8 helpers shared by the text front-end and the lexicon.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::viseme::detail {

/// Decodes the code point at text[pos] and advances pos; returns U+FFFD and advances one byte on
/// invalid input when `strict` is false, throws Error("invalid UTF-8 at byte N") when true.
char32_t next_code_point(std::string_view text, std::size_t& pos, bool strict = true);

void append_utf8(std::string& out, char32_t cp);
std::string to_utf8(char32_t cp);
std::u32string to_u32(std::string_view text);
std::string to_utf8(std::u32string_view text);

/// CJK unified ideographs (basic, extension A, compatibility).
inline bool is_han(char32_t c) {
  return (c >= 0x4E00 && c <= 0x9FFF) || (c >= 0x3400 && c <= 0x4DBF) ||
         (c >= 0xF900 && c <= 0xFAFF) || (c >= 0x20000 && c <= 0x2FA1F);
}
inline bool is_ascii_alpha(char32_t c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}
inline bool is_ascii_digit(char32_t c) {
  return c >= '0' && c <= '9';
}
/// Full-width ASCII forms (U+FF01..U+FF5E) and the ideographic space to ASCII; others unchanged.
inline char32_t fold_width(char32_t c) {
  if (c >= 0xFF01 && c <= 0xFF5E) return c - 0xFF01 + 0x21;
  if (c == 0x3000) return ' ';
  return c;
}
inline bool is_space(char32_t c) {
  return c == ' ' || c == '\t' || c == '\r' || c == 0x3000 || c == 0xA0;
}

}  // namespace facecast::viseme::detail
