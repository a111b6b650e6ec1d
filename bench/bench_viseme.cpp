// bench_viseme: the viseme engine's speed.
//  - first call: loading configs/viseme and the Chinese lexicon cache
//  - loading the English lexicon (pocketsphinx-en-us's CMU dictionary): time and memory
//  - a 1,000-character Chinese paragraph with the duration model (target <= 10 ms)
//  - espeak-ng timing (synthesis with phoneme events), Chinese and English (target >= 20x real
//  time)
//  - the English lexicon's effect on espeak-ng timing: ten sentences with it on and off (speech
//    length, mean difference of a word's duration, words it speaks otherwise)
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <string>

#include "en_lexicon.hpp"
#include "facecast/viseme/viseme.hpp"
#include "plan.hpp"

namespace v = facecast::viseme;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::size_t han_count(const std::string& s) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) n += (static_cast<unsigned char>(s[i]) & 0xF0) == 0xE0;
  return n;
}

// A news-style paragraph about the product (numbers, polyphones, punctuation), repeated to
// 1,000 Han characters.
std::string paragraph(std::size_t han) {
  const std::string base =
      "今天，我们在北京举行了新产品的发布会。这款虚拟主播可以根据文字实时生成口型和表情，"
      "让观众感觉像是在和真人交流。银行行长、学校老师和电视台的主持人都来到了现场，"
      "大家对这项技术的发展前景非常看好。据统计，去年全国有超过三千家公司开始使用数字人，"
      "市场规模增长了将近一倍。研发团队表示，他们还会继续改进语音合成和面部动画的质量，"
      "重新设计整个系统的架构，使它在普通电脑上也能流畅运行。";
  std::string out;
  while (han_count(out) < han) out += base;
  // Trim to exactly `han` Han characters (every Han character here is 3 UTF-8 bytes).
  std::string trimmed;
  std::size_t n = 0;
  for (std::size_t i = 0; i < out.size() && n < han;) {
    const bool h = (static_cast<unsigned char>(out[i]) & 0xF0) == 0xE0;
    const std::size_t len = h ? 3 : 1;
    // punctuation like "，" is also 3 bytes: count only CJK ideographs (first byte E4-E9)
    const auto b = static_cast<unsigned char>(out[i]);
    if (h && b >= 0xE4 && b <= 0xE9) ++n;
    trimmed.append(out, i, len);
    i += len;
  }
  return trimmed;
}

}  // namespace

int main() {
  std::cout << std::fixed << std::setprecision(2);
  auto t0 = Clock::now();
  (void)v::to_pinyin("银行");
  std::cout << "first call (configs + Chinese lexicon cache load): " << ms_since(t0) << " ms\n";
  {
    namespace d = facecast::viseme::detail;
    t0 = Clock::now();
    const d::EnglishLexicon lex = d::EnglishLexicon::load(d::EnglishLexicon::default_path());
    std::cout << "English lexicon load (" << d::EnglishLexicon::default_path().string()
              << "): " << ms_since(t0) << " ms, " << lex.size() << " pronunciations in "
              << static_cast<double>(lex.memory_bytes()) / (1 << 20) << " MiB\n";
  }

  const std::string zh = paragraph(1000);
  std::size_t syllables = 0;
  double best = 1e9, total = 0;
  const int runs = 30;
  for (int i = 0; i < runs; ++i) {
    t0 = Clock::now();
    const v::Utterance u = v::analyze(zh);
    const double t = ms_since(t0);
    best = std::min(best, t);
    total += t;
    syllables = u.syllables.size();
  }
  std::cout << "duration model, 1,000-character Chinese paragraph (" << syllables
            << " syllables): mean " << total / runs << " ms, best " << best
            << " ms  (target <= 10 ms)\n";

  const std::string en =
      "Today we are launching Facecast, a speech driven avatar server. It turns text and "
      "expression tags into visemes, blends them into blendshape weights, and streams them to "
      "browsers in real time. The first customers are virtual hosts, teachers and news readers.";
  v::Options tts;
  tts.timing = v::Timing::kTts;
  for (const auto& [name, text] :
       {std::pair<const char*, std::string>{"Chinese", zh}, {"English", en}}) {
    t0 = Clock::now();
    const v::Utterance u = v::analyze(text, tts);
    const double t = ms_since(t0);
    std::cout << "espeak-ng timing, " << name << ": " << u.duration << " s of speech in " << t
              << " ms = " << u.duration * 1000.0 / t << "x real time  (target >= 20x)\n";
  }

  const char* sentences[] = {
      "Hello world, this is a test of the speech system.",
      "The quick brown fox jumps over the lazy dog.",
      "Please call Stella and ask her to bring these things with her from the store.",
      "Six spoons of fresh snow peas, five thick slabs of blue cheese, and maybe a snack for her "
      "brother Bob.",
      "We also need a small plastic snake and a big toy frog for the kids.",
      "She can scoop these things into three red bags, and we will go meet her Wednesday at the "
      "train station.",
      "Photography is not a crime, said the photographer to the police officer.",
      "Our company records show that the president read the report yesterday.",
      "I would like to thank everybody who came to the conference in Pittsburgh.",
      "Artificial intelligence is changing how we work and communicate every day."};
  double on_s = 0, off_s = 0, word_diff = 0;
  std::size_t words = 0, respoken = 0;
  for (const char* s : sentences) {
    v::Options o = tts;
    o.lang = v::LangMode::kEn;
    const v::Utterance on = v::analyze(s, o);
    for (const auto& u : facecast::viseme::detail::make_plan(s, o).units)
      respoken += !u.spoken.empty();
    o.english_lexicon = false;
    const v::Utterance off = v::analyze(s, o);
    on_s += on.duration;
    off_s += off.duration;
    for (std::size_t w = 0; w < on.words.size() && w < off.words.size(); ++w, ++words)
      word_diff +=
          std::abs((on.words[w].end - on.words[w].start) - (off.words[w].end - off.words[w].start));
  }
  std::cout << "espeak-ng timing, ten English sentences, the English lexicon on / off: " << on_s
            << " / " << off_s << " s of speech (" << 100 * (on_s / off_s - 1)
            << " %), a word's duration " << 1000 * word_diff / static_cast<double>(words)
            << " ms apart on average; " << respoken << " of " << words
            << " words spoken from the lexicon\n";
  return 0;
}
