// Speech audio in (formats, resampling, one-line errors) and forced alignment of text to speech
// from other synthesizers (festival) and altered Chinese espeak-ng speech.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <thread>

#include <unistd.h>

#include "align_cases.hpp"
#include "align_hmm.hpp"
#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"
#include "human_cases.hpp"
#include "tables.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::viseme;
using Catch::Contains;

namespace {

using test::Scratch;

std::vector<float> sine(double hz, int rate, double seconds) {
  std::vector<float> s(static_cast<std::size_t>(seconds * rate));
  for (std::size_t i = 0; i < s.size(); ++i)
    s[i] = 0.5f *
           static_cast<float>(std::sin(2 * std::numbers::pi * hz * static_cast<double>(i) / rate));
  return s;
}

// Frequency by counting upward zero crossings.
double frequency(const std::vector<float>& s, int rate) {
  int crossings = 0;
  for (std::size_t i = 1; i < s.size(); ++i) crossings += s[i - 1] < 0 && s[i] >= 0;
  return crossings * static_cast<double>(rate) / static_cast<double>(s.size());
}

double rms(const std::vector<float>& s, std::size_t from, std::size_t to) {
  double sum = 0;
  for (std::size_t i = from; i < to; ++i) sum += s[i] * s[i];
  return std::sqrt(sum / static_cast<double>(to - from));
}

}  // namespace

TEST_CASE("resampling keeps frequency and level, and streaming equals whole", "[viseme][audio]") {
  const auto in = sine(1000, 44100, 1.0);
  const auto out = resample(in, 44100, 16000);
  CHECK(out.size() == 16000);
  CHECK(std::abs(frequency(out, 16000) - 1000) < 3);
  CHECK(std::abs(rms(out, 1000, 15000) - 0.5 / std::sqrt(2.0)) < 0.01);
  // A tone above the new Nyquist frequency is removed, not aliased.
  const auto high = resample(sine(12000, 44100, 1.0), 44100, 16000);
  CHECK(rms(high, 1000, 15000) < 0.01);
  StreamResampler stream(44100, 16000);
  std::vector<float> chunked;
  for (std::size_t at = 0; at < in.size(); at += 441)
    stream.push(in.data() + at, std::min<std::size_t>(441, in.size() - at), chunked);
  REQUIRE(chunked.size() > 15900);
  for (std::size_t i = 0; i < 15900; i += 97) CHECK(std::abs(chunked[i] - out[i]) < 1e-5f);
}

TEST_CASE("read_audio: WAV, FLAC, OGG, MP3 and AAC at any rate and channel count",
          "[viseme][audio]") {
  const Scratch dir("formats");
  const std::string src = (dir / "src.wav").string();
  test::run_capture("sox -n -r 44100 -c 2 " + src + " synth 2.0 sine 440 vol 0.5");
  const std::vector<std::string> files = {src, (dir / "a.flac").string(), (dir / "a.ogg").string(),
                                          (dir / "a.mp3").string(), (dir / "a.m4a").string()};
  test::run_capture("sox " + src + " -r 22050 " + files[1]);
  test::run_capture("sox " + src + " -r 48000 -c 1 " + files[2]);
  test::run_capture("ffmpeg -v error -y -i " + src + " -ar 32000 " + files[3]);
  test::run_capture("ffmpeg -v error -y -i " + src + " -c:a aac " + files[4]);
  for (const auto& f : files) {
    INFO(f);
    const Audio a = read_audio(f);
    CHECK(a.sample_rate == 16000);
    CHECK(std::abs(a.seconds() - 2.0) < 0.08);  // MP3/AAC add encoder padding
    CHECK(std::abs(frequency(a.samples, 16000) - 440) < 8);
    CHECK(rms(a.samples, 4000, 28000) > 0.1);
  }
}

TEST_CASE("read_audio: bad audio is a one-line error naming the file", "[viseme][audio]") {
  const Scratch dir("bad");
  const std::string text = (dir / "notes.mp3").string(), empty = (dir / "empty.wav").string();
  std::ofstream(text) << "these are not the samples you are looking for\n";
  std::ofstream(empty).close();
  CHECK_THROWS_WITH(read_audio(text), Contains(text) && Contains("not audio"));
  CHECK_THROWS_WITH(read_audio(empty), Contains("empty"));
  CHECK_THROWS_WITH(read_audio((dir / "missing.wav").string()), Contains("no such"));
  const std::string header_only = (dir / "zero.wav").string();
  test::run_capture("sox -n -r 16000 -c 1 " + header_only + " trim 0 0");
  CHECK_THROWS_WITH(read_audio(header_only), Contains("no audio samples"));
  // Over the limit: refused from the header (libsndfile) or at the limit while decoding (ffmpeg).
  AudioOptions o;
  o.max_seconds = 3;
  const std::string wav = (dir / "long.wav").string(), m4a = (dir / "long.m4a").string();
  test::run_capture("sox -n -r 16000 -c 1 " + wav + " synth 8 sine 300");
  test::run_capture("ffmpeg -v error -y -i " + wav + " -c:a aac " + m4a);
  CHECK_THROWS_WITH(read_audio(wav, o), Contains("longer than the limit"));
  CHECK_THROWS_WITH(read_audio(m4a, o), Contains("longer than the limit"));
  for (const std::string& f : {text, empty, wav, m4a}) {
    try {
      read_audio(f, o);
    } catch (const Error& e) {
      CHECK(std::string(e.what()).find('\n') == std::string::npos);
    }
  }
}

TEST_CASE("audio and align option defaults mirror configs/viseme", "[viseme][config]") {
  const AudioOptions d, c = load_audio_options();
  CHECK(d.sample_rate == c.sample_rate);
  CHECK(d.max_seconds == c.max_seconds);
  CHECK(d.min_seconds == c.min_seconds);
  CHECK(d.ffmpeg == c.ffmpeg);
  CHECK(d.decode_timeout == c.decode_timeout);
  const AlignOptions a, b = load_align_options();
  CHECK(a.english == b.english);
  CHECK(a.hmm_phones == b.hmm_phones);
  CHECK(a.min_speed == b.min_speed);
  CHECK(a.max_speed == b.max_speed);
  CHECK(a.band == b.band);
  CHECK(a.band_frames == b.band_frames);
  CHECK(a.refine_seconds == b.refine_seconds);
  CHECK(a.refine_weight == b.refine_weight);
  CHECK(a.min_pause == b.min_pause);
  CHECK(a.silence_range == b.silence_range);
  CHECK(a.silence_max_db == b.silence_max_db);
  CHECK(a.hold_penalty == b.hold_penalty);
  CHECK(a.deltas == b.deltas);
  CHECK(a.refine == b.refine);
  CHECK(a.warps == b.warps);
  CHECK(a.max_seconds == b.max_seconds);
  CHECK(a.stream_lag == b.stream_lag);
}

TEST_CASE("alignment: word onsets on festival English and altered Chinese speech",
          "[viseme][align]") {
  const Scratch dir("cases");
  std::vector<test::AlignCase> cases = test::festival_cases(dir.path);
  for (auto& c : test::chinese_cases(dir.path)) cases.push_back(std::move(c));
  // English through both backends (the HMM where pocketsphinx-en-us is installed), Chinese DTW.
  for (const auto& [lang, backend] :
       {std::pair{"en", AlignOptions::Backend::kHmm}, std::pair{"en", AlignOptions::Backend::kDtw},
        std::pair{"zh", AlignOptions::Backend::kDtw}}) {
    AlignOptions ao;
    ao.english = backend;
    std::vector<double> errors;
    for (const auto& c : cases) {
      if (c.lang != lang) continue;
      const Audio audio = read_audio(c.audio);
      const Utterance u = align(c.text, audio, {}, ao);
      CHECK(u.duration == audio.seconds());
      CHECK(u.pcm.size() == audio.samples.size());
      const auto e = test::onset_errors(u, c);
      errors.insert(errors.end(), e.begin(), e.end());
      // Every phone keeps some duration (a quiet fricative is not swallowed by a pause).
      for (const auto& p : u.phones) CHECK((p.phone == "pau" || p.end > p.start));
    }
    std::sort(errors.begin(), errors.end());
    double mean = 0;
    for (double e : errors) mean += e / static_cast<double>(errors.size());
    const double p95 = errors[errors.size() * 95 / 100];
    INFO(lang << (backend == AlignOptions::Backend::kHmm ? " hmm" : " dtw") << ": mean "
              << mean * 1000 << " ms, p95 " << p95 * 1000 << " ms over " << errors.size()
              << " words");
    // Looser than bench_align's targets (30 / 80 ms): this guards against regressions.
    CHECK(mean < 0.050);
    CHECK(p95 < 0.150);
  }
}

TEST_CASE("alignment: no word is shorter than its phones can be (short function words)",
          "[viseme][align]") {
  // espeak-ng reads some word pairs as one word ("to be", "I am", "at once", "of the"): each word
  // must still get its own phones, in the text-to-speech timing and in both aligners, or it has no
  // length (issue 36: "be" after "to" aligned to nothing on human speech).
  Options o;
  o.timing = Timing::kTts;
  for (const std::string text :
       {"He has to be home", "I am going to be there", "Take it at once"}) {
    const Utterance u = analyze(text, o);
    for (const auto& w : u.words) {
      INFO(text << ": " << w.text << " " << w.start << ".." << w.end);
      CHECK(w.end > w.start);
    }
  }
  const Scratch dir("function");
  const auto& sentences = test::function_word_sentences();
  std::vector<test::AlignCase> cases = test::festival_cases(dir.path, sentences, "fw");
  for (auto& c : test::flite_cases(dir.path, sentences, {"slt", "kal16", "awb", "rms"}, "fw"))
    cases.push_back(std::move(c));
  // The HMM backend (DTW's word lengths depend on what the process aligned before; see
  // docs/benchmarks.md).
  if (!detail::hmm_installed()) return;
  std::vector<double> errors;
  for (const auto& c : cases) {
    const Utterance u = align(c.text, read_audio(c.audio));
    REQUIRE(u.words.size() == c.onsets.size());
    for (const auto& w : u.words) {
      // The word's phones: CMU phones (the HMM's units) of those that start inside it.
      std::size_t phones = 0, cmu = 0;
      for (const auto& p : u.phones)
        if (p.start >= w.start - 1e-9 && p.start < w.end - 1e-9) {
          ++phones;
          const auto it = detail::tables().espeak_cmu.find(p.phone);
          if (it != detail::tables().espeak_cmu.end()) cmu += it->second.size();
        }
      INFO(c.name << ": " << w.text << " " << w.start << ".." << w.end << ", " << phones
                  << " phones, " << cmu << " CMU phones");
      CHECK(phones > 0);
      // pocketsphinx's phones are three states left to right without skips: at least 3 frames
      // (30 ms) each.
      CHECK(w.end - w.start >= 0.03 * static_cast<double>(std::max<std::size_t>(cmu, 1)) - 1e-6);
    }
    const auto e = test::onset_errors(u, c);
    errors.insert(errors.end(), e.begin(), e.end());
  }
  std::sort(errors.begin(), errors.end());
  double mean = 0;
  for (double e : errors) mean += e / static_cast<double>(errors.size());
  INFO("hmm: mean " << mean * 1000 << " ms, p95 " << errors[errors.size() * 95 / 100] * 1000
                    << " ms, worst " << errors.back() * 1000 << " ms over " << errors.size()
                    << " words");
  // Measured (2026-12-03), mean / p95 / worst: 15.8 / 44 / 100 ms; with the joined words of no
  // length 27.2 / 100 / 468.
  CHECK(mean < 0.025);
  CHECK(errors[errors.size() * 95 / 100] < 0.070);
}

TEST_CASE("alignment: pauses in the audio become rest", "[viseme][align]") {
  Options o;
  o.timing = Timing::kTts;
  const Utterance spoken = analyze("Hello there", o);
  const Utterance later = analyze("good morning", o);
  // "Hello there" + 1.2 s of silence + "good morning", aligned to the text without punctuation.
  std::vector<int16_t> pcm = spoken.pcm;
  pcm.resize(pcm.size() + static_cast<std::size_t>(1.2 * spoken.sample_rate), 0);
  const double gap_start = spoken.duration, gap_end = spoken.duration + 1.2;
  pcm.insert(pcm.end(), later.pcm.begin(), later.pcm.end());
  const Audio audio = audio_from_pcm16(pcm, spoken.sample_rate);
  const Utterance u = align("Hello there good morning", audio);
  AlignOptions short_limit;
  short_limit.max_seconds = 2;
  CHECK_THROWS_WITH(align("Hello there good morning", audio, {}, short_limit),
                    Contains("longer than the limit"));
  REQUIRE(u.words.size() == 4);
  std::string timed;
  for (const auto& p : u.phones)
    timed += p.phone + " " + std::to_string(p.start) + " " + std::to_string(p.end) + ", ";
  INFO(timed);
  CHECK(u.words[1].end <= gap_start + 0.08);
  CHECK(std::abs(u.words[2].start - gap_end) < 0.08);
  bool rest = false;
  for (const auto& v : u.visemes)
    rest |= v.viseme == "sil" && v.start < gap_start + 0.2 && v.end > gap_end - 0.2;
  CHECK(rest);
}

namespace {

// The HMM backend's word-onset errors (seconds, sorted) on a hand-labelled set of human English
// speech (human_cases.hpp), checking on the way that it ran and reached each transcript's end.
// Empty when the model or a recording is missing (require_data: a failure under CI=true).
std::vector<double> hmm_human_errors(const std::string& tsv, std::size_t min_files) {
  // The model and recordings come from scripts/install-deps.sh (pocketsphinx-en-us, alsa-utils,
  // pocketsphinx-testdata): missing, this fails under CI=true and warns elsewhere.
  if (!test::require_data("/usr/share/pocketsphinx/model/en-us/en-us/mdef")) return {};
  const auto cases = test::human_cases(test::source_dir() / "tests/viseme/eval" / tsv);
  REQUIRE(cases.size() >= min_files);
  for (const auto& c : cases)
    if (!test::require_data(c.audio)) return {};
  REQUIRE(detail::hmm_installed());
  const int decoders = detail::hmm_pool_stats().created;
  std::vector<double> errors;
  for (const auto& c : cases) {
    INFO(c.name);
    const Audio audio = test::human_audio(c);
    const Utterance u = align(c.text, audio);
    // The HMM ran and reached the transcript's end: its words, in order, inside the audio.
    REQUIRE(u.words.size() == c.onsets.size());
    for (std::size_t w = 1; w < u.words.size(); ++w)
      CHECK(u.words[w].start >= u.words[w - 1].end - 1e-9);
    const auto e = test::scored_onset_errors(u, c);
    errors.insert(errors.end(), e.begin(), e.end());
  }
  CHECK(detail::hmm_pool_stats().created >= std::max(decoders, 1));
  std::sort(errors.begin(), errors.end());
  return errors;
}

struct OnsetStats {
  double mean = 0, p95 = 0, worst = 0;
};

OnsetStats onset_stats(const std::vector<double>& sorted) {
  OnsetStats s;
  for (double e : sorted) s.mean += e / static_cast<double>(sorted.size());
  s.p95 = sorted[sorted.size() * 95 / 100];
  s.worst = sorted.back();
  return s;
}

}  // namespace

TEST_CASE("alignment: English HMM word onsets on human speech (hand labels)", "[viseme][align]") {
  const auto errors = hmm_human_errors("human_words.tsv", 10);
  if (errors.empty()) return;
  const OnsetStats s = onset_stats(errors);
  INFO("human English (HMM): mean " << s.mean * 1000 << " ms, p95 " << s.p95 * 1000 << " ms, worst "
                                    << s.worst * 1000 << " ms over " << errors.size() << " words");
  // The goal (mean <= 30 ms, p95 <= 80 ms), on the development labels (+- 10-30 ms).
  CHECK(s.mean <= 0.030);
  CHECK(s.p95 <= 0.080);
}

TEST_CASE("alignment: English HMM word onsets on held-out human speech (issue 36's check)",
          "[viseme][align]") {
  // pocketsphinx-testdata's cards/ and librivox/ recordings, held out by issue 36: labelled by
  // hand before any aligner ran on them, never tuned on (eval/human_words_heldout.tsv).
  const auto errors = hmm_human_errors("human_words_heldout.tsv", 8);
  if (errors.empty()) return;
  const OnsetStats s = onset_stats(errors);
  INFO("held-out human English (HMM): mean " << s.mean * 1000 << " ms, p95 " << s.p95 * 1000
                                             << " ms, worst " << s.worst * 1000 << " ms over "
                                             << errors.size() << " words");
  // The goal is mean <= 30 ms, p95 <= 80 ms; measured 23.2 ms mean, 55 ms p95, 205 ms worst
  // over 48 words (2026-12-03, after the joined-words fix; docs/benchmarks.md tells the history).
  // The bounds are the measured figures with a small margin, so that the check catches a
  // regression; nothing was tuned on these recordings.
  CHECK(s.mean <= 0.026);
  CHECK(s.p95 <= 0.065);
}

TEST_CASE("alignment: silence around the speech does not move its words (both backends)",
          "[viseme][align]") {
  // Recordings often hold seconds of room noise before and after the speech. Both backends
  // normalise the cepstra over the utterance, so that silence pulled the statistics toward it:
  // DTW lost words by up to a second, the HMM moved some by 80 ms.
  if (!test::require_data("/usr/share/pocketsphinx/model/en-us/en-us/mdef")) return;
  const auto cases = test::human_cases(test::source_dir() / "tests/viseme/eval/human_words.tsv");
  REQUIRE(cases.size() >= 10);
  for (const auto& [name, backend] :
       {std::pair{"hmm", AlignOptions::Backend::kHmm}, {"dtw", AlignOptions::Backend::kDtw}}) {
    AlignOptions o = load_align_options();
    o.english = backend;
    std::vector<double> moved;
    for (const auto& c : cases) {
      if (!test::require_data(c.audio)) return;
      INFO(name << " " << c.name);
      const Audio audio = test::human_audio(c);
      test::AlignCase pc = c;
      Audio padded = audio;
      test::pad_audio(padded, pc, 3.0);
      const Utterance u = align(c.text, audio, {}, o), v = align(c.text, padded, {}, o);
      REQUIRE(u.words.size() == v.words.size());
      for (std::size_t w = 0; w < u.words.size(); ++w)
        moved.push_back(std::abs(v.words[w].start - 3.0 - u.words[w].start));
    }
    std::sort(moved.begin(), moved.end());
    const OnsetStats s = onset_stats(moved);
    WARN(name << ": words moved by 3 s of faint noise around the speech: mean " << s.mean * 1000
              << " ms, p95 " << s.p95 * 1000 << " ms, worst " << s.worst * 1000 << " ms");
    // Measured: HMM 6.9 / 40 / 97.5 ms (10 / 80 / 90 before), DTW 10 / 40 / 110 ms (98 / 780 /
    // 1080 before).
    CHECK(s.mean <= 0.02);
    CHECK(s.p95 <= 0.06);
    CHECK(s.worst <= 0.15);
  }
}

TEST_CASE("alignment: the HMM backend is quiet, falls back to DTW and runs in parallel",
          "[viseme][align]") {
  if (!test::require_data("/usr/share/pocketsphinx/model/en-us/en-us/mdef")) return;
  Options o;
  o.timing = Timing::kTts;
  const Utterance spoken = analyze("Please call me when you get home", o);
  const Audio audio = audio_from_pcm16(spoken.pcm, spoken.sample_rate);
  // Nothing on stderr from pocketsphinx.
  fflush(stderr);
  const int saved = dup(2);
  const Scratch dir("quiet");
  const std::string log = (dir / "stderr.txt").string();
  FILE* f = std::fopen(log.c_str(), "w");
  REQUIRE(f);
  dup2(fileno(f), 2);
  const Utterance u = align("Please call me when you get home", audio);
  fflush(stderr);
  dup2(saved, 2);
  close(saved);
  std::fclose(f);
  CHECK(std::filesystem::file_size(log) == 0);
  REQUIRE(u.words.size() == 7);
  for (std::size_t w = 0; w < 7; ++w)
    CHECK(std::abs(u.words[w].start - spoken.words[w].start) < 0.06);
  // English text over the wrong audio still gives every word (the HMM or, failing, DTW).
  const Utterance wrong = align("twelve purple elephants dance quietly tonight", audio);
  CHECK(wrong.words.size() == 6);
  // Decoders from the pool in parallel give the same times as one after another.
  std::vector<Utterance> out(4);
  std::vector<std::thread> threads;
  for (auto& r : out)
    threads.emplace_back([&] { r = align("Please call me when you get home", audio); });
  for (auto& t : threads) t.join();
  for (const auto& r : out) {
    REQUIRE(r.words.size() == u.words.size());
    for (std::size_t w = 0; w < u.words.size(); ++w) CHECK(r.words[w].start == u.words[w].start);
  }
}
