// ConfigReader: defaults kept, types checked, errors name the file and the key path.
#include <catch2/catch.hpp>
#include <functional>

#include "facecast/core/config_reader.hpp"

using facecast::ConfigReader;
using facecast::Error;
using nlohmann::json;

namespace {

enum class Mode { kAuto, kOff };

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("ConfigReader reads present keys and keeps defaults for missing ones", "[core]") {
  ConfigReader c(
      json::parse(
          R"({"n": 3, "x": 2, "s": "a", "v": [1, 2.5], "_note": "comment", "description": "also a comment",
                                 "sec": {"b": true}, "mode": "off"})"),
      "f.json");
  int n = 0, missing = 7;
  double x = 0;
  std::string s;
  std::vector<double> v;
  bool b = false;
  Mode mode = Mode::kAuto;
  c.read("n", n).read("x", x).read("s", s).read("v", v).read("missing", missing);
  c.read_choice("mode", mode, {{"auto", Mode::kAuto}, {"off", Mode::kOff}});
  c.section("sec").read("b", b);
  CHECK_NOTHROW(c.reject_unknown());
  CHECK(n == 3);
  CHECK(x == 2.0);
  CHECK(s == "a");
  CHECK(v == std::vector<double>{1, 2.5});
  CHECK(missing == 7);
  CHECK(b);
  CHECK(mode == Mode::kOff);
}

TEST_CASE("ConfigReader errors name the file and the key path", "[core]") {
  const auto reader = [](const char* text) { return ConfigReader(json::parse(text), "f.json"); };
  int n = 0;
  CHECK(message_of([&] { reader(R"({"n": "x"})").read("n", n); }) ==
        "f.json: n: expected an integer");
  CHECK(message_of([&] { reader(R"({"n": 1.5})").read("n", n); }) ==
        "f.json: n: expected a whole number in -2147483648..2147483647");
  unsigned u = 0;
  CHECK_THAT(message_of([&] { reader(R"({"u": -1})").read("u", u); }),
             Catch::StartsWith("f.json: u: expected a whole number in 0.."));
  CHECK(message_of([&] { reader(R"({})").require("n", n); }) == "f.json: n: missing");
  CHECK(message_of([&] {
          auto c = reader(R"({"a": {"b": {"c": 1}}})");
          c.section("a").section("b").reject_unknown();
          c.reject_unknown();
        }) == "f.json: unknown key 'a.b.c'");
  CHECK(message_of([&] { reader(R"({"typo": 1})").reject_unknown(); }) ==
        "f.json: unknown key 'typo'");
  std::array<float, 3> rgb{};
  CHECK(message_of([&] { reader(R"({"rgb": [1, 2]})").read("rgb", rgb); }) ==
        "f.json: rgb: expected an array of 3");
  std::vector<int> list;
  CHECK(message_of([&] { reader(R"({"l": [1, "x"]})").read("l", list); }) ==
        "f.json: l[1]: expected an integer");
  Mode mode = Mode::kAuto;
  CHECK(message_of([&] {
          reader(R"({"m": "on"})")
              .read_choice("m", mode, {{"auto", Mode::kAuto}, {"off", Mode::kOff}});
        }) == "f.json: m: 'on' is not one of auto, off");
  CHECK(message_of([&] { reader(R"({"s": 1})").section("s"); }) == "f.json: s: expected an object");
  CHECK(message_of([&] { ConfigReader(json::array(), "f.json"); }) ==
        "f.json: expected a JSON object");
  CHECK(message_of([&] { reader(R"({"s": {}})").section("s").fail("a and b disagree"); }) ==
        "f.json: s: a and b disagree");
}
