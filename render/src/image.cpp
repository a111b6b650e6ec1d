// Images: PNG and WebP decoded here (libpng, libwebp), everything else through OpenImageIO in the
// module image_codec.hpp describes, loaded on first use.
#include "facecast/render/image.hpp"

#include <dlfcn.h>
#include <png.h>
#include <webp/decode.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/install.hpp"
#include "facecast/rig/rig.hpp"
#include "image_codec.hpp"

namespace facecast::render {
namespace {

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

// The OpenImageIO module: <prefix>/lib/facecast/ in an installed Facecast, else this build's
// (FACECAST_IMAGE_MODULE, set by render/CMakeLists.txt).
const detail::ImageCodec& codec() {
  static const detail::ImageCodec* const loaded = [] {
    const auto share = installed_share_dir();
    const std::string path =
        share.empty()
            ? std::string(FACECAST_IMAGE_MODULE)
            : (share.parent_path().parent_path() / "lib" / "facecast" / "facecast_image_oiio.so")
                  .string();
    void* module = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!module)
      throw Error("image support (OpenImageIO) cannot be loaded: " + one_line(dlerror()),
                  ErrorCode::kInternal);
    using Entry = const detail::ImageCodec* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(module, "facecast_image_codec"));
    const detail::ImageCodec* table = entry ? entry() : nullptr;
    if (!table || table->version != detail::ImageCodec::kVersion)
      throw Error(path + ": not this build's image module", ErrorCode::kInternal);
    return table;
  }();
  return *loaded;
}

void check_image(const Image& image, std::string_view what) {
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * image.height * image.channels)
    throw Error(std::string(what) + ": image has inconsistent size");
}

// Encodes with the OpenImageIO writer for `format_name` (a file name whose extension selects it).
std::string encode(const Image& image, const std::string& format_name, int quality,
                   bool linear_half) {
  check_image(image, format_name);
  std::vector<float> linear;
  if (linear_half) {
    linear.resize(image.pixels.size());
    for (std::size_t i = 0; i < linear.size(); ++i)
      linear[i] = rig::srgb_to_linear(image.pixels[i] / 255.0f);
  }
  std::string out;
  detail::Failure failure;
  if (!codec().encode(image, linear_half ? linear.data() : nullptr, format_name.c_str(), quality,
                      out, failure))
    throw Error(failure.message, failure.code);
  return out;
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// PNG through libpng's simplified API, into RGBA (8-bit sRGB whatever the file's depth, palette or
// gamma). Not through OpenImageIO: its PNG reader leaks its error message on every truncated image
// (libpng's longjmp skips the string's destructor), which an upload could repeat without end.
Image decode_png(std::string_view bytes, const std::string& name, int max_side) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
    throw Error(name + ": cannot decode: " + one_line(png.message));
  if (png.width < 1 || png.height < 1 || png.width > static_cast<png_uint_32>(max_side) ||
      png.height > static_cast<png_uint_32>(max_side)) {
    png_image_free(&png);
    throw Error(name + ": PNG image of " + std::to_string(png.width) + "x" +
                    std::to_string(png.height) + " is out of range (at most " +
                    std::to_string(max_side) + " a side)",
                ErrorCode::kLimit);
  }
  png.format = PNG_FORMAT_RGBA;
  Image img{static_cast<int>(png.width), static_cast<int>(png.height), 4, {}};
  img.pixels.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, img.pixels.data(), 0, nullptr)) {
    const std::string why = png.message;
    png_image_free(&png);
    throw Error(name + ": cannot decode: " + one_line(why));
  }
  return img;
}

// WebP through libwebp, into RGBA. Animated WebP (an avatar texture never is) is refused.
Image decode_webp(std::string_view bytes, const std::string& name, int max_side) {
  const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data());
  WebPBitstreamFeatures features;
  if (WebPGetFeatures(data, bytes.size(), &features) != VP8_STATUS_OK)
    throw Error(name + ": cannot decode: malformed WebP");
  if (features.width < 1 || features.height < 1 || features.width > max_side ||
      features.height > max_side)
    throw Error(name + ": WebP image of " + std::to_string(features.width) + "x" +
                    std::to_string(features.height) + " is out of range (at most " +
                    std::to_string(max_side) + " a side)",
                ErrorCode::kLimit);
  if (features.has_animation)
    throw Error(name + ": animated WebP is not a texture", ErrorCode::kUnsupported);
  Image img{features.width, features.height, 4, {}};
  img.pixels.resize(static_cast<std::size_t>(img.width) * img.height * 4);
  if (!WebPDecodeRGBAInto(data, bytes.size(), img.pixels.data(), img.pixels.size(), img.width * 4))
    throw Error(name + ": cannot decode: corrupt WebP data");
  return img;
}

}  // namespace

std::string encode_jpeg(const Image& image, int quality) {
  if (image.channels == 4) {  // JPEG has no alpha
    Image rgb{image.width, image.height, 3, {}};
    rgb.pixels.reserve(static_cast<std::size_t>(image.width) * image.height * 3);
    for (std::size_t i = 0; i < image.pixels.size(); i += 4)
      rgb.pixels.insert(rgb.pixels.end(), image.pixels.begin() + static_cast<std::ptrdiff_t>(i),
                        image.pixels.begin() + static_cast<std::ptrdiff_t>(i + 3));
    return encode(rgb, "frame.jpg", quality, false);
  }
  return encode(image, "frame.jpg", quality, false);
}

std::string encode_png(const Image& image) {
  return encode(image, "frame.png", 0, false);
}

void write_image(const std::filesystem::path& path, const Image& image, int jpeg_quality) {
  const std::string ext = lower_extension(path);
  std::string bytes;
  if (ext == ".png") {
    bytes = encode_png(image);
  } else if (ext == ".jpg" || ext == ".jpeg") {
    bytes = encode_jpeg(image, jpeg_quality);
  } else if (ext == ".exr") {
    bytes = encode(image, "frame.exr", 0, true);
  } else {
    throw Error(
        path.string() + ": unsupported image extension '" + ext + "' (use .png, .jpg or .exr)",
        ErrorCode::kUnsupported);
  }
  write_file_atomic(path, bytes);
}

Image decode_image(std::string_view bytes, std::string_view what, const rig::DecodeLimits& limits) {
  const std::string name(what);
  const int max_side = limits.max_image_side;
  // The format from the signature: the name an avatar gives an image need not have an extension.
  const bool png =
      bytes.size() >= 8 && bytes.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8);
  const bool jpeg = bytes.size() >= 3 && bytes.substr(0, 3) == std::string_view("\xff\xd8\xff", 3);
  const bool webp =
      bytes.size() >= 12 && bytes.substr(0, 4) == "RIFF" && bytes.substr(8, 4) == "WEBP";
  if (bytes.size() >= 12 && bytes.substr(0, 12) == std::string_view("\xabKTX 20\xbb\r\n\x1a\n", 12))
    throw Error(name + ": " + std::string(rig::kNoKtx2Decoder), ErrorCode::kUnsupported);
  if (!png && !jpeg && !webp)
    throw Error(name + ": not a PNG, JPEG or WebP image", ErrorCode::kUnsupported);
  (void)rig::check_image(bytes, what, limits);  // the header's size, before any decoder runs
  if (webp) return decode_webp(bytes, name, max_side);
  if (png) return decode_png(bytes, name, max_side);
  Image img;
  detail::Failure failure;
  if (!codec().decode(bytes, "image.jpg", max_side, img, failure))
    throw Error(name + ": " + failure.message, failure.code);
  return img;
}

Image read_image(const std::filesystem::path& path, const rig::DecodeLimits& limits) {
  // PNG, JPEG and WebP headers are read by us before OpenImageIO opens the file (some of its
  // readers allocate per image on open); other formats' sizes from the header OpenImageIO read.
  {
    std::string head;
    try {
      head = read_file(path);
    } catch (const Error&) {
    }
    (void)rig::check_image(head, path.string(), limits);
  }
  Image img;
  detail::Failure failure;
  if (!codec().read(path.c_str(), limits.max_image_side, limits.max_image_bytes, img, failure))
    throw Error(path.string() + ": " + failure.message, failure.code);
  return img;
}

bool draw_text(Image& image, int x, int y, std::string_view text, int size,
               const std::array<float, 3>& colour, const std::string& font) {
  check_image(image, "draw_text");
  return codec().draw_text(image, x, y, text, size, colour.data(), font.c_str());
}

ImageDifference compare_images(const Image& a, const Image& b, int threshold) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw Error("compare_images: sizes differ (" + std::to_string(a.width) + "x" +
                std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                std::to_string(b.height) + ")");
  ImageDifference d;
  std::size_t over = 0;
  double sum = 0;
  const std::size_t n = static_cast<std::size_t>(a.width) * a.height;
  for (std::size_t p = 0; p < n; ++p) {
    int worst = 0;
    for (int c = 0; c < a.channels; ++c) {
      const int diff =
          std::abs(int(a.pixels[p * a.channels + c]) - int(b.pixels[p * a.channels + c]));
      sum += diff;
      worst = std::max(worst, diff);
    }
    d.max_abs = std::max(d.max_abs, worst);
    if (worst > threshold) ++over;
  }
  d.mean_abs = sum / static_cast<double>(n * a.channels);
  d.fraction_over = static_cast<double>(over) / static_cast<double>(n);
  return d;
}

}  // namespace facecast::render
