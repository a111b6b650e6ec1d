#include "facecast/core/utf8.hpp"

#include "facecast/core/error.hpp"

namespace facecast {
namespace {

// The code point at text[pos] and its length in bytes; length 0 when the bytes there are not
// well-formed UTF-8.
std::pair<char32_t, std::size_t> decode(std::string_view text, std::size_t pos) noexcept {
  const auto b0 = static_cast<unsigned char>(text[pos]);
  if (b0 < 0x80) return {b0, 1};
  std::size_t n = 0;
  char32_t cp = 0;
  if ((b0 & 0xE0) == 0xC0) {
    n = 1, cp = b0 & 0x1F;
  } else if ((b0 & 0xF0) == 0xE0) {
    n = 2, cp = b0 & 0x0F;
  } else if ((b0 & 0xF8) == 0xF0) {
    n = 3, cp = b0 & 0x07;
  } else {
    return {0, 0};
  }
  if (text.size() - pos <= n) return {0, 0};
  for (std::size_t i = 1; i <= n; ++i) {
    const char b = text[pos + i];
    if (!is_utf8_continuation(b)) return {0, 0};
    cp = (cp << 6) | (static_cast<unsigned char>(b) & 0x3F);
  }
  static constexpr char32_t kMin[] = {0, 0x80, 0x800, 0x10000};
  if (cp < kMin[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return {0, 0};
  return {cp, n + 1};
}

}  // namespace

char32_t next_code_point(std::string_view text, std::size_t& pos, bool strict) {
  const auto [cp, len] = decode(text, pos);
  if (len == 0) {
    if (strict) throw Error("invalid UTF-8 at byte " + std::to_string(pos));
    ++pos;
    return 0xFFFD;
  }
  pos += len;
  return cp;
}

bool is_valid_utf8(std::string_view text) noexcept {
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t len = decode(text, pos).second;
    if (len == 0) return false;
    pos += len;
  }
  return true;
}

std::size_t utf8_length(std::string_view text) noexcept {
  std::size_t n = 0;
  for (const char c : text) n += !is_utf8_continuation(c);
  return n;
}

void append_utf8(std::string& out, char32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

std::string to_utf8(char32_t cp) {
  std::string s;
  append_utf8(s, cp);
  return s;
}

std::string to_utf8(std::u32string_view text) {
  std::string out;
  out.reserve(text.size() * 3);
  for (const char32_t c : text) append_utf8(out, c);
  return out;
}

std::u32string to_u32(std::string_view text) {
  std::u32string out;
  out.reserve(text.size());
  for (std::size_t pos = 0; pos < text.size();) out += next_code_point(text, pos);
  return out;
}

}  // namespace facecast
