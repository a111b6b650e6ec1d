// libFuzzer target: the image decoder that photo uploads and avatar textures reach (PNG through
// libpng, WebP through libwebp, JPEG through OpenImageIO, KTX2 refused), after the header check
// it starts with, and a photo's turn by its EXIF orientation (decode_photo: decode_image, then
// the tag OpenImageIO read from the JPEG's Exif segment).
// Anything but facecast::Error is a bug; a decoded image must have the size its header promised.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  facecast::rig::DecodeLimits limits;
  limits.max_image_side = 1024;  // the fuzzer's memory limit; the bound itself is what is tested
  limits.max_image_bytes = std::size_t{1024} * 1024 * 4;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const facecast::render::Image img = facecast::render::decode_photo(bytes, "fuzz", limits);
    if (img.width < 1 || img.height < 1 || img.width > limits.max_image_side ||
        img.height > limits.max_image_side || img.channels != 3 ||
        img.pixels.size() != static_cast<std::size_t>(img.width) * img.height * 3)
      __builtin_trap();
  } catch (const facecast::Error&) {
  }
  return 0;
}
