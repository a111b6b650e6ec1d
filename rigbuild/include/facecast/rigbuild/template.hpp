#pragma once
// The realistic template shipped with Facecast: the ICT FaceKit (MIT, USC Institute for Creative
// Technologies; rigbuild/data/ict_facekit.LICENSE) as a compact GLB, rigbuild/data/ict_facekit.glb,
// packed from the FaceKit by `facecast rig pack-template` (docs/algorithms.md#shipped-template). It
// holds the FaceKit's neutral without its transparent eye layers (lacrimal fluid, eye blend, eye
// occlusion), its expressions under ARKit names (eyeBlinkLeft; browInnerUp and cheekPuff as the sum
// of the FaceKit's halves, which are kept as browInnerUp_L ... with its other extras
// cheekRaiser_L/R and PupilDilate_L/R), the 15 Oculus visemes (viseme_sil ... viseme_U) baked from
// configs/anim/visemes_arkit.json, its 68 landmarks ("dlib_00".."dlib_67", mesh extras) and
// materials for its skin, eyes, teeth, gums and lashes. Positions and morph deltas are 16-bit
// (KHR_mesh_quantization, one scale for all: 21 um steps), every buffer view meshopt-compressed
// (EXT_meshopt_compression). It also holds the FaceKit's 10 identity modes for the photo avatar
// (photo_avatar.hpp): not as morph targets, since they are no expressions, but as int16 accessors
// that no primitive uses, listed in mesh.extras.facecast.identity; so renderers, rig readers,
// listings and mappings never see them as channels. `facecast rig pack-template --ict DIR --out
// FILE` makes it from the FaceKit's FaceXModel folder (../shared/data/ict-facekit.tar.xz).
#include <filesystem>
#include <string>
#include <vector>

#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rigbuild {

/// The server's rig id of the shipped template.
inline constexpr const char* kShippedTemplateId = "ict-facekit";

/// ict_facekit.glb: <prefix>/share/facecast/ when installed, else rigbuild/data/ in the source
/// tree. Throws Error(kNotFound) naming it when it is missing.
std::filesystem::path shipped_template_path();

/// The shipped template as a rig (the file's vertex order; its landmarks and shapes). Throws
/// facecast::Error naming the file when it is missing or unreadable.
rig::Rig load_shipped_template();

/// What a listing needs without building the rig: its shape names and vertex count (read from
/// the file's glTF document, rig::AvatarDocument). Throws Error naming the file.
struct TemplateSummary {
  std::vector<std::string> shapes;
  int vertices = 0;
};
TemplateSummary shipped_template_summary();

/// The ICT FaceKit's FaceXModel folder (generic_neutral_mesh.obj, the expression OBJs,
/// vertex_indices.json) as the shipped template's rig: parts, names, visemes, landmarks and
/// materials as above. Throws Error naming the file that is missing or malformed.
rig::Rig ict_template_rig(const std::filesystem::path& facexmodel_dir);

/// The FaceKit's identity modes (identity000.obj .. in name order) as deltas from its neutral on
/// the template's vertices (ict_template_rig's order). Throws Error naming a malformed file.
std::vector<rig::Positions> ict_identity_modes(const std::filesystem::path& facexmodel_dir);

/// The compact GLB of a rig (one mesh, one primitive per material): positions and morph deltas
/// as normalized int16 with one node scale and translation (14 bits over the head's box), normals
/// as normalized int8, UVs as floats rounded to 1/4096, uint16 or uint32 indices, dense morph
/// targets (their zero rows cost almost nothing once compressed), every view meshopt-compressed;
/// target names in mesh.extras.targetNames, landmarks in mesh.extras.facecast.landmarks. The
/// quantization step is `quantization_step(rig)`. `identity`: the identity modes (#V by 3 deltas,
/// quantized like the morph deltas), stored as accessors outside the primitives and listed in
/// mesh.extras.facecast.identity ({name: "identity000", accessor}). Throws Error when a mode is
/// outside the quantization's range or has the wrong size.
std::string compact_glb_bytes(const rig::Rig& rig,
                              const std::vector<rig::Positions>& identity = {});
/// The largest error of a quantized coordinate: half the int16 step of the rig's box.
double quantization_step(const rig::Rig& rig);

/// The identity modes a compact GLB holds (compact_glb_bytes), in order; empty when it has none.
/// Throws Error naming the file when they are malformed.
std::vector<rig::Positions> read_template_identity(const std::filesystem::path& glb);
/// The same from a document already read.
std::vector<rig::Positions> read_template_identity(const rig::AvatarDocument& doc);

}  // namespace facecast::rigbuild
