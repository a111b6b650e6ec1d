#include <catch2/catch.hpp>

#include "facecast/core/utf8.hpp"

TEST_CASE("is_valid_utf8 accepts UTF-8 and rejects malformed sequences", "[core]") {
  using facecast::is_valid_utf8;
  CHECK(is_valid_utf8(""));
  CHECK(is_valid_utf8("jawOpen"));
  CHECK(is_valid_utf8("嘴巴 \xF0\x9F\x98\x80"));   // CJK and an emoji
  CHECK_FALSE(is_valid_utf8("li\x90"));            // a lone continuation byte
  CHECK_FALSE(is_valid_utf8("\xE5\x98"));          // cut short
  CHECK_FALSE(is_valid_utf8("\xC0\xAF"));          // overlong '/'
  CHECK_FALSE(is_valid_utf8("\xED\xA0\x80"));      // a surrogate
  CHECK_FALSE(is_valid_utf8("\xF4\x90\x80\x80"));  // past U+10FFFF
  CHECK_FALSE(is_valid_utf8(std::string_view("\xFF", 1)));
}

TEST_CASE("code points decode, encode and count", "[core]") {
  using namespace facecast;
  const std::string text = "a你\xF0\x9F\x98\x80";
  CHECK(to_u32(text) == U"a你\U0001F600");
  CHECK(to_utf8(to_u32(text)) == text);
  CHECK(utf8_length(text) == 3);
  CHECK(utf8_length("a\x90") == 1);  // a stray continuation byte starts nothing
  std::size_t pos = 1;
  CHECK(next_code_point(text, pos) == U'你');
  CHECK(pos == 4);
  // Invalid bytes: an error naming the byte, or U+FFFD and one byte on.
  pos = 1;
  CHECK_THROWS_WITH(next_code_point("a\xE5\x98", pos), "invalid UTF-8 at byte 1");
  pos = 1;
  CHECK(next_code_point("a\xE5\x98", pos, false) == 0xFFFD);
  CHECK(pos == 2);
  CHECK(is_utf8_continuation('\x98'));
  CHECK_FALSE(is_utf8_continuation('a'));
}
