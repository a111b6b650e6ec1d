// Audio-only lip-sync: options mirror the config, the learned templates load, streaming in any
// chunking equals one push, the look-ahead fits the latency budget, bad input is a one-line error,
// and on festival English and altered Chinese speech both the class accuracy and the jawOpen
// correlation beat the "mouth follows loudness" baseline (bench_lipsync prints the figures).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <random>

#include <unistd.h>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "lipsync_eval.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::viseme;
using Catch::Contains;

TEST_CASE("lipsync option defaults mirror configs/viseme/lipsync.json", "[viseme][lipsync]") {
  const LipsyncOptions d, c = load_lipsync_options();
  CHECK(d.adapt_seconds == c.adapt_seconds);
  CHECK(d.prior_frames == c.prior_frames);
  CHECK(d.silence_range == c.silence_range);
  CHECK(d.silence_max_db == c.silence_max_db);
  CHECK(d.closure_max == c.closure_max);
  CHECK(d.closure_entry_db == c.closure_entry_db);
  CHECK(d.murmur_nasal_db == c.murmur_nasal_db);
  CHECK(d.murmur_dull_db == c.murmur_dull_db);
  CHECK(d.murmur_dip_db == c.murmur_dip_db);
  CHECK(d.murmur_voicing == c.murmur_voicing);
  CHECK(d.murmur_openness == c.murmur_openness);
  CHECK(d.closure_bias == c.closure_bias);
  CHECK(d.burst_max_db == c.burst_max_db);
  CHECK(d.labiodental_max_db == c.labiodental_max_db);
  CHECK(d.labiodental_bias == c.labiodental_bias);
  CHECK(d.jaw_openness == c.jaw_openness);
  CHECK(d.lookahead_frames == c.lookahead_frames);
  CHECK(d.context_frames == c.context_frames);
  CHECK(d.switch_margin == c.switch_margin);
  CHECK(d.jaw_range_db == c.jaw_range_db);
  CHECK(d.jaw_min == c.jaw_min);
  CHECK(d.jaw_max == c.jaw_max);
  CHECK(d.delay == c.delay);
  CHECK(d.window == c.window);
  CHECK(d.oculus == c.oculus);
  CHECK(d.zh15 == c.zh15);
  CHECK(d.mpeg4 == c.mpeg4);
  // f/v has a class of its own, shown as each set's labiodental viseme.
  CHECK(d.viseme(VisemeSet::kOculus, SoundClass::kLabiodental) == "FF");
  CHECK(d.viseme(VisemeSet::kZh15, SoundClass::kLabiodental) == "f");
  CHECK(d.viseme(VisemeSet::kMpeg4, SoundClass::kLabiodental) == "fv");
  CHECK(parse_sound_class("labiodental") == SoundClass::kLabiodental);
}

TEST_CASE("lipsync templates: every sounding class learned, bad tables are errors",
          "[viseme][lipsync]") {
  const LipsyncTemplates& t = LipsyncTemplates::builtin();
  CHECK(t.dims > 0);
  CHECK(t.classes[0].empty());
  for (int k = 1; k < kSoundClasses; ++k) CHECK(!t.classes[static_cast<std::size_t>(k)].empty());
  CHECK_THROWS_WITH(LipsyncTemplates::parse("{", "t.json"), Contains("t.json"));
  CHECK_THROWS_WITH(LipsyncTemplates::parse(R"({"dims": 3})", "t.json"), Contains("dims 3"));
}

TEST_CASE("lipsync: streaming in random chunks equals one push, latency within budget",
          "[viseme][lipsync]") {
  Options o;
  o.timing = Timing::kTts;
  const Utterance u = analyze("Maybe we should open the window", o);
  const Audio a = audio_from_pcm16(u.pcm, u.sample_rate);
  LipsyncAnalyzer whole(a.sample_rate), chunked(a.sample_rate);
  std::vector<LipsyncFrame> f1, f2;
  whole.push(a.samples.data(), a.samples.size(), f1);
  whole.finish(f1);
  std::mt19937 rng(7);
  for (std::size_t at = 0; at < a.samples.size();) {
    const std::size_t n = std::min<std::size_t>(a.samples.size() - at, rng() % 700 + 1);
    chunked.push(a.samples.data() + at, n, f2);
    at += n;
  }
  chunked.finish(f2);
  REQUIRE(f1.size() == f2.size());
  for (std::size_t i = 0; i < f1.size(); ++i) {
    CHECK(f1[i].cls == f2[i].cls);
    CHECK(f1[i].loudness == f2[i].loudness);
  }
  // Half a window + look-ahead + the live delay + one 60 fps frame stay under 150 ms.
  CHECK(whole.latency() + LipsyncOptions{}.delay + 1.0 / 60 <= 0.150);
  const Utterance l = lipsync(a, o, {}, "(smile,40,0.3)@0.5");
  CHECK(l.set == VisemeSet::kOculus);
  CHECK(l.duration == a.seconds());
  REQUIRE(l.expressions.size() == 1);
  CHECK(l.expressions[0].start == 0.5);
  std::size_t vowels = 0;
  for (const auto& e : l.visemes) {
    CHECK(e.strength >= 0);
    CHECK(e.strength <= 1);
    vowels += e.viseme == "aa" || e.viseme == "E" || e.viseme == "I" || e.viseme == "O" ||
              e.viseme == "U";
  }
  CHECK(vowels >= 5);
  // The JSON carries the strengths and reads back.
  const Utterance back = utterance_from_json(to_json(l));
  REQUIRE(back.visemes.size() == l.visemes.size());
  CHECK(std::abs(back.visemes[3].strength - l.visemes[3].strength) < 1e-3);
}

TEST_CASE("lipsync: silence and bad tags are one-line errors", "[viseme][lipsync]") {
  Audio quiet;
  quiet.sample_rate = 16000;
  quiet.samples.assign(16000, 0.0f);
  CHECK_THROWS_WITH(lipsync(quiet), Contains("no speech"));
  Options o;
  o.timing = Timing::kTts;
  const Utterance u = analyze("hello", o);
  const Audio a = audio_from_pcm16(u.pcm, u.sample_rate);
  CHECK_THROWS_WITH(lipsync(a, {}, {}, "(smile,99,1)@0"), Contains("0..63"));
  CHECK_THROWS_WITH(lipsync(a, {}, {}, "(happy,9,1)@0"), Contains("unknown expression 'happy'"));
  CHECK_THROWS_WITH(lipsync(a, {}, {}, "smile@1"),
                    Contains("expected (name,intensity,seconds)@time"));
}

TEST_CASE("lipsync: class accuracy, closures, FF and jawOpen on synthetic speech",
          "[viseme][lipsync][slow]") {
  // Bounds a little under what bench_lipsync measures (docs/benchmarks.md#speech): festival
  // English 54.6 % accuracy (loudness 16.6 %), p/b/m closures 20/24 (6/24), closure precision
  // 30.4 % (14.6 %), FF 8/8, jaw 0.585 (loudness 0.478); altered espeak-ng Chinese 42.4 %
  // (21.4 %), jaw 0.682 (0.539).
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("facecast_lipsync_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::vector<test::AlignCase> cases = test::festival_cases(dir);
  for (auto& c : test::chinese_cases(dir)) cases.push_back(std::move(c));
  for (const char* lang : {"en", "zh"}) {
    test::LipsyncScore s;
    for (const auto& c : cases)
      if (c.lang == lang) s += test::score_lipsync(c, {});
    INFO(lang << ": accuracy " << s.accuracy() << " (loudness " << s.baseline_accuracy()
              << "), p/b/m closed " << s.pbm_closed << "/" << s.pbm << " (loudness "
              << s.baseline_pbm_closed << "), closure precision " << s.closure_precision()
              << " (loudness " << s.baseline_closure_precision() << "), FF " << s.ff_shown << "/"
              << s.ff << ", jaw correlation " << s.correlation() << " (loudness "
              << s.baseline_correlation() << ")");
    CHECK(s.accuracy() > s.baseline_accuracy() + 0.15);
    if (std::string(lang) == "en") {
      CHECK(s.accuracy() >= 0.50);
      CHECK(s.closure_recall() >= 0.75);
      CHECK(s.closure_recall() > s.baseline_closure_recall() + 0.4);
      CHECK(s.closure_precision() >= 0.25);
      CHECK(s.closure_precision() > s.baseline_closure_precision());
      CHECK(s.ff_recall() >= 0.6);
      CHECK(s.correlation() >= 0.55);
      CHECK(s.correlation() > s.baseline_correlation() + 0.06);
    } else {
      CHECK(s.accuracy() >= 0.39);
      CHECK(s.correlation() > s.baseline_correlation() + 0.1);
    }
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

TEST_CASE("lipsync: human speech (development recordings) against the HMM alignment",
          "[viseme][lipsync]") {
  // The recordings and the English model come from scripts/install-deps.sh (alsa-utils,
  // pocketsphinx-testdata, pocketsphinx-en-us): missing, this fails under CI=true and warns
  // elsewhere. Never librivox/ or cards/ (held out). Measured by bench_lipsync: accuracy 39.6 %
  // (loudness 18.4 %), p/b/m 3/3 (0/3), closure precision 6.7 % (0 %), FF 4/9, jaw 0.630 cold,
  // 0.668 when the speaker was heard before (loudness 0.591, 0.610).
  if (!test::require_data("/usr/share/pocketsphinx/model/en-us/en-us/mdef")) return;
  const std::filesystem::path tsv = test::source_dir() / "tests/viseme/eval/human_words.tsv";
  for (const auto& c : test::human_cases(tsv))
    if (!test::require_data(c.audio)) return;
  const auto cases = test::human_lipsync_cases(tsv);
  REQUIRE(cases.size() >= 10);
  test::LipsyncScore cold, warm;
  for (const auto& c : cases) {
    cold += test::score_lipsync(c.audio, c.truth, {});
    Audio twice = c.audio;
    twice.samples.insert(twice.samples.end(), c.audio.samples.begin(), c.audio.samples.end());
    auto truth = c.truth;
    for (auto& e : truth) e.start += c.audio.seconds(), e.end += c.audio.seconds();
    warm += test::score_lipsync(twice, truth, {}, c.audio.seconds());
  }
  INFO("human: accuracy " << cold.accuracy() << " (loudness " << cold.baseline_accuracy()
                          << "), p/b/m " << cold.pbm_closed << "/" << cold.pbm << " cold, "
                          << warm.pbm_closed << "/" << warm.pbm << " warm, FF " << cold.ff_shown
                          << "/" << cold.ff << ", jaw " << cold.correlation() << " cold, "
                          << warm.correlation() << " warm (loudness " << cold.baseline_correlation()
                          << ", " << warm.baseline_correlation() << ")");
  REQUIRE(cold.pbm >= 3);
  CHECK(cold.accuracy() >= 0.36);
  CHECK(cold.accuracy() > cold.baseline_accuracy() + 0.15);
  // The issue's goal: the lips close in >= 80 % of the p/b/m segments of human speech.
  CHECK(cold.closure_recall() >= 0.8);
  CHECK(warm.closure_recall() >= 0.8);
  CHECK(cold.closure_precision() >= 0.04);
  CHECK(cold.ff_recall() >= 0.3);
  // ... and a jaw closer to the text path's than the loudness is.
  CHECK(cold.correlation() >= 0.6);
  CHECK(cold.correlation() > cold.baseline_correlation());
  CHECK(warm.correlation() > warm.baseline_correlation());
}

TEST_CASE("lipsync input: not audio, empty and 10-hour files are one-line errors naming the file",
          "[viseme][lipsync]") {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("facecast_lipbad_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string junk = (dir / "junk.ogg").string(), empty = (dir / "empty.wav").string(),
                    hours = (dir / "ten_hours.wav").string();
  std::ofstream(junk) << "no audio here\n";
  std::ofstream(empty).close();
  {
    // A PCM16 WAV header for 10 hours at 8 kHz, the data a sparse hole (no disk used).
    const std::uint32_t rate = 8000, bytes = 36000u * rate * 2;
    std::ofstream f(hours, std::ios::binary);
    const auto u32 = [&](std::uint32_t v) { f.write(reinterpret_cast<const char*>(&v), 4); };
    const auto u16 = [&](std::uint16_t v) { f.write(reinterpret_cast<const char*>(&v), 2); };
    f << "RIFF";
    u32(36 + bytes);
    f << "WAVEfmt ";
    u32(16), u16(1), u16(1), u32(rate), u32(rate * 2), u16(2), u16(16);
    f << "data";
    u32(bytes);
  }
  std::filesystem::resize_file(hours, 44 + 36000ull * 8000 * 2);
  const auto check = [&](const std::string& file, const char* what) {
    try {
      (void)lipsync(read_audio(file, load_audio_options()));
      FAIL("no error for " << file);
    } catch (const Error& e) {
      const std::string m = e.what();
      INFO(m);
      CHECK(m.find(file) != std::string::npos);
      CHECK(m.find(what) != std::string::npos);
      CHECK(m.find('\n') == std::string::npos);
    }
  };
  check(junk, "not audio");
  check(empty, "empty");
  check(hours, "longer than the limit");
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}
