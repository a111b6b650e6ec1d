#pragma once
// 8-bit sRGB images and their files, through OpenImageIO: PNG, JPEG and EXR files, JPEG and PNG
// encoded to memory (for streaming), reading back and comparing (golden-image tests).
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/rig/decode_limits.hpp"

namespace facecast::render {

/// Interleaved 8-bit sRGB pixels, rows from top to bottom.
struct Image {
  int width = 0, height = 0, channels = 3;
  std::vector<std::uint8_t> pixels;  // width * height * channels
  /// A photo's lens as its EXIF FocalLengthIn35mmFilm gives it, mm on a 36 x 24 mm frame (0:
  /// unknown). Read by read_photo and decode_photo (JPEG), written into JPEGs when set.
  double focal_35mm = 0;

  std::uint8_t at(int x, int y, int c) const {
    return pixels[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }
};

/// Writes by extension: .png, .jpg/.jpeg (quality 1..100) or .exr (linear half floats, converted
/// from sRGB). Atomic: a failure leaves no partial file. Throws facecast::Error naming the path.
void write_image(const std::filesystem::path& path, const Image& image, int jpeg_quality = 90);

/// JPEG / PNG bytes in memory.
std::string encode_jpeg(const Image& image, int quality = 85);
std::string encode_png(const Image& image);

/// Reads any format OpenImageIO knows, as 8-bit with 3 channels (alpha dropped, grey expanded).
/// The size the header declares is checked against `limits` (max_image_side, max_image_bytes)
/// before anything is decoded.
Image read_image(const std::filesystem::path& path, const rig::DecodeLimits& limits = {});

/// Decodes PNG or JPEG bytes (a texture embedded in an avatar, a photo upload) as 8-bit RGBA,
/// refusing images over `limits` (max_image_side, max_image_bytes) from their header, before
/// decoding. Throws facecast::Error naming `what`.
Image decode_image(std::string_view bytes, std::string_view what,
                   const rig::DecodeLimits& limits = {});

/// The stored pixels turned and mirrored as an EXIF Orientation tag (1-8) says they are shown:
/// 6 and 8 are a phone's portraits stored sideways. Other values leave the image as it is.
Image apply_orientation(Image image, int orientation);

/// The image scaled by `scale` (0 < scale <= 1; the size rounded) with a box filter: each output
/// pixel is the mean of the source pixels it covers.
Image scale_down(const Image& image, double scale);

/// A photo as viewers and browsers show it: read like read_image (a file) or decode_image (bytes),
/// as 3-channel RGB, turned upright by its EXIF Orientation tag (JPEG's), with its EXIF 35-mm
/// focal length (Image::focal_35mm; a value outside 1..5000 mm is ignored).
Image read_photo(const std::filesystem::path& path, const rig::DecodeLimits& limits = {});
Image decode_photo(std::string_view bytes, std::string_view what,
                   const rig::DecodeLimits& limits = {});

struct ImageDifference {
  double mean_abs = 0;       // mean absolute channel difference, 0..255
  double fraction_over = 0;  // fraction of pixels with a channel differing by more than threshold
  int max_abs = 0;           // largest channel difference
};
/// Compares two images of the same size (throws facecast::Error otherwise).
ImageDifference compare_images(const Image& a, const Image& b, int threshold = 32);

}  // namespace facecast::render
