#pragma once
// Where an installed Facecast keeps its data (cmake --install or the .deb):
//   <prefix>/bin/facecast
//   <prefix>/share/facecast/{configs, web, node_modules/three, node_modules/@pixiv/three-vrm,
//                            zh_lexicon.txt, ict_facekit.glb, deploy}
// found relative to the running executable, so that no source tree is needed.
#include <filesystem>

namespace facecast {

/// <folder of the running executable>/../share/facecast when it holds configs/, else empty (a
/// build tree: data comes from the source tree).
std::filesystem::path installed_share_dir();

}  // namespace facecast
