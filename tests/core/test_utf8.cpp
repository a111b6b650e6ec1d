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
