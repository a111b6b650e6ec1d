#include <catch2/catch.hpp>
#include <string>

#include "facecast/core/error.hpp"
#include "facecast/core/json_limits.hpp"

using Catch::Matchers::Contains;

TEST_CASE("JSON depth is counted on the raw bytes, strings skipped", "[json_limits]") {
  CHECK(facecast::json_depth("1", 10) == 0);
  CHECK(facecast::json_depth(R"({"a": [1, {"b": []}]})", 10) == 4);
  // Brackets inside strings (escaped quotes included) do not count.
  CHECK(facecast::json_depth(R"({"a": "[[[{{{\"[[["})", 10) == 1);
  // Unbalanced closers do not go below zero.
  CHECK(facecast::json_depth("]]]][[", 10) == 2);
}

TEST_CASE("deep JSON is refused with its offset before a parser sees it", "[json_limits]") {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  CHECK_NOTHROW(facecast::check_json_depth("[[[]]]", 3, "x.gltf"));
  try {
    facecast::check_json_depth(deep, 64, "upload.glb");
    FAIL("no error");
  } catch (const facecast::Error& e) {
    CHECK(e.code() == facecast::ErrorCode::kLimit);
    CHECK_THAT(e.what(), Contains("upload.glb: JSON nests deeper than 64 levels at byte 64"));
  }
  // The scan stops at the first level too deep: its cost does not depend on what follows.
  std::size_t at = 0;
  CHECK(facecast::json_depth(deep, 64, &at) == 65);
  CHECK(at == 64);
}
