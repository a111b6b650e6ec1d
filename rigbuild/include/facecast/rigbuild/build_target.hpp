#pragma once
// A rig build's target as the user gave it: a mesh (OBJ), or an avatar file (GLB, .gltf, VRM)
// whose face the build gives shapes to and whose every other part (body, hair, textures, skin,
// extensions) is kept: the result is that file with the new morph targets in its own meshes.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rigbuild {

class BuildTarget {
 public:
  /// Reads .obj, .glb, .gltf or .vrm (by extension).
  static BuildTarget read(const std::filesystem::path& path);
  /// An upload: `format` is obj, glb, gltf or vrm; `name` is used in error messages. Read within
  /// `limits` (rig/decode_limits.hpp).
  static BuildTarget parse(std::string_view bytes, std::string_view format, std::string_view name,
                           const rig::DecodeLimits& limits = {});

  /// The neutral the build works on: the OBJ's mesh, or the avatar's face view (its meshes with
  /// morph targets, or what the head joint carries; avatar_view.hpp), without its shapes.
  const rig::Rig& neutral() const { return neutral_; }
  rig::Rig& neutral() { return neutral_; }
  /// True for an avatar file (the result keeps it).
  bool is_avatar() const { return doc_.has_value(); }

  /// The result as GLB bytes: for an avatar, its document with `built`'s shapes written into the
  /// meshes they move (rig::write_back; same-named targets replaced, new ones appended),
  /// everything else byte for byte; for a mesh, Facecast's GLB of `built`. `built` has the
  /// neutral's vertices (BuildResult::rig).
  std::string glb_bytes(const rig::Rig& built) const;

 private:
  static BuildTarget from_document(rig::AvatarDocument doc);
  rig::Rig neutral_;
  std::optional<rig::AvatarDocument> doc_;
  std::optional<rig::AvatarView> view_;
};

}  // namespace facecast::rigbuild
