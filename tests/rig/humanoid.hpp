#pragma once
// A humanoid made in code: a torso (skinned to Hips), a head with a "jawOpen" shape (Head), and
// arms of two bones each, saved with its arms `droop` degrees below the horizontal (0: T-pose,
// 45: A-pose). Joints: 0 Hips, 1/2/3 left arm, forearm, hand, 4/5/6 the right ones, 7 Neck,
// 8 Head, 9 Spine, 10 Spine2 (the chest: neck and shoulders hang from it), 11/12 left and right
// shoulders (the arms hang from them), 13/14 left thigh and shin, 15/16 the right ones (no
// vertices); Mixamo's names unless the upper arms are named. Vertices: torso 0-7 (the top four on
// the chest, the bottom four on the hips), head 8-15, left arm 16-23, right arm 24-31.
#include "facecast/rig/rig.hpp"

namespace facecast::test {

/// One degree in radians (the humanoid tests turn bones by degrees).
constexpr float kDeg = 3.14159265f / 180.0f;

rig::Rig humanoid(float droop, const char* left = "mixamorig:LeftArm",
                  const char* right = "mixamorig:RightArm");

/// Adds a ponytail hanging behind the head (`front`: a lock hanging in front of the face, as the
/// camera sees it): joints 17 Hair1 (on the Head), 18 Hair2, 19 Hair3 down it, a box of vertices
/// on Hair1 (top half) and Hair2 (bottom half), and as spring bones Hair1 and Hair2 (stiffness 1,
/// drag 0.4, no gravity) with a sphere collider on the head (radius 0.1 about its centre), the
/// file's springs replaced.
void add_ponytail(rig::Rig& rig, bool front = false);

}  // namespace facecast::test
