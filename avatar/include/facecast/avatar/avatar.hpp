#pragma once
// The built-in default avatar: a stylized, friendly head generated in code, with ARKit-named
// blendshapes, so the server and the tests can animate and render a face with nothing downloaded.
//
// Geometry (centimetres, +Y up, the face looks along +Z, origin near the centre of the skull):
//  - the skin: one closed surface (a topological sphere) on a conformal grid whose pole is the
//    mouth (elliptic coordinates around the lip line, mapped onto the head): skull, jaw, cheeks,
//    chin, brows, simple ears, a nose with nostril pockets, lips that meet along the lip line, and
//    behind them the inner lips and the mouth cavity (the same surface folded inwards: a real
//    double layer). Around each eye the skin folds into a socket (a bowl behind the eyeball).
//  - upper and lower teeth (closed tubes along the dental arch), a tongue, two eyeballs (sclera,
//    iris and pupil bands), and four eyelids: thin shells concentric with the eyeballs, so that a
//    blink rotates them over the eyeball without ever passing through it (the upper lid slides over
//    the lower one).
// Blendshapes are procedural: region weights, rotations about joints (jaw hinge, eye centres) and
// smooth displacement fields; teeth and tongue follow the jaw, eyeballs rotate for eyeLook*.
//
// The generator is deterministic: the same parameters give the same bytes. Different parameters
// give other "users" with the same topology (a ready same-topology target for the rig builder).
// The code: avatar.cpp (parameters, assembly), geometry.cpp (the head and the parts'
// assembly; the parts in skin.cpp, mouth.cpp, eyes.cpp), shapes.cpp.
// See docs/algorithms.md#avatar.
#include <cstdint>
#include <string>
#include <vector>

#include "facecast/rig/rig.hpp"

namespace facecast::avatar {

/// Proportions of the generated head. Each is a factor around 1 (the default avatar); the valid
/// range of each is [0.75, 1.3]. Mirrored in configs/avatar/avatar.json.
struct AvatarParams {
  float face_width = 1.0f;     // width of face and skull (x)
  float jaw_length = 1.0f;     // vertical extent of the face below the nose
  float lip_thickness = 1.0f;  // how far the lips bulge out
  float eye_size = 1.0f;       // eyeball radius (lids and sockets follow)
  float nose_length = 1.0f;    // how far the nose reaches forward and down

  /// Throws facecast::Error naming the first parameter outside [0.75, 1.3].
  void validate() const;
};

/// A deterministic "other user": parameters drawn from `seed` within the valid ranges (seed 0
/// gives the default avatar).
AvatarParams avatar_variant(std::uint64_t seed);

/// The ARKit blendshape names the avatar has, in rig order (the 52 ARKit shapes).
const std::vector<std::string>& avatar_shape_names();

/// Generates the avatar. The rig's groups name the parts ("skin", "lip_upper", "lip_lower",
/// "teeth_upper", "teeth_lower", "tongue", "eyeball_left", ..., "lid_upper_left", ...) so that
/// checks can tell them apart; "lip_upper" and "lip_lower" are the skin bands along the lip line
/// where the lips touch. Landmarks name a few vertices (mouth corners, lip centres, nose tip,
/// chin, pupils, inner/outer eye corners, brow points).
rig::Rig make_avatar(const AvatarParams& params = {});

/// The default avatar (make_avatar({})), built once per process and then returned by reference.
const rig::Rig& default_avatar();

}  // namespace facecast::avatar
