#pragma once
// 16-bit mono PCM WAV encoding and decoding.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace facecast {

/// A complete RIFF/WAVE file (PCM16, mono) as bytes; write it with facecast::write_file_atomic.
std::string encode_wav(const std::vector<int16_t>& pcm, int sample_rate);

struct Pcm {
  std::vector<int16_t> samples;  // mono
  int sample_rate = 0;
};
/// Reads a RIFF/WAVE file's bytes: PCM 16-bit or float 32-bit, any channel count (averaged to
/// mono). Throws facecast::Error naming `source` and what is wrong (not RIFF, a missing chunk, an
/// unsupported encoding, a truncated data chunk).
Pcm decode_wav(std::string_view bytes, std::string_view source = "<wav>");

}  // namespace facecast
