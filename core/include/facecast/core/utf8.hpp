#pragma once
// UTF-8: decoding and encoding code points, validity, lengths. Names read from files (OBJ groups
// and materials, file stems, glTF strings) must be valid UTF-8 before they reach JSON, GLB or the
// protocol; the text front-end walks its input by code point.
#include <cstddef>
#include <string>
#include <string_view>

namespace facecast {

/// Decodes the code point at text[pos] and advances pos. Invalid input (a stray or missing
/// continuation byte, an overlong form, a surrogate, past U+10FFFF): when `strict`, throws
/// Error("invalid UTF-8 at byte N"); otherwise returns U+FFFD and advances one byte.
char32_t next_code_point(std::string_view text, std::size_t& pos, bool strict = true);

/// True when `text` is well-formed UTF-8.
bool is_valid_utf8(std::string_view text) noexcept;

/// A byte that continues a multi-byte sequence (10xxxxxx).
constexpr bool is_utf8_continuation(char c) noexcept {
  return (static_cast<unsigned char>(c) & 0xC0) == 0x80;
}
/// Code points in valid UTF-8 (the bytes that start one).
std::size_t utf8_length(std::string_view text) noexcept;

void append_utf8(std::string& out, char32_t cp);
std::string to_utf8(char32_t cp);
std::string to_utf8(std::u32string_view text);
/// Throws Error on invalid UTF-8 (next_code_point, strict).
std::u32string to_u32(std::string_view text);

}  // namespace facecast
