#pragma once
// A rig build's target as the user gave it: a mesh (OBJ), or an avatar file (GLB, .gltf, VRM)
// whose face the build gives shapes to and whose every other part (body, hair, textures, skin,
// extensions) is kept: the result is that file with the new morph targets in its own meshes.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "facecast/anim/avatar_view.hpp"
#include "facecast/anim/rig.hpp"

namespace facecast::rigbuild {

class BuildTarget {
 public:
  /// Reads .obj, .glb, .gltf or .vrm (by extension).
  static BuildTarget read(const std::filesystem::path& path);
  /// An upload: `format` is obj, glb, gltf or vrm; `name` is used in error messages. Read within
  /// `limits` (anim/decode_limits.hpp).
  static BuildTarget parse(std::string_view bytes, std::string_view format, std::string_view name,
                           const anim::DecodeLimits& limits = {});

  /// The neutral the build works on: the OBJ's mesh, or the avatar's face view (its meshes with
  /// morph targets, or what the head joint carries; avatar_view.hpp), without its shapes.
  const anim::Rig& neutral() const { return neutral_; }
  anim::Rig& neutral() { return neutral_; }
  /// True for an avatar file (the result keeps it).
  bool is_avatar() const { return doc_.has_value(); }

  /// The result as GLB bytes: for an avatar, its document with `built`'s shapes written into the
  /// meshes they move (anim::write_back; same-named targets replaced, new ones appended),
  /// everything else byte for byte; for a mesh, Facecast's GLB of `built`. `built` has the
  /// neutral's vertices (BuildResult::rig).
  std::string glb_bytes(const anim::Rig& built) const;

 private:
  static BuildTarget from_document(anim::AvatarDocument doc);
  anim::Rig neutral_;
  std::optional<anim::AvatarDocument> doc_;
  std::optional<anim::AvatarView> view_;
};

}  // namespace facecast::rigbuild
