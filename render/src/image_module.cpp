// facecast_image_oiio.so: the OpenImageIO side of facecast/render/image.hpp (see image_codec.hpp).
// Images are encoded in memory (IOVecOutput) so that files are written atomically and JPEG frames
// can be streamed. Nothing here throws: OpenImageIO reports through its return values, and the
// messages go back to the caller on one line.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>

#include "image_codec.hpp"

namespace facecast::render::detail {
namespace {

namespace OIIO = OIIO_NAMESPACE;

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

bool fail(Failure& failure, std::string message, ErrorCode code) {
  failure = {one_line(std::move(message)), code};
  return false;
}

bool encode(const Image& image, const float* linear, const char* format_name, int quality,
            std::string& out, Failure& failure) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto writer = OIIO::ImageOutput::create(format_name);
  if (!writer)
    return fail(failure,
                "no image writer for " + std::string(format_name) + ": " + OIIO::geterror(),
                ErrorCode::kUnsupported);
  if (!writer->supports("ioproxy"))
    return fail(failure,
                "the " + std::string(writer->format_name()) + " writer cannot write to memory",
                ErrorCode::kUnsupported);
  OIIO::ImageSpec spec(image.width, image.height, image.channels,
                       linear ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
  if (quality > 0)
    spec.attribute("Compression", "jpeg:" + std::to_string(std::clamp(quality, 1, 100)));
  const bool ok = writer->set_ioproxy(&proxy) && writer->open(format_name, spec) &&
                  (linear ? writer->write_image(OIIO::TypeDesc::FLOAT, linear)
                          : writer->write_image(OIIO::TypeDesc::UINT8, image.pixels.data())) &&
                  writer->close();
  if (!ok)
    return fail(failure, "cannot encode " + std::string(format_name) + ": " + writer->geterror(),
                ErrorCode::kInternal);
  out.assign(bytes.begin(), bytes.end());
  return true;
}

bool decode(std::string_view bytes, const char* file_name, int max_side, Image& out,
            Failure& failure) {
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  OIIO::ImageSpec config;
  const void* proxy_pointer = &proxy;  // the attribute holds the pointer's value
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_pointer);
  auto in = OIIO::ImageInput::create(file_name, false, &config, &proxy);
  if (!in) return fail(failure, "no image reader: " + OIIO::geterror(), ErrorCode::kInternal);
  OIIO::ImageSpec spec;
  if (!in->open(file_name, spec, config))
    return fail(failure, "cannot decode: " + in->geterror(), ErrorCode::kInvalidInput);
  if (spec.width < 1 || spec.height < 1 || spec.width > max_side || spec.height > max_side ||
      spec.nchannels < 1 || spec.nchannels > 4)
    return fail(failure,
                "image of " + std::to_string(spec.width) + "x" + std::to_string(spec.height) + "x" +
                    std::to_string(spec.nchannels) + " is out of range (at most " +
                    std::to_string(max_side) + " a side)",
                ErrorCode::kUnsupported);
  out = Image{spec.width, spec.height, 4, {}};
  out.pixels.assign(static_cast<std::size_t>(spec.width) * spec.height * 4, 255);
  // Read the file's channels into the first ones of RGBA; grey is expanded below. On the calling
  // thread: renderers are made on worker threads already (and OIIO's own pool hides its writes
  // into our buffer from ThreadSanitizer).
  in->threads(1);
  const OIIO::stride_t pixel = 4;
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, out.pixels.data(), pixel))
    return fail(failure, "cannot decode: " + in->geterror(), ErrorCode::kInvalidInput);
  if (spec.nchannels <= 2) {
    for (std::size_t i = 0; i < out.pixels.size(); i += 4) {
      const std::uint8_t g = out.pixels[i], a = spec.nchannels == 2 ? out.pixels[i + 1] : 255;
      out.pixels[i + 1] = out.pixels[i + 2] = g;
      out.pixels[i + 3] = a;
    }
  }
  return true;
}

bool read(const char* path, int max_side, std::size_t max_bytes, Image& out, Failure& failure) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return fail(failure, "cannot read image: " + OIIO::geterror(), ErrorCode::kNotFound);
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > max_side || spec.height > max_side ||
      spec.nchannels < 1 || spec.nchannels > 64 ||
      static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
              static_cast<std::size_t>(std::max(spec.nchannels, 4)) >
          max_bytes)
    return fail(failure,
                "image of " + std::to_string(spec.width) + "x" + std::to_string(spec.height) + "x" +
                    std::to_string(spec.nchannels) + " is over the image limits (max_image_side " +
                    std::to_string(max_side) + ", max_image_bytes " + std::to_string(max_bytes) +
                    ")",
                ErrorCode::kLimit);
  const std::size_t count = static_cast<std::size_t>(spec.width) * spec.height;
  std::vector<std::uint8_t> raw(count * spec.nchannels);
  if (spec.format.basetype == OIIO::TypeDesc::FLOAT ||
      spec.format.basetype == OIIO::TypeDesc::HALF) {
    // Linear floats (EXR): encode to sRGB.
    std::vector<float> lin(raw.size());
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, lin.data()))
      return fail(failure, in->geterror(), ErrorCode::kInvalidInput);
    for (std::size_t i = 0; i < lin.size(); ++i) {
      const float c = std::clamp(lin[i], 0.0f, 1.0f);
      const float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
      raw[i] = static_cast<std::uint8_t>(std::lround(e * 255.0f));
    }
  } else if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, raw.data())) {
    return fail(failure, in->geterror(), ErrorCode::kInvalidInput);
  }
  out = Image{spec.width, spec.height, 3, {}};
  out.pixels.resize(count * 3);
  for (std::size_t p = 0; p < count; ++p)
    for (int c = 0; c < 3; ++c)
      out.pixels[p * 3 + c] = raw[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
  return true;
}

bool draw_text(Image& image, int x, int y, std::string_view text, int size, const float* rgb,
               const char* font) {
  // The image's own pixels, wrapped: render_text blends into them (alpha, if any, made opaque).
  OIIO::ImageBuf buf(
      OIIO::ImageSpec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8),
      image.pixels.data());
  const float colour[4] = {rgb[0], rgb[1], rgb[2], 1.0f};
  const bool ok = OIIO::ImageBufAlgo::render_text(
      buf, x, y, text, size, font,
      OIIO::cspan<float>(colour, static_cast<std::size_t>(image.channels)));
  (void)buf.geterror();  // (clears it: an unread error is printed when the buffer goes)
  return ok;
}

}  // namespace
}  // namespace facecast::render::detail

extern "C" __attribute__((visibility("default"))) const facecast::render::detail::ImageCodec*
facecast_image_codec() {
  namespace d = facecast::render::detail;
  static const d::ImageCodec codec{d::ImageCodec::kVersion, d::encode, d::decode, d::read,
                                   d::draw_text};
  return &codec;
}
