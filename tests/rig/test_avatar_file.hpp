#pragma once
// A small avatar as people export them, written with tinygltf: four meshes (Head with two
// primitives, Teeth, Hair, Body), morph targets on Head and Teeth under a shared name (jawOpen),
// a skin (Hips > Spine > Neck > Head) that Head and Body use, Teeth placed by a node under the
// Head joint, two PNG textures (one with KHR_texture_transform), an animation, extras and an
// unknown extension.
#include <string>

namespace facecast::test {

/// The GLB bytes.
std::string test_avatar_glb();
/// The PNG bytes of image `i` (0: skin, 1: normal map) as stored in the GLB.
std::string test_avatar_png(int i);

}  // namespace facecast::test
