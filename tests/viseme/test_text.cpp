// Expression tags and pauses in text.
#include <catch2/catch.hpp>

#include "facecast/core/error.hpp"
#include "facecast/viseme/text.hpp"

using namespace facecast::viseme;
using Kind = TextPiece::Kind;

namespace {

std::string error_of(const char* text) {
  try {
    parse_text(text);
  } catch (const facecast::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("expression tags are parsed with ASCII or full-width punctuation", "[viseme][text]") {
  const auto p = parse_text("(joy, 40, 0.5)你好（surprise，63，0.3）Wow");
  REQUIRE(p.size() == 4);
  CHECK(p[0].kind == Kind::kTag);
  CHECK(p[0].name == "joy");
  CHECK(p[0].intensity == 40);
  CHECK(p[0].ramp == Approx(0.5));
  CHECK(p[0].offset == 0);
  CHECK(p[1].kind == Kind::kText);
  CHECK(p[1].text == "你好");
  CHECK(p[1].offset == 14);
  CHECK(p[2].kind == Kind::kTag);
  CHECK(p[2].name == "surprise");
  CHECK(p[2].intensity == 63);
  CHECK(p[2].offset == 16);
  CHECK(p[3].text == "Wow");
  CHECK(parse_text("(Anger,0,1)")[0].name == "anger");  // names are case-insensitive; 0 resets
}

TEST_CASE("tag errors give the character offset and the reason", "[viseme][text]") {
  CHECK_THAT(error_of("你好(happy, 40, 0.5)"),
             Catch::Contains("character 3") && Catch::Contains("unknown expression 'happy'"));
  CHECK_THAT(error_of("(joy, 80, 0.5)"),
             Catch::Contains("character 6") && Catch::Contains("intensity 80 is outside 0..63"));
  CHECK_THAT(error_of("(joy, 4.5, 1)"),
             Catch::Contains("character 6") && Catch::Contains("integer"));
  CHECK_THAT(error_of("(joy, 40)"),
             Catch::Contains("character 8") && Catch::Contains("expected ','"));
  CHECK_THAT(error_of("(joy, 40, -1)"),
             Catch::Contains("character 10") && Catch::Contains("negative"));
  CHECK_THAT(error_of("(joy, 40, 0.5 hello"), Catch::Contains("expected ')'"));
  CHECK_THAT(error_of("(joy 40 0.5)"), Catch::Contains("character 5"));
  CHECK_THAT(error_of("ok\xff"), Catch::Contains("invalid UTF-8"));
}

TEST_CASE("ordinary parentheses are text, not tags", "[viseme][text]") {
  const auto p = parse_text("(see below) and (yes, really)");
  for (const auto& piece : p) CHECK(piece.kind != Kind::kTag);
}

TEST_CASE("punctuation gives configured pauses, but not inside numbers and abbreviations",
          "[viseme][text]") {
  const auto p = parse_text("你好，世界。Dr. Smith paid 3.5 dollars, at 10:30!?");
  std::vector<double> pauses;
  for (const auto& piece : p)
    if (piece.kind == Kind::kPause) pauses.push_back(piece.pause);
  REQUIRE(pauses.size() == 4);
  CHECK(pauses[0] == Approx(0.25));  // ，
  CHECK(pauses[1] == Approx(0.45));  // 。
  CHECK(pauses[2] == Approx(0.2));   // ,
  CHECK(pauses[3] == Approx(0.4));   // "!?" counts once, the longer
  CHECK(p[4].text == "Dr. Smith paid 3.5 dollars");
}
