#pragma once
// Human English speech with hand-labelled word onsets (tests/viseme/eval/human_words.tsv: how
// they were labelled, and how precisely, is in its header) for the alignment test and
// bench/bench_align. The recordings come from Debian packages (alsa-utils,
// pocketsphinx-testdata) installed by scripts/install-deps.sh; pocketsphinx's .raw files are
// 16 kHz 16-bit little-endian mono without a header.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "align_cases.hpp"
#include "facecast/viseme/audio.hpp"

namespace facecast::test {

inline const std::filesystem::path kPocketsphinxTestData = "/usr/share/pocketsphinx/test/data";

/// The labelled recordings as AlignCases (lang "en", name "human <file>"); an unscored word's
/// onset is NaN. `audio` is an absolute path.
inline std::vector<AlignCase> human_cases(const std::filesystem::path& tsv) {
  std::ifstream in(tsv);
  if (!in) throw std::runtime_error("cannot read " + tsv.string());
  std::vector<AlignCase> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    std::string file, word, onset;
    std::getline(f, file, '\t');
    std::getline(f, word, '\t');
    std::getline(f, onset, '\t');
    if (file.empty() || word.empty() || onset.empty())
      throw std::runtime_error(tsv.string() + ": bad line '" + line + "'");
    const std::string path = file[0] == '/' ? file : (kPocketsphinxTestData / file).string();
    if (out.empty() || out.back().audio != path) {
      AlignCase c;
      c.name = "human " + std::filesystem::path(file).filename().string();
      c.lang = "en";
      c.audio = path;
      out.push_back(std::move(c));
    }
    AlignCase& c = out.back();
    c.text += (c.text.empty() ? "" : " ") + word;
    c.onsets.push_back(onset == "-" ? std::numeric_limits<double>::quiet_NaN() : std::stod(onset));
  }
  return out;
}

/// The case's audio: WAV through read_audio, headerless .raw as 16 kHz 16-bit mono.
inline viseme::Audio human_audio(const AlignCase& c) {
  if (std::filesystem::path(c.audio).extension() != ".raw") return viseme::read_audio(c.audio);
  std::ifstream in(c.audio, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + c.audio);
  std::vector<int16_t> pcm;
  for (char b[2]; in.read(b, 2);)
    pcm.push_back(
        static_cast<int16_t>(static_cast<uint16_t>(static_cast<unsigned char>(b[0])) |
                             static_cast<uint16_t>(static_cast<unsigned char>(b[1])) << 8));
  return viseme::audio_from_pcm16(pcm, 16000);
}

/// `seconds` of faint noise (about -60 dBFS, as a quiet room records it) before and after the
/// audio; the case's true times move with it.
inline void pad_audio(viseme::Audio& audio, AlignCase& c, double seconds) {
  const auto n = static_cast<std::size_t>(seconds * audio.sample_rate);
  std::uint32_t state = 12345;
  const auto noise = [&] {
    state = state * 1664525u + 1013904223u;
    return 1.7e-3f * (static_cast<float>(state >> 8) / 8388608.0f - 1.0f);
  };
  std::vector<float> out;
  for (std::size_t i = 0; i < n; ++i) out.push_back(noise());
  out.insert(out.end(), audio.samples.begin(), audio.samples.end());
  for (std::size_t i = 0; i < n; ++i) out.push_back(noise());
  audio.samples = std::move(out);
  for (double& t : c.onsets) t += seconds;
  for (auto& p : c.phones) p.start += seconds, p.end += seconds;
}

/// |aligned - true| word onsets of the scored words, seconds.
inline std::vector<double> scored_onset_errors(const viseme::Utterance& u, const AlignCase& c) {
  if (u.words.size() != c.onsets.size())
    throw std::runtime_error(c.name + ": " + std::to_string(u.words.size()) + " words aligned, " +
                             std::to_string(c.onsets.size()) + " labelled");
  std::vector<double> e;
  for (std::size_t i = 0; i < u.words.size(); ++i)
    if (!std::isnan(c.onsets[i])) e.push_back(std::abs(u.words[i].start - c.onsets[i]));
  return e;
}

}  // namespace facecast::test
