// Images through OpenImageIO, encoded in memory (IOVecOutput) so that files are written atomically
// and JPEG frames can be streamed.
#include "facecast/render/image.hpp"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <png.h>
#include <webp/decode.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <utility>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::render {
namespace {

namespace OIIO = OIIO_NAMESPACE;

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
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
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create(format_name);
  if (!out)
    throw Error("no image writer for " + format_name + ": " + OIIO::geterror(),
                ErrorCode::kUnsupported);
  if (!out->supports("ioproxy"))
    throw Error("the " + std::string(out->format_name()) + " writer cannot write to memory",
                ErrorCode::kUnsupported);
  OIIO::ImageSpec spec(image.width, image.height, image.channels,
                       linear_half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
  if (quality > 0)
    spec.attribute("Compression", "jpeg:" + std::to_string(std::clamp(quality, 1, 100)));
  if (image.focal_35mm > 0)  // an EXIF SHORT, whole millimetres
    spec.attribute("Exif:FocalLengthIn35mmFilm", static_cast<int>(std::lround(image.focal_35mm)));
  if (!out->set_ioproxy(&proxy) || !out->open(format_name, spec))
    throw Error("cannot encode " + format_name + ": " + out->geterror(), ErrorCode::kInternal);
  bool ok = false;
  if (linear_half) {
    std::vector<float> lin(image.pixels.size());
    for (std::size_t i = 0; i < lin.size(); ++i)
      lin[i] = rig::srgb_to_linear(image.pixels[i] / 255.0f);
    ok = out->write_image(OIIO::TypeDesc::FLOAT, lin.data());
  } else {
    ok = out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data());
  }
  if (!ok || !out->close())
    throw Error("cannot encode " + format_name + ": " + out->geterror(), ErrorCode::kInternal);
  return std::string(bytes.begin(), bytes.end());
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// RGBA to RGB (alpha dropped).
Image rgb(Image image) {
  if (image.channels == 3) return image;
  Image out{image.width, image.height, 3, {}};
  out.pixels.resize(static_cast<std::size_t>(image.width) * image.height * 3);
  for (std::size_t p = 0, n = out.pixels.size() / 3; p < n; ++p)
    for (std::size_t c = 0; c < 3; ++c)
      out.pixels[p * 3 + c] =
          image.pixels[p * static_cast<std::size_t>(image.channels) +
                       std::min(c, static_cast<std::size_t>(image.channels) - 1)];
  return out;
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
  if (image.channels == 4) return encode(rgb(image), "frame.jpg", quality, false);  // no alpha
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

namespace {

// What a photo's EXIF says about how it is shown and taken.
struct Exif {
  int orientation = 1;    // the Orientation tag (1: as stored)
  double focal_35mm = 0;  // FocalLengthIn35mmFilm, mm (0: none, or outside 1..5000)
};

Exif exif_of(const OIIO::ImageSpec& spec) {
  Exif out;
  out.orientation = spec.get_int_attribute("Orientation", 1);
  const int focal = spec.get_int_attribute("Exif:FocalLengthIn35mmFilm", 0);
  if (focal >= 1 && focal <= 5000) out.focal_35mm = focal;
  return out;
}

// decode_image's body; `exif` gets a JPEG's (none for PNG and WebP, whose rare EXIF chunks are not
// read).
Image decode(std::string_view bytes, std::string_view what, const rig::DecodeLimits& limits,
             Exif& exif) {
  exif = {};
  const std::string name(what);
  const int max_side = limits.max_image_side;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
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
  OIIO::Filesystem::IOMemReader proxy(data, bytes.size());
  OIIO::ImageSpec config;
  const void* proxy_pointer = &proxy;  // the attribute holds the pointer's value
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_pointer);
  const std::string file = "image.jpg";
  auto in = OIIO::ImageInput::create(file, false, &config, &proxy);
  if (!in)
    throw Error(name + ": no image reader: " + one_line(OIIO::geterror()), ErrorCode::kInternal);
  OIIO::ImageSpec spec;
  if (!in->open(file, spec, config))
    throw Error(name + ": cannot decode: " + one_line(in->geterror()));
  if (spec.width < 1 || spec.height < 1 || spec.width > max_side || spec.height > max_side ||
      spec.nchannels < 1 || spec.nchannels > 4)
    throw Error(name + ": image of " + std::to_string(spec.width) + "x" +
                    std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) +
                    " is out of range (at most " + std::to_string(max_side) + " a side)",
                ErrorCode::kUnsupported);
  Image img{spec.width, spec.height, 4, {}};
  img.pixels.assign(static_cast<std::size_t>(spec.width) * spec.height * 4, 255);
  // Read the file's channels into the first ones of RGBA; grey is expanded below. On the calling
  // thread: renderers are made on worker threads already (and OIIO's own pool hides its writes
  // into our buffer from ThreadSanitizer).
  in->threads(1);
  exif = exif_of(spec);
  const OIIO::stride_t pixel = 4;
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, img.pixels.data(), pixel))
    throw Error(name + ": cannot decode: " + one_line(in->geterror()));
  if (spec.nchannels <= 2) {
    for (std::size_t i = 0; i < img.pixels.size(); i += 4) {
      const std::uint8_t g = img.pixels[i], a = spec.nchannels == 2 ? img.pixels[i + 1] : 255;
      img.pixels[i + 1] = img.pixels[i + 2] = g;
      img.pixels[i + 3] = a;
    }
  }
  return img;
}

// read_image's body; `exif` gets the file's (none where it has none).
Image read(const std::filesystem::path& path, const rig::DecodeLimits& limits, Exif& exif) {
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
  auto in = OIIO::ImageInput::open(path.string());
  if (!in)
    throw Error(path.string() + ": cannot read image: " + OIIO::geterror(), ErrorCode::kNotFound);
  const OIIO::ImageSpec& spec = in->spec();
  exif = exif_of(spec);
  const auto side = static_cast<long long>(limits.max_image_side);
  if (spec.width < 1 || spec.height < 1 || spec.width > side || spec.height > side ||
      spec.nchannels < 1 || spec.nchannels > 64 ||
      static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
              static_cast<std::size_t>(std::max(spec.nchannels, 4)) >
          limits.max_image_bytes)
    throw Error(path.string() + ": image of " + std::to_string(spec.width) + "x" +
                    std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) +
                    " is over the image limits (max_image_side " +
                    std::to_string(limits.max_image_side) + ", max_image_bytes " +
                    std::to_string(limits.max_image_bytes) + ")",
                ErrorCode::kLimit);
  const std::size_t count = static_cast<std::size_t>(spec.width) * spec.height;
  std::vector<std::uint8_t> raw(count * spec.nchannels);
  if (spec.format.basetype == OIIO::TypeDesc::FLOAT ||
      spec.format.basetype == OIIO::TypeDesc::HALF) {
    // Linear floats (EXR): encode to sRGB.
    std::vector<float> lin(raw.size());
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, lin.data()))
      throw Error(path.string() + ": " + in->geterror());
    for (std::size_t i = 0; i < lin.size(); ++i) {
      const float c = std::clamp(lin[i], 0.0f, 1.0f);
      const float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
      raw[i] = static_cast<std::uint8_t>(std::lround(e * 255.0f));
    }
  } else if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, raw.data())) {
    throw Error(path.string() + ": " + in->geterror());
  }
  Image img{spec.width, spec.height, 3, {}};
  img.pixels.resize(count * 3);
  for (std::size_t p = 0; p < count; ++p)
    for (int c = 0; c < 3; ++c)
      img.pixels[p * 3 + c] = raw[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
  return img;
}

}  // namespace

Image decode_image(std::string_view bytes, std::string_view what, const rig::DecodeLimits& limits) {
  Exif exif;
  return decode(bytes, what, limits, exif);
}

Image read_image(const std::filesystem::path& path, const rig::DecodeLimits& limits) {
  Exif exif;
  return read(path, limits, exif);
}

Image scale_down(const Image& image, double scale) {
  if (!(scale > 0 && scale <= 1)) throw Error("scale_down: scale must be in (0, 1]");
  const int w = std::max(1, static_cast<int>(std::lround(image.width * scale)));
  const int h = std::max(1, static_cast<int>(std::lround(image.height * scale)));
  const int n = image.channels;
  Image out{w, h, n, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * h * n)};
  out.focal_35mm = image.focal_35mm;  // the same angle of view
  const double step = 1.0 / scale;
  std::vector<int> sum(static_cast<std::size_t>(n));
  for (int y = 0; y < h; ++y) {
    const int y0 = static_cast<int>(y * step),
              y1 = std::min(std::max(y0 + 1, static_cast<int>((y + 1) * step)), image.height);
    for (int x = 0; x < w; ++x) {
      const int x0 = static_cast<int>(x * step),
                x1 = std::min(std::max(x0 + 1, static_cast<int>((x + 1) * step)), image.width);
      std::fill(sum.begin(), sum.end(), 0);
      int count = 0;
      for (int yy = y0; yy < y1; ++yy)
        for (int xx = x0; xx < x1; ++xx, ++count)
          for (int c = 0; c < n; ++c) sum[static_cast<std::size_t>(c)] += image.at(xx, yy, c);
      count = std::max(count, 1);
      for (int c = 0; c < n; ++c)
        out.pixels[(static_cast<std::size_t>(y) * w + x) * n + static_cast<std::size_t>(c)] =
            static_cast<std::uint8_t>(sum[static_cast<std::size_t>(c)] / count);
    }
  }
  return out;
}

Image apply_orientation(Image image, int orientation) {
  if (orientation < 2 || orientation > 8) return image;
  const int w = image.width, h = image.height;
  const bool turned = orientation >= 5;  // the shown picture is the stored one transposed
  Image out{turned ? h : w, turned ? w : h, image.channels, {}};
  out.pixels.resize(image.pixels.size());
  const auto n = static_cast<std::size_t>(image.channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Where the stored pixel (x, y) is shown (the tag's 0th row and column: EXIF 2.3, 4.6.4).
      int u = x, v = y;
      switch (orientation) {
        case 2:
          u = w - 1 - x;
          break;
        case 3:
          u = w - 1 - x, v = h - 1 - y;
          break;
        case 4:
          v = h - 1 - y;
          break;
        case 5:
          u = y, v = x;
          break;
        case 6:
          u = h - 1 - y, v = x;
          break;
        case 7:
          u = h - 1 - y, v = w - 1 - x;
          break;
        default:
          u = y, v = w - 1 - x;
          break;  // 8
      }
      std::copy_n(image.pixels.begin() +
                      static_cast<std::ptrdiff_t>((static_cast<std::size_t>(y) * w + x) * n),
                  n,
                  out.pixels.begin() + static_cast<std::ptrdiff_t>(
                                           (static_cast<std::size_t>(v) * out.width + u) * n));
    }
  return out;
}

Image decode_photo(std::string_view bytes, std::string_view what, const rig::DecodeLimits& limits) {
  Exif exif;
  Image stored = rgb(decode(bytes, what, limits, exif));  // before exif is read
  Image image = apply_orientation(std::move(stored), exif.orientation);
  image.focal_35mm = exif.focal_35mm;
  return image;
}

Image read_photo(const std::filesystem::path& path, const rig::DecodeLimits& limits) {
  Exif exif;
  Image stored = read(path, limits, exif);  // before exif is read
  Image image = apply_orientation(std::move(stored), exif.orientation);
  image.focal_35mm = exif.focal_35mm;
  return image;
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
