#pragma once
// The avatar document: a user's glTF (GLB, .gltf, .vrm) kept as the source of truth. Every node,
// mesh, primitive, material, texture, image, sampler, skin, animation, extra and extension it
// holds survives load -> save; compressed data (EXT_meshopt_compression,
// KHR_draco_mesh_compression) is decoded on load and saved plain. The Rig the animation works on
// is a view of it (avatar_view.hpp).
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "facecast/rig/decode_limits.hpp"

namespace tinygltf {
class Model;
}

namespace facecast::rig {

class AvatarDocument {
 public:
  /// Reads a .glb, .vrm or .gltf file; a .gltf's external buffers and images are read relative to
  /// its folder. What the file declares is checked against `limits` before it is parsed, decoded
  /// or allocated (Error(kLimit) naming the file and the field); make_view keeps to them too.
  static AvatarDocument read(const std::filesystem::path& path, const DecodeLimits& limits = {});
  /// Parses a self-contained GLB/VRM or .gltf JSON (an upload): URIs other than data: URIs are
  /// refused, images are kept encoded (their headers checked). `name` is used in error messages.
  static AvatarDocument parse(std::string_view bytes, std::string_view name,
                              const DecodeLimits& limits = {});
  /// Wraps a model built in code (the GLB writer's, tests').
  static AvatarDocument from_model(tinygltf::Model model, std::string name);

  /// The document as a GLB (one buffer; images keep their bytes).
  std::string glb_bytes() const;
  /// Writes glb_bytes() atomically.
  void write_glb(const std::filesystem::path& path) const;

  const tinygltf::Model& model() const { return *model_; }
  tinygltf::Model& model() { return *model_; }
  /// The file name (or upload name) errors refer to.
  const std::string& name() const { return name_; }
  /// The limits the document was read with, the size of what was read (file and external
  /// buffers) and of the document decoded (compressed data and URIs unpacked, as tinygltf read
  /// it); 0 for a document built in code (no limits apply to it).
  const DecodeLimits& limits() const { return limits_; }
  std::size_t source_bytes() const { return source_bytes_; }
  std::size_t decoded_bytes() const { return decoded_bytes_; }

  AvatarDocument(AvatarDocument&&) noexcept;
  AvatarDocument& operator=(AvatarDocument&&) noexcept;
  ~AvatarDocument();

 private:
  AvatarDocument();
  std::unique_ptr<tinygltf::Model> model_;
  std::string name_;
  DecodeLimits limits_;
  std::size_t source_bytes_ = 0, decoded_bytes_ = 0;
};

}  // namespace facecast::rig
