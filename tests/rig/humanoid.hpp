#pragma once
// A humanoid made in code: a torso (skinned to Hips), a head with a "jawOpen" shape (Head), and
// arms of two bones each, saved with its arms `droop` degrees below the horizontal (0: T-pose,
// 45: A-pose). Joints: 0 Hips, 1/2/3 left arm, forearm, hand, 4/5/6 the right ones, 7 Neck,
// 8 Head; Mixamo's names unless the upper arms are named. Vertices: torso 0-7, head 8-15, left
// arm 16-23, right arm 24-31.
#include "facecast/rig/rig.hpp"

namespace facecast::test {

rig::Rig humanoid(float droop, const char* left = "mixamorig:LeftArm",
                  const char* right = "mixamorig:RightArm");

}  // namespace facecast::test
