#include "facecast/core/wav.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "facecast/core/error.hpp"

namespace facecast {
namespace {

void put(std::string& out, std::uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}

std::uint32_t get(std::string_view in, size_t at, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i)
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(in[at + i])) << (8 * i);
  return v;
}

}  // namespace

Pcm decode_wav(std::string_view in, std::string_view source) {
  const auto fail = [&](const std::string& why) { return Error(std::string(source) + ": " + why); };
  if (in.size() < 12 || in.substr(0, 4) != "RIFF" || in.substr(8, 4) != "WAVE")
    throw fail("not a RIFF/WAVE file");
  int format = 0, channels = 0, bits = 0;
  Pcm out;
  for (size_t at = 12; at + 8 <= in.size();) {
    const std::string_view id = in.substr(at, 4);
    const std::uint32_t size = get(in, at + 4, 4);
    const size_t body = at + 8;
    if (id == "fmt ") {
      if (size < 16 || body + 16 > in.size()) throw fail("truncated fmt chunk");
      format = static_cast<int>(get(in, body, 2));
      channels = static_cast<int>(get(in, body + 2, 2));
      out.sample_rate = static_cast<int>(get(in, body + 4, 4));
      bits = static_cast<int>(get(in, body + 14, 2));
      if (format == 0xFFFE && size >= 26) format = static_cast<int>(get(in, body + 24, 2));
    } else if (id == "data") {
      if (channels < 1 || out.sample_rate < 1) throw fail("data chunk before a valid fmt chunk");
      const bool pcm16 = format == 1 && bits == 16, float32 = format == 3 && bits == 32;
      if (!pcm16 && !float32)
        throw fail("unsupported encoding (format " + std::to_string(format) + ", " +
                   std::to_string(bits) + " bits); use PCM16 or float32");
      const size_t frame = static_cast<size_t>(channels) * (bits / 8);
      const size_t avail = std::min<size_t>(size, in.size() - body);
      if (avail < size && avail % frame != 0) throw fail("truncated data chunk");
      const size_t frames = avail / frame;
      out.samples.resize(frames);
      for (size_t f = 0; f < frames; ++f) {
        double sum = 0;
        for (int c = 0; c < channels; ++c) {
          const size_t p = body + f * frame + static_cast<size_t>(c) * (bits / 8);
          if (pcm16) {
            sum += static_cast<int16_t>(get(in, p, 2));
          } else {
            const std::uint32_t u = get(in, p, 4);
            float v;
            std::memcpy(&v, &u, 4);
            sum += std::isfinite(v) ? std::clamp(v, -1.0f, 1.0f) * 32767.0 : 0.0;
          }
        }
        out.samples[f] = static_cast<int16_t>(std::lround(sum / channels));
      }
      return out;
    }
    at = body + size + (size & 1);
  }
  throw fail("no data chunk");
}

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

}  // namespace facecast
