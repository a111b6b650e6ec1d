// libFuzzer target: the tagged-text parser and the whole text front-end with the duration model.
// Build with -DFACECAST_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++; run ./fuzz_text -max_total_time=60
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/text.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    (void)facecast::viseme::parse_text(text);
    if (size < 400) (void)facecast::viseme::analyze(text);
  } catch (const facecast::Error&) {
    // user errors are expected; anything else (crash, other exception) is a bug
  }
  return 0;
}
