#pragma once
// Bounds on what an avatar or rig file from outside may make Facecast spend: checked on what the
// file declares (JSON nesting, counts, decoded sizes, image headers) BEFORE the parser, decoder or
// allocation that would spend it. A file over a bound is an Error(kLimit) naming the file and the
// field. The defaults suit every avatar exporter we know (Ready Player Me, VRoid, Avaturn, Blender,
// gltf-transform); the server reads them from configs/server.json ("decode"), the CLI uses these.
#include <cstddef>
#include <string>
#include <string_view>

namespace facecast::rig {

struct DecodeLimits {
  /// Nesting of the glTF JSON (a recursive parser runs out of stack on deep nesting). glTF nests
  /// about 8 levels, VRM extensions about 12.
  int max_json_depth = 64;
  /// Values (and keys) in the glTF JSON, counted before it is parsed: each costs a JSON parser
  /// and tinygltf up to a few hundred bytes, whatever its size in the file. An avatar has about
  /// 10,000 to 100,000.
  std::size_t max_json_values = 1048576;
  /// Bytes a document may decode in all (meshopt and Draco output, accessors read as floats and
  /// integers, sparse accessors made dense, OBJ records): at most `max_decoded_ratio` times the
  /// file's size and at most `max_decoded_bytes`, whichever is smaller.
  std::size_t max_decoded_bytes = std::size_t{512} << 20;
  std::size_t max_decoded_ratio = 64;
  /// Images (PNG, JPEG, WebP, KTX2 headers; checked before any decoder runs): width and height at
  /// most `max_image_side`, width x height x 4 (RGBA8, what the renderer decodes to) at most
  /// `max_image_bytes`, the images of one document together at most `max_texture_bytes`.
  int max_image_side = 8192;
  std::size_t max_image_bytes = std::size_t{256} << 20;
  std::size_t max_texture_bytes = std::size_t{1} << 30;
  /// Counts of glTF objects (each costs memory in every parser, whatever its size): nodes,
  /// meshes, primitives of all meshes, morph targets of all primitives, joints of all skins,
  /// accessors, images.
  std::size_t max_nodes = 65536;
  std::size_t max_meshes = 16384;
  std::size_t max_primitives = 65536;
  std::size_t max_morph_targets = 262144;
  std::size_t max_joints = 65536;
  std::size_t max_accessors = 1048576;
  std::size_t max_images = 1024;
  /// OBJ: bytes of one line, corners of one face.
  std::size_t max_obj_line = 65536;
  std::size_t max_obj_face = 256;

  /// The decoded-bytes budget of a file of `file_bytes` bytes.
  std::size_t budget(std::size_t file_bytes) const;
  /// "64 x the 2097152-byte file" or "max_decoded_bytes": where budget() comes from.
  std::string budget_reason(std::size_t file_bytes) const;
};

/// What an encoded image's header says. `format` is "png", "jpeg", "webp" or "ktx2"; empty when
/// the bytes are none of these.
struct ImageHeader {
  std::string format;
  long long width = 0, height = 0;
  int channels = 0;  // as stored (a palette counts 3, a JPEG its components)
};

/// Why a KTX2 (Basis Universal) image is refused, and what to run instead.
inline constexpr std::string_view kNoKtx2Decoder =
    "KTX2 (Basis Universal) textures cannot be decoded here (Debian ships no decoder); convert "
    "them first: gltf-transform png IN OUT (or gltf-transform webp IN OUT)";

/// Reads the header only (no decoding); a recognized format whose header is truncated or
/// malformed is an Error naming `what`.
ImageHeader read_image_header(std::string_view bytes, std::string_view what);

/// Checks an encoded image against the limits before it is decoded: Error(kLimit) naming `what`
/// when a side or the decoded size is over; Error(kInvalidInput) for a malformed header. Returns
/// the decoded size (width x height x 4; 0 for a format Facecast does not decode).
std::size_t check_image(std::string_view bytes, std::string_view what,
                        const DecodeLimits& limits = {});

}  // namespace facecast::rig
