#pragma once
// Takes as the Live Link Face app records them (Epic Games' iOS capture app): a CSV that Unreal's
// LiveLinkFaceImporter, MetaHuman Animator and the Blender importers read. 63 columns: Timecode
// ("HH:MM:SS:FF.fff", frames of the take's rate with the sub-frame fraction), BlendShapeCount (61),
// the 52 ARKit shapes in the app's column order and capitalization (which puts JawRight before
// JawLeft and MouthRight before MouthLeft), then HeadYaw, HeadPitch, HeadRoll and the two eyes'
// yaw, pitch and roll in radians. One row per frame.
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/anim/animation.hpp"

namespace facecast::anim {

/// The 52 ARKit columns of a Live Link Face take, in its order.
const std::array<std::string_view, 52>& live_link_face_shapes();

/// The ARKit shape names (camelCase: "eyeBlinkLeft") of live_link_face_shapes(), for a mapping
/// that drives an ARKit face whatever the rig is.
std::vector<std::string> arkit_shape_names();

/// "HH:MM:SS:FF.fff" for frame `frame` of a take at `fps`.
std::string live_link_timecode(int frame, double fps);

/// The take's CSV. Each column takes the track's shape of that ARKit name, matched without regard
/// to case and with "_L"/"_R" read as "Left"/"Right" (the ICT FaceKit's names); a column the track
/// has no shape for is 0. The head columns are the track's head pose; the eyes' rotations are 0
/// (Facecast turns the eyes through the eyeLook shapes, which are columns of their own).
std::string to_live_link_csv(const WeightTrack& track);

}  // namespace facecast::anim
