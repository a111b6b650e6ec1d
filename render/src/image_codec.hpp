#pragma once
// What OpenImageIO does for Facecast, behind one table of functions in a module of its own
// (facecast_image_oiio.so), loaded the first time an image needs it. Debian's OpenImageIO brings
// 261 shared libraries (OpenVDB, libheif, ffmpeg, gdcm, ...) whose symbol binding took 0.3 s at
// the start of every process, most of which never touch an image (docs/algorithms.md#images).
//
// The module and its callers are built by the same compiler in the same tree: C++ types cross the
// boundary, exceptions do not (a failure comes back as false and a Failure, which the caller
// throws).
#include <cstddef>
#include <string>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"

namespace facecast::render::detail {

/// A one-line message and its error code.
struct Failure {
  std::string message;
  ErrorCode code = ErrorCode::kInvalidInput;
};

struct ImageCodec {
  /// Bumped with any change below: a stale module from another build is refused.
  static constexpr int kVersion = 1;
  int version = kVersion;

  /// Encodes to the format `format_name` names by its extension (frame.jpg, frame.png,
  /// frame.exr) into `out`. `linear` (width * height * channels floats) replaces the pixels and
  /// is written as half floats; `quality` > 0 sets the JPEG quality.
  bool (*encode)(const Image& image, const float* linear, const char* format_name, int quality,
                 std::string& out, Failure& failure) = nullptr;

  /// Decodes an image held in memory (`file_name` names its format) into RGBA; sizes over
  /// `max_side` a side are refused after the header, before the pixels.
  bool (*decode)(std::string_view bytes, const char* file_name, int max_side, Image& out,
                 Failure& failure) = nullptr;

  /// Reads a file of any format OpenImageIO knows into 8-bit RGB (floats taken as linear and
  /// encoded to sRGB), refused after its header when over `max_side` a side or `max_bytes` of
  /// pixels.
  bool (*read)(const char* path, int max_side, std::size_t max_bytes, Image& out,
               Failure& failure) = nullptr;

  /// Draws `text` in the TrueType font `font` with its baseline's left end at (x, y) on an 8-bit
  /// image; false when no font could be used.
  bool (*draw_text)(Image& image, int x, int y, std::string_view text, int size, const float* rgb,
                    const char* font) = nullptr;
};

}  // namespace facecast::render::detail

/// The module's one exported symbol.
extern "C" const facecast::render::detail::ImageCodec* facecast_image_codec();
