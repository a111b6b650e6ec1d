// tinygltf's implementation, compiled into the fuzzers (instrumented) instead of linking Debian's
// libtinygltf.so. Facecast never decodes or encodes images through tinygltf (glb_io.cpp sets its
// own image loader), so stb_image is left out and the default image callbacks refuse.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

namespace tinygltf {

bool LoadImageData(Image*, const int, std::string* err, std::string*, int, int,
                   const unsigned char*, int, void*) {
  if (err) *err = "image decoding is not built into the fuzzer";
  return false;
}

bool WriteImageData(const std::string*, const std::string*, const Image*, bool, std::string* err,
                    void*) {
  if (err) *err = "image encoding is not built into the fuzzer";
  return false;
}

}  // namespace tinygltf
