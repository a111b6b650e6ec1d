#pragma once
// Speech with known word onsets for the alignment test and bench/bench_align, made at run time
// into a scratch folder (never committed): English from festival (kal diphone voice; word starts
// from its Word relation) and flite (slt and kal voices; segment end times from -psdur, grouped
// into words by each word's own phone count), Chinese from espeak-ng's Mandarin voice with other
// variants and speeds, then pitch-shifted, time-stretched unevenly in three pieces, reverberated
// and mixed with pink noise by sox (the onsets follow the stretch).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "facecast/core/wav.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/import.hpp"

namespace facecast::test {

// A scratch folder for one test case, removed with everything in it at the end of the case.
struct Scratch {
  std::filesystem::path path;
  explicit Scratch(const std::string& name)
      : path(std::filesystem::temp_directory_path() /
             ("facecast_align_" + name + "_" + std::to_string(getpid()))) {
    std::filesystem::create_directories(path);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  std::filesystem::path operator/(const std::string& file) const { return path / file; }
};

struct AlignCase {
  std::string name, lang, text, audio;
  std::vector<double> onsets;         // true onset of each word of the utterance, seconds
  std::vector<viseme::Phone> phones;  // true phones (festival/flite names; zh: facecast's units)
  std::vector<viseme::VisemeEvent> visemes;  // the text path's Oculus visemes on the true timing
};

// The text path's Oculus visemes on true ARPAbet-like phone times (festival's and flite's phone
// names are ARPAbet in lower case, "pau" for pauses).
inline void add_true_visemes(AlignCase& c) {
  nlohmann::json phones = nlohmann::json::array();
  for (const auto& p : c.phones)
    phones.push_back({{"phone", p.phone}, {"start", p.start}, {"end", p.end}});
  viseme::Options o;
  o.set = viseme::VisemeSet::kOculus;
  c.visemes = viseme::import_timestamps(viseme::TimestampFormat::kJson, phones.dump(), o,
                                        viseme::PhoneSet::kArpabet, c.name)
                  .visemes;
}

inline std::string run_capture(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) throw std::runtime_error("cannot run: " + command);
  char buf[4096];
  for (std::size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  if (pclose(p) != 0) throw std::runtime_error("failed: " + command);
  return out;
}

inline const std::vector<std::string>& english_sentences() {
  static const std::vector<std::string> s = {
      "The quick brown fox jumps over the lazy dog",
      "She sells sea shells by the sea shore every morning",
      "Please call me when you get home from the station",
      "We will meet again tomorrow, before the long meeting starts",
      "My father bought a small boat to fish on the lake",
      "Reading books at night helps me fall asleep quickly",
      "The weather was cold, so we stayed inside and played music",
      "Can you tell me where the nearest bank is"};
  return s;
}

// Short function words after pauses and plosives ("to be", "will be", "to a", "of the"): the
// words the HMM aligner's worst errors on human speech were (issue 36); a development set for
// the alignment's tail (test_align.cpp, bench_align's "function" set).
inline const std::vector<std::string>& function_word_sentences() {
  static const std::vector<std::string> s = {
      "I am going to be there at noon",    "He has to be home before dark",
      "That will be the last time we go",  "It may be too late to ask him",
      "We want to be sure of the price",   "You need to be careful with it",
      "Take it to a doctor at once",       "Most of the people seemed to be tired",
      "It used to be a good place to eat", "They are going to be late, but it will be fine",
      "Give it to a friend of the family", "What could be better than that"};
  return s;
}

inline const std::vector<std::string>& chinese_sentences() {
  static const std::vector<std::string> s = {
      "今天天气很好，我们一起去公园散步吧", "我想喝一杯热咖啡，然后开始工作",
      "他每天早上七点起床，坐地铁去学校",   "这本书非常有意思，你一定要看看",
      "明天下午我们在会议室讨论这个问题",   "请把窗户打开，房间里太热了"};
  return s;
}

// The words of `text` as facecast reads them (lower-cased letters only), for matching.
inline std::vector<std::string> word_tokens(const std::string& text) {
  std::vector<std::string> out;
  std::string w;
  for (char c : text + " ") {
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '\'') {
      w += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!w.empty()) {
      out.push_back(w);
      w.clear();
    }
  }
  return out;
}

inline std::vector<AlignCase> festival_cases(
    const std::filesystem::path& dir, const std::vector<std::string>& s = english_sentences(),
    const std::string& tag = "") {
  std::ofstream scm(dir / ("festival" + tag + ".scm"));
  for (std::size_t i = 0; i < s.size(); ++i) {
    scm << "(set! u (Utterance Text \"" << s[i] << "\"))\n(utt.synth u)\n(utt.save.wave u \""
        << (dir / ("fest" + tag + std::to_string(i) + ".wav")).string() << "\" 'riff)\n"
        << "(format t \"S " << i << "\\n\")\n"
        << "(mapcar (lambda (w) (format t \"%f\\n\" (item.feat w \"word_start\"))) "
           "(utt.relation.items u 'Word))\n"
        << "(mapcar (lambda (s) (format t \"P %s %f\\n\" (item.name s) "
           "(item.feat s \"segment_end\"))) (utt.relation.items u 'Segment))\n";
  }
  scm.close();
  std::istringstream out(
      run_capture("festival -b " + (dir / ("festival" + tag + ".scm")).string()));
  std::vector<AlignCase> cases;
  for (std::string line; std::getline(out, line);) {
    if (line.rfind("S ", 0) == 0) {
      const auto i = static_cast<std::size_t>(std::stoi(line.substr(2)));
      cases.push_back({"festival " + tag + std::to_string(i),
                       "en",
                       s[i],
                       (dir / ("fest" + tag + std::to_string(i) + ".wav")).string(),
                       {},
                       {},
                       {}});
    } else if (line.rfind("P ", 0) == 0 && !cases.empty()) {
      std::istringstream in(line.substr(2));
      viseme::Phone p;
      in >> p.phone >> p.end;
      auto& ph = cases.back().phones;
      p.start = ph.empty() ? 0 : ph.back().end;
      ph.push_back(p);
    } else if (!cases.empty() && !line.empty()) {
      cases.back().onsets.push_back(std::stod(line));
    }
  }
  for (auto& c : cases) add_true_visemes(c);
  return cases;
}

// flite cases, voice i % voices.size() for sentence i; `stretch` scales its durations (< 1:
// faster).
inline std::vector<AlignCase> flite_cases(const std::filesystem::path& dir,
                                          const std::vector<std::string>& s = english_sentences(),
                                          const std::vector<std::string>& voices = {"slt", "kal16"},
                                          const std::string& tag = "", double stretch = 1.0) {
  std::vector<AlignCase> cases;
  const std::string setf =
      stretch == 1.0 ? "" : " --setf duration_stretch=" + std::to_string(stretch);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const std::string voice = voices[i % voices.size()];
    const std::string wav = (dir / ("flite" + tag + std::to_string(i) + ".wav")).string();
    std::istringstream segs(
        run_capture("flite -voice " + voice + setf + " -t '" + s[i] + "' -o " + wav + " -psdur"));
    std::vector<std::pair<std::string, double>> phones;  // (name, start)
    double prev = 0;
    for (std::string tok; segs >> tok;) {
      const auto colon = tok.find(':');
      if (colon == std::string::npos) continue;
      const double end = std::stod(tok.substr(colon + 1));
      phones.push_back({tok.substr(0, colon), prev});
      prev = end;
    }
    AlignCase c{"flite " + voice + " " + tag + std::to_string(i), "en", s[i], wav, {}, {}, {}};
    for (std::size_t k = 0; k < phones.size(); ++k)
      c.phones.push_back({phones[k].first, phones[k].second,
                          k + 1 < phones.size() ? phones[k + 1].second : prev, ""});
    add_true_visemes(c);
    std::size_t at = 0;
    for (const std::string& w : word_tokens(s[i])) {
      std::istringstream one(
          run_capture("flite -voice " + voice + setf + " -t '" + w + "' -o none -ps"));
      std::size_t count = 0;
      for (std::string p; one >> p;) count += p != "pau";
      while (at < phones.size() && phones[at].first == "pau") ++at;
      if (at >= phones.size()) break;
      c.onsets.push_back(phones[at].second);
      at += count;
    }
    cases.push_back(std::move(c));
  }
  return cases;
}

// One Chinese case: espeak-ng through facecast (true word onsets from its events) with `voice` at
// `speed`, then sox: pitch shift, three pieces stretched by `tempo`, reverb, pink noise.
inline AlignCase chinese_case(const std::filesystem::path& dir, std::size_t i,
                              const std::string& voice, int speed, int cents,
                              const double (&tempo)[3]) {
  viseme::Options o;
  o.timing = viseme::Timing::kTts;
  o.zh_voice = voice;
  o.espeak_speed = speed;
  o.set = viseme::VisemeSet::kOculus;  // the true visemes for the audio-only benchmark
  const std::string text = chinese_sentences()[i];
  const viseme::Utterance u = viseme::analyze(text, o);
  const std::string base = (dir / ("zh" + std::to_string(i))).string();
  {
    std::ofstream f(base + "_src.wav", std::ios::binary);
    f << facecast::encode_wav(u.pcm, u.sample_rate);
  }
  const double total = u.duration;
  const double cut[4] = {0, total / 3, 2 * total / 3, total};
  double out_start[3], scale[3], at = 0;
  std::string pieces;
  for (int k = 0; k < 3; ++k) {
    const std::string p = base + "_p" + std::to_string(k) + ".wav";
    run_capture("sox -R " + base + "_src.wav " + p + " trim " + std::to_string(cut[k]) + " =" +
                std::to_string(cut[k + 1]) + " tempo -s " + std::to_string(tempo[k]));
    const double len = std::stod(run_capture("soxi -D " + p));
    out_start[k] = at;
    scale[k] = len / (cut[k + 1] - cut[k]);
    at += len;
    pieces += p + " ";
  }
  run_capture("sox -R " + pieces + base + "_cat.wav pitch " + std::to_string(cents) + " reverb 35");
  run_capture("sox -R -n -r " + std::to_string(u.sample_rate) + " -c 1 " + base +
              "_noise.wav synth " + std::to_string(at + 1) + " pinknoise vol 0.015");
  const std::string out = base + ".wav";
  run_capture("sox -R -m " + base + "_cat.wav " + base + "_noise.wav " + out + " trim 0 " +
              std::to_string(at + 0.3));
  AlignCase c{"espeak " + voice + " " + std::to_string(speed) + " " + std::to_string(i),
              "zh",
              text,
              out,
              {},
              {},
              {}};
  const auto map = [&](double t) {
    const int k = t < cut[1] ? 0 : t < cut[2] ? 1 : 2;
    return out_start[k] + (t - cut[k]) * scale[k];
  };
  for (const auto& w : u.words) c.onsets.push_back(map(w.start));
  for (const auto& p : u.phones) c.phones.push_back({p.phone, map(p.start), map(p.end), p.lang});
  for (const auto& v : u.visemes) c.visemes.push_back({v.viseme, map(v.start), map(v.end), 1});
  return c;
}

inline std::vector<AlignCase> chinese_cases(const std::filesystem::path& dir) {
  const std::string voices[] = {"cmn-latn-pinyin+f3", "cmn-latn-pinyin+m3", "cmn-latn-pinyin+f1"};
  const int speeds[] = {140, 210, 170};
  const int cents[] = {250, -300, 120};
  const double tempi[][3] = {{0.8, 1.25, 0.95}, {1.2, 0.85, 1.1}, {0.9, 1.15, 0.75}};
  std::vector<AlignCase> out;
  for (std::size_t i = 0; i < chinese_sentences().size(); ++i)
    out.push_back(chinese_case(dir, i, voices[i % 3], speeds[i % 3], cents[i % 3], tempi[i % 3]));
  return out;
}

/// festival, flite and Chinese cases made in `dir` (created), for the benchmarks.
inline std::vector<AlignCase> all_cases(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::vector<AlignCase> cases = festival_cases(dir);
  for (auto& c : flite_cases(dir)) cases.push_back(std::move(c));
  for (auto& c : chinese_cases(dir)) cases.push_back(std::move(c));
  return cases;
}

/// |aligned - true| word onsets, seconds; words matched in order (English by spelling, Chinese by
/// the shared segmentation). Throws when the word counts differ.
inline std::vector<double> onset_errors(const viseme::Utterance& u, const AlignCase& c) {
  if (u.words.size() != c.onsets.size())
    throw std::runtime_error(c.name + ": " + std::to_string(u.words.size()) + " words aligned, " +
                             std::to_string(c.onsets.size()) + " true");
  std::vector<double> e;
  for (std::size_t i = 0; i < u.words.size(); ++i)
    e.push_back(std::abs(u.words[i].start - c.onsets[i]));
  return e;
}

/// |aligned - true| phone onsets, seconds. Chinese: the same front end on both sides, so phone i
/// matches phone i. English: festival's and flite's phones are not espeak-ng's, so phones are
/// compared inside each word only where both sides have the same number of them (`compared` counts
/// the true phones that were; the rest are left out).
inline std::vector<double> phone_onset_errors(const viseme::Utterance& u, const AlignCase& c,
                                              std::size_t* compared = nullptr) {
  std::vector<double> e;
  const auto spoken = [](const std::vector<viseme::Phone>& v) {
    std::vector<viseme::Phone> out;
    for (const auto& p : v)
      if (p.phone != "pau" && p.end > p.start) out.push_back(p);
    return out;
  };
  const auto truth = spoken(c.phones), mine = spoken(u.phones);
  if (c.lang == "zh") {
    if (truth.size() == mine.size())
      for (std::size_t i = 0; i < truth.size(); ++i)
        e.push_back(std::abs(mine[i].start - truth[i].start));
  } else {
    for (std::size_t w = 0; w < c.onsets.size() && w < u.words.size(); ++w) {
      const double t0 = c.onsets[w], t1 = w + 1 < c.onsets.size() ? c.onsets[w + 1] : 1e9;
      const double m0 = u.words[w].start, m1 = u.words[w].end;
      std::vector<double> a, b;
      for (const auto& p : truth)
        if (p.start >= t0 - 1e-6 && p.start < t1 - 1e-6) a.push_back(p.start);
      for (const auto& p : mine)
        if (p.start >= m0 - 1e-6 && p.start < m1 - 1e-6) b.push_back(p.start);
      if (a.size() == b.size())
        for (std::size_t i = 0; i < a.size(); ++i) e.push_back(std::abs(a[i] - b[i]));
    }
  }
  if (compared) *compared += e.size();
  return e;
}

}  // namespace facecast::test
