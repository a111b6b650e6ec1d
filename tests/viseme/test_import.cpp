// Timestamp importers, each on a fixture in its real format (tests/viseme/fixtures/).
#include <catch2/catch.hpp>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/import.hpp"
#include "viseme_names.hpp"

using namespace facecast::viseme;

using facecast::test::visemes;

namespace {

Utterance load(TimestampFormat f, const char* file, VisemeSet set,
               PhoneSet phones = PhoneSet::kAuto) {
  const std::string path =
      (facecast::test::source_dir() / "tests/viseme/fixtures").string() + "/" + file;
  Options o;
  o.set = set;
  return import_timestamps(f, facecast::read_file(path), o, phones, path);
}

std::string error_of(TimestampFormat f, const std::string& content,
                     PhoneSet phones = PhoneSet::kAuto) {
  try {
    import_timestamps(f, content, {}, phones, "in");
  } catch (const facecast::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("Azure viseme events (100 ns ticks)", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kAzure, "azure_visemes.json", VisemeSet::kOculus);
  CHECK(visemes(u) == "kk E nn O");  // ids 12 4 14 8; 0 is silence
  REQUIRE(u.visemes.size() == 4);
  CHECK(u.visemes[0].start == Approx(0.1));
  CHECK(u.visemes[0].end == Approx(0.175));
  CHECK(u.visemes[3].end == Approx(0.45));
  CHECK(u.duration == Approx(0.55));
}

TEST_CASE("Amazon Polly speech marks (NDJSON, ms)", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kPolly, "polly_speechmarks.ndjson", VisemeSet::kOculus);
  CHECK(visemes(u) == "kk RR DD O U RR DD");
  CHECK(u.visemes[0].start == Approx(0.006));
  REQUIRE(u.words.size() == 2);
  CHECK(u.words[0].text == "Hello");
  CHECK(u.words[1].start == Approx(0.374));
  CHECK(u.words[1].end == Approx(0.686));
  CHECK(u.duration == Approx(0.686));
}

TEST_CASE("Montreal Forced Aligner TextGrid, long format, ARPAbet", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kMfa, "mfa_long.TextGrid", VisemeSet::kOculus);
  CHECK(visemes(u) == "kk aa nn O U RR nn DD");
  REQUIRE(u.words.size() == 2);
  CHECK(u.words[1].text == "world");
  CHECK(u.phones[0].phone == "HH");
  CHECK(u.phones[0].lang == "arpabet");
  CHECK(u.visemes.front().start == Approx(0.1));
  CHECK(u.visemes.back().end == Approx(1.05));
  CHECK(u.duration == Approx(1.2));
}

TEST_CASE("Montreal Forced Aligner TextGrid, short format, pinyin", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kMfa, "mfa_short.TextGrid", VisemeSet::kZh15);
  CHECK(visemes(u) == "dtnl i gkh a");
  REQUIRE(u.syllables.size() == 2);
  CHECK(u.syllables[1].pinyin == "hao3");
  CHECK(u.syllables[1].start == Approx(0.2));
  CHECK(u.words.at(0).text == "你好");
}

TEST_CASE("Montreal Forced Aligner JSON, IPA", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kMfa, "mfa_alignment.json", VisemeSet::kOculus);
  CHECK(visemes(u) == "PP aa PP aa");
  CHECK(u.phones[1].lang == "ipa");
}

TEST_CASE("Rhubarb mouth cues, TSV and JSON", "[viseme][import]") {
  const Utterance tsv = load(TimestampFormat::kRhubarb, "rhubarb.tsv", VisemeSet::kOculus);
  CHECK(visemes(tsv) == "SS E SS U aa PP");
  CHECK(tsv.visemes[0].start == Approx(0.12));
  CHECK(tsv.duration == Approx(0.85));
  const Utterance json = load(TimestampFormat::kRhubarb, "rhubarb.json", VisemeSet::kZh15);
  CHECK(visemes(json) == "zcs e dtnl uv f");
}

TEST_CASE("ElevenLabs character alignment runs the text front-end", "[viseme][import]") {
  const Utterance u =
      load(TimestampFormat::kElevenLabs, "elevenlabs_alignment.json", VisemeSet::kZh15);
  REQUIRE(u.syllables.size() == 2);
  CHECK(u.syllables[0].pinyin == "ni3");
  CHECK(u.syllables[0].start == Approx(0.0));
  CHECK(u.syllables[1].start == Approx(0.25));
  CHECK(u.syllables[1].end == Approx(0.5));
  REQUIRE(u.words.size() == 2);
  CHECK(u.words[0].text == "你好");
  CHECK(u.words[1].text == "Hi");
  CHECK(u.words[1].start == Approx(0.7));  // the phones of "Hi" sit inside H..i
  CHECK(u.words[1].end == Approx(0.95));
  CHECK(u.text == "你好， Hi!");
}

TEST_CASE("generic JSON phones: pinyin syllables and errors", "[viseme][import]") {
  const Utterance u = load(TimestampFormat::kJson, "phones_pinyin.json", VisemeSet::kZh15);
  CHECK(visemes(u) == "zhchsh uv a ng sil jqx uv e");
  CHECK(u.syllables.size() == 2);
  CHECK(u.text == "装学");
  const std::string unknown_path =
      (facecast::test::source_dir() / "tests/viseme/fixtures").string() + "/phones_unknown.json";
  const std::string err =
      error_of(TimestampFormat::kJson, facecast::read_file(unknown_path), PhoneSet::kArpabet);
  CHECK_THAT(
      err, Catch::Contains("'QQ9'") && Catch::Contains("0.100 s") && Catch::Contains("phones[1]"));
  CHECK_THAT(error_of(TimestampFormat::kJson, "[{\"phone\": \"a\", \"start\": 1}]"),
             Catch::Contains("'end'"));
  CHECK_THAT(error_of(TimestampFormat::kJson, "[{\"phone\": \"a\", \"start\": 1, \"end\": 0.5}]"),
             Catch::Contains("invalid times"));
  CHECK_THAT(
      error_of(TimestampFormat::kPolly, "{\"time\": 5, \"type\": \"viseme\", \"value\": \"Z\"}"),
      Catch::Contains("in:1") && Catch::Contains("'Z'"));
  CHECK_THAT(
      error_of(TimestampFormat::kMfa,
               "File type = \"ooTextFile\"\nObject class = "
               "\"TextGrid\"\n0\n1\n<exists>\n1\n\"IntervalTier\"\n\"phones\"\n0\n1\n1\n0\nx"),
      Catch::Contains("in:13"));
  CHECK_THAT(error_of(TimestampFormat::kRhubarb, "0.0\tX\nzero\tA\n"), Catch::Contains("in:2"));
  CHECK_THAT(error_of(TimestampFormat::kAzure, "[{\"AudioOffset\": 1000, \"VisemeId\": 99}]"),
             Catch::Contains("unknown Azure viseme '99'"));
  // A number past a double's range is a one-line error, not an escaping json exception (fuzz).
  CHECK_THAT(error_of(TimestampFormat::kElevenLabs, "{\"characters\": 1e999999}"),
             Catch::Contains("in: invalid JSON: a number is out of range"));
}

TEST_CASE("the timestamp format is detected from the content", "[viseme][import]") {
  const std::pair<const char*, TimestampFormat> cases[] = {
      {"azure_visemes.json", TimestampFormat::kAzure},
      {"elevenlabs_alignment.json", TimestampFormat::kElevenLabs},
      {"mfa_alignment.json", TimestampFormat::kMfa},
      {"mfa_long.TextGrid", TimestampFormat::kMfa},
      {"mfa_short.TextGrid", TimestampFormat::kMfa},
      {"phones_pinyin.json", TimestampFormat::kJson},
      {"polly_speechmarks.ndjson", TimestampFormat::kPolly},
      {"rhubarb.json", TimestampFormat::kRhubarb},
      {"rhubarb.tsv", TimestampFormat::kRhubarb},
  };
  for (const auto& [file, format] : cases) {
    const std::string path =
        (facecast::test::source_dir() / "tests/viseme/fixtures").string() + "/" + file;
    INFO(file);
    CHECK(detect_timestamp_format(facecast::read_file(path), "x") == format);
  }
  CHECK_THROWS_AS(detect_timestamp_format("  \n", "empty.json"), facecast::Error);
  CHECK_THROWS_AS(detect_timestamp_format("hello", "x.txt"), facecast::Error);
}
