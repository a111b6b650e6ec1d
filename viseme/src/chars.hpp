#pragma once
// Character classes of the text front-end and the lexicon, on code points (decoding and encoding
// UTF-8: facecast/core/utf8.hpp).
#include "facecast/core/utf8.hpp"

namespace facecast::viseme::detail {

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
