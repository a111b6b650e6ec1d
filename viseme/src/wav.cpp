#include "facecast/viseme/wav.hpp"

namespace facecast::viseme {
namespace {

void put(std::string& out, std::uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}

}  // namespace

std::string encode_wav(const std::vector<int16_t>& pcm, int sample_rate) {
  const auto data_bytes = static_cast<std::uint32_t>(pcm.size() * 2);
  std::string out;
  out.reserve(44 + data_bytes);
  out += "RIFF";
  put(out, 36 + data_bytes, 4);
  out += "WAVEfmt ";
  put(out, 16, 4);  // fmt chunk size
  put(out, 1, 2);   // PCM
  put(out, 1, 2);   // mono
  put(out, static_cast<std::uint32_t>(sample_rate), 4);
  put(out, static_cast<std::uint32_t>(sample_rate) * 2, 4);  // byte rate
  put(out, 2, 2);                                            // block align
  put(out, 16, 2);                                           // bits per sample
  out += "data";
  put(out, data_bytes, 4);
  for (int16_t s : pcm) put(out, static_cast<std::uint16_t>(s), 2);
  return out;
}

}  // namespace facecast::viseme
