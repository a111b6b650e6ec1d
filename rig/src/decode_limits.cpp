// Decode limits (see decode_limits.hpp): the budget of a file, image headers read without decoding.
#include "facecast/rig/decode_limits.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>

#include "decode_budget.hpp"
#include "facecast/core/error.hpp"

namespace facecast::rig {
namespace {

std::uint32_t be32(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) << 24 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 3]));
}
std::uint32_t be16(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1]));
}
std::uint32_t le32(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 3])) << 24;
}
std::uint32_t le24(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 16;
}
std::uint32_t le16(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8;
}

[[noreturn]] void malformed(std::string_view what, const char* format, const char* why) {
  throw Error(std::string(what) + ": " + format + " header " + why);
}

// PNG: the IHDR chunk must come first (width, height, bit depth, colour type).
ImageHeader png_header(std::string_view b, std::string_view what) {
  if (b.size() < 8 + 8 + 13 || b.substr(12, 4) != "IHDR") malformed(what, "PNG", "is truncated");
  ImageHeader h{"png", be32(b, 16), be32(b, 20), 0};
  static constexpr int kChannels[] = {1, 0, 3, 3, 2, 0, 4};
  const auto type = static_cast<unsigned char>(b[25]);
  if (type > 6 || kChannels[type] == 0) malformed(what, "PNG", "has an unknown colour type");
  h.channels = kChannels[type];
  return h;
}

// JPEG: markers up to the first start-of-frame (SOF0..SOF15 but DHT, JPG and DAC), each segment
// skipped by its length.
ImageHeader jpeg_header(std::string_view b, std::string_view what) {
  std::size_t at = 2;
  while (true) {
    while (at < b.size() && static_cast<unsigned char>(b[at]) == 0xFF && at + 1 < b.size() &&
           static_cast<unsigned char>(b[at + 1]) == 0xFF)
      ++at;  // fill bytes
    if (at + 4 > b.size() || static_cast<unsigned char>(b[at]) != 0xFF)
      malformed(what, "JPEG", "has no frame header");
    const auto marker = static_cast<unsigned char>(b[at + 1]);
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
      at += 2;
      continue;
    }
    if (marker == 0xD9 || marker == 0xDA) malformed(what, "JPEG", "has no frame header");
    const std::size_t length = be16(b, at + 2);
    if (length < 2) malformed(what, "JPEG", "has a bad segment length");
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (length < 8 || at + 2 + 8 > b.size()) malformed(what, "JPEG", "is truncated");
      ImageHeader h{"jpeg", be16(b, at + 7), be16(b, at + 5),
                    static_cast<unsigned char>(b[at + 9])};
      if (h.height == 0) malformed(what, "JPEG", "leaves the height to a DNL marker");
      return h;
    }
    at += 2 + length;
  }
}

// WebP: RIFF, then a VP8 (lossy), VP8L (lossless) or VP8X (extended: the canvas) chunk.
ImageHeader webp_header(std::string_view b, std::string_view what) {
  if (b.size() < 30) malformed(what, "WebP", "is truncated");
  const std::string_view chunk = b.substr(12, 4);
  if (chunk == "VP8X") return {"webp", le24(b, 24) + 1ll, le24(b, 27) + 1ll, 4};
  if (chunk == "VP8L") {
    if (static_cast<unsigned char>(b[20]) != 0x2F) malformed(what, "WebP", "has a bad signature");
    const std::uint32_t bits = le32(b, 21);
    return {"webp", (bits & 0x3FFF) + 1ll, ((bits >> 14) & 0x3FFF) + 1ll, 4};
  }
  if (chunk == "VP8 ") {
    if (b.substr(23, 3) != std::string_view("\x9d\x01\x2a", 3))
      malformed(what, "WebP", "has a bad start code");
    return {"webp", le16(b, 26) & 0x3FFF, le16(b, 28) & 0x3FFF, 3};
  }
  malformed(what, "WebP", "has no image chunk");
}

}  // namespace

std::size_t DecodeLimits::budget(std::size_t file_bytes) const {
  return std::min(max_decoded_bytes, detail::product(file_bytes, max_decoded_ratio));
}

std::string DecodeLimits::budget_reason(std::size_t file_bytes) const {
  if (detail::product(file_bytes, max_decoded_ratio) < max_decoded_bytes)
    return std::to_string(max_decoded_ratio) + " x the " + std::to_string(file_bytes) +
           "-byte file";
  return "max_decoded_bytes";
}

ImageHeader read_image_header(std::string_view b, std::string_view what) {
  if (b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8))
    return png_header(b, what);
  if (b.size() >= 3 && b.substr(0, 3) == std::string_view("\xff\xd8\xff", 3))
    return jpeg_header(b, what);
  if (b.size() >= 12 && b.substr(0, 4) == "RIFF" && b.substr(8, 4) == "WEBP")
    return webp_header(b, what);
  if (b.size() >= 12 && b.substr(0, 12) == std::string_view("\xabKTX 20\xbb\r\n\x1a\n", 12)) {
    if (b.size() < 28) malformed(what, "KTX2", "is truncated");
    return {"ktx2", le32(b, 20), std::max<std::uint32_t>(le32(b, 24), 1), 4};
  }
  return {};
}

std::size_t check_image(std::string_view bytes, std::string_view what, const DecodeLimits& limits) {
  const ImageHeader h = read_image_header(bytes, what);
  if (h.format.empty()) return 0;
  const std::string dims = std::to_string(h.width) + "x" + std::to_string(h.height);
  if (h.width < 1 || h.height < 1)
    throw Error(std::string(what) + ": " + h.format + " image of " + dims + " pixels");
  if (h.width > limits.max_image_side || h.height > limits.max_image_side)
    throw Error(std::string(what) + ": " + h.format + " image of " + dims +
                    " is over the limit of " + std::to_string(limits.max_image_side) +
                    " pixels a side (max_image_side)",
                ErrorCode::kLimit);
  const std::size_t decoded = detail::product(
      detail::product(static_cast<std::size_t>(h.width), static_cast<std::size_t>(h.height)),
      std::max(h.channels, 4));
  if (decoded > limits.max_image_bytes)
    throw Error(std::string(what) + ": " + h.format + " image of " + dims + " decodes to " +
                    std::to_string(decoded) + " bytes, over the limit of " +
                    std::to_string(limits.max_image_bytes) + " (max_image_bytes)",
                ErrorCode::kLimit);
  return decoded;
}

namespace detail {

std::size_t product(std::size_t a, std::size_t b) {
  if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a)
    return std::numeric_limits<std::size_t>::max();
  return a * b;
}

DecodeBudget::DecodeBudget(const DecodeLimits& limits, std::size_t file_bytes, std::size_t used,
                           std::string noun)
    : limited_(true),
      limits_(limits),
      file_bytes_(file_bytes),
      total_(limits.budget(file_bytes)),
      used_(used),
      noun_(std::move(noun)) {}

void DecodeBudget::add_file_bytes(std::size_t bytes) {
  if (!limited_) return;
  file_bytes_ += bytes;
  total_ = limits_.budget(file_bytes_);
}

void DecodeBudget::charge(std::size_t bytes, const std::string& at, std::string_view doing) {
  if (!limited_) return;
  if (used_ <= total_ && bytes <= total_ - used_) {
    used_ += bytes;
    return;
  }
  std::string msg = at + ": " + std::string(doing) + " of " + std::to_string(bytes) + " bytes";
  if (used_ > 0) msg += " (after " + std::to_string(used_) + " decoded)";
  std::string reason = limits_.budget_reason(file_bytes_);
  if (noun_ != "file" && reason.ends_with("-byte file"))
    reason.replace(reason.size() - 4, 4, noun_);
  throw Error(msg + " is over the budget of " + std::to_string(total_) + " (" + reason + ")",
              ErrorCode::kLimit);
}

}  // namespace detail

}  // namespace facecast::rig
