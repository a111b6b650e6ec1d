// libFuzzer target: the MPEG-4 FAP file parser; what it accepts must write and parse again.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/anim/fap.hpp"
#include "facecast/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace a = facecast::anim;
  a::FapLimits limits;
  limits.max_frames = 4096;  // the fuzzer's memory limit; the bound itself is what is tested
  a::FapSequence s;
  try {
    s = a::parse_fap(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz", limits);
  } catch (const facecast::Error&) {
    return 0;
  }
  const a::FapSequence again = a::parse_fap(a::to_fap_text(s), "again", limits);
  if (again.frames.size() != s.frames.size()) __builtin_trap();
  return 0;
}
