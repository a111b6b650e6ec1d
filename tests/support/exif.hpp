#pragma once
// A JPEG as a phone writes it: an APP1 Exif segment with an Orientation tag after the SOI marker
// (EXIF 2.3: a big-endian TIFF header, IFD0 with the one entry 0x0112 SHORT). Written here byte
// by byte, so that the readers' handling of the tag is checked against the standard, not against
// a writer of the same library.
#include <stdexcept>
#include <string>

namespace facecast::test {

inline std::string with_exif_orientation(const std::string& jpeg, int orientation) {
  if (jpeg.size() < 2 || jpeg.compare(0, 2, "\xff\xd8") != 0)
    throw std::invalid_argument("with_exif_orientation: not a JPEG");
  const std::string tiff = std::string("MM\x00\x2a\x00\x00\x00\x08", 8) +  // header, IFD0 at 8
                           std::string("\x00\x01", 2) +                    // one entry
                           std::string("\x01\x12\x00\x03\x00\x00\x00\x01", 8) +  // SHORT x 1
                           std::string{'\0', static_cast<char>(orientation), '\0', '\0'} +
                           std::string(4, '\0');  // no next IFD
  const std::string body = std::string("Exif\0\0", 6) + tiff;
  const std::size_t length = body.size() + 2;
  return jpeg.substr(0, 2) + "\xff\xe1" + static_cast<char>(length >> 8) +
         static_cast<char>(length & 0xff) + body + jpeg.substr(2);
}

}  // namespace facecast::test
