#pragma once
// 16-bit mono PCM WAV encoding.
#include <cstdint>
#include <string>
#include <vector>

namespace facecast::viseme {

/// A complete RIFF/WAVE file (PCM16, mono) as bytes; write it with facecast::write_file_atomic.
std::string encode_wav(const std::vector<int16_t>& pcm, int sample_rate);

}  // namespace facecast::viseme
