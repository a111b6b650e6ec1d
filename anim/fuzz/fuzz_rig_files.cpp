// libFuzzer target: the avatar file parsers that uploads reach (GLB through tinygltf, OBJ).
// Build with -DFACECAST_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++; run
//   ./fuzz_glb -max_total_time=600 -rss_limit_mb=2048   (and ./fuzz_obj the same way)
// FACECAST_FUZZ_FORMAT picks the parser (1: GLB, 2: OBJ). Anything but
// facecast::Error (a crash, a sanitizer report, another exception, running out of memory on a
// declared size) is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/anim/rig_io.hpp"
#include "facecast/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
#if FACECAST_FUZZ_FORMAT == 1
    const auto rig = facecast::anim::parse_glb(bytes, "fuzz.glb");
    (void)facecast::anim::glb_bytes(rig);  // what was read writes back
#else
    const auto rig = facecast::anim::parse_obj(bytes, "fuzz.obj");
    (void)facecast::anim::glb_bytes(rig);
#endif
  } catch (const facecast::Error&) {
  }
  return 0;
}
