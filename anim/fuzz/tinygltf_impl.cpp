// tinygltf's implementation, compiled into the fuzzers (instrumented) instead of linking Debian's
// libtinygltf.so. Images are never decoded by Facecast (glb_io.cpp sets its own image loader).
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
