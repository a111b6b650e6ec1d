// MPEG-4 FAP files on the command line: a rig measured at its feature points (stored or known
// landmarks, else detected), and a file read into a motion of that rig.
#include <iostream>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "speech_input.hpp"

namespace facecast::cli {

anim::FapRig fap_rig(const rig::Rig& rig) {
  if (const auto known = rigbuild::known_landmarks(rig)) return anim::FapRig(rig, *known);
  std::cerr << "finding the rig's 68 landmarks (FAP feature points)...\n";
  const auto found = rigbuild::detect_landmarks(rig, rigbuild::load_landmark_options());
  if (found.views_found == 0)
    throw Error(
        "rig: no face found in its rendered views: the FAP feature points need its "
        "landmarks (store them as dlib_00..dlib_67, e.g. with rig build)");
  return anim::FapRig(rig, found.vertex);
}

anim::FapMotion read_fap_motion(const std::string& path, const anim::FapRig& fap) {
  const anim::FapSequence sequence = anim::parse_fap(read_file(path), path);
  return anim::FapMotion(sequence, fap, anim::Mapping::for_rig(fap.shape_names()));
}

}  // namespace facecast::cli
