#pragma once
// LidMargins: where the landmark pipeline (landmarks.cpp) snaps dlib's lid points.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "facecast/render/camera.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/geometry.hpp"

namespace facecast::rigbuild {

// The lid margins (docs/algorithms.md#landmarks, step 7). On a grey render of a head whose
// eye sockets are empty, dlib sees a narrower eye than the lids make and puts the lid points
// inside the opening, a lower lid's sometimes on the upper lid (MakeHuman's head: up to 0.1 of
// the eye's width off, more than the opening). The margin seen from the front is where the skin
// turns away from the camera into the socket, or ends at a hole: its contour (`margin` below).
class LidMargins {
 public:
  struct Eye {
    int inner, outer;                 // corner landmarks
    std::array<int, 2> upper, lower;  // lid landmarks
  };
  static constexpr std::array<Eye, 2> kEyes{Eye{39, 36, {37, 38}, {41, 40}},
                                            Eye{42, 45, {43, 44}, {47, 46}}};

  // `head` (with its connected components) seen from `camera`; its skin is its largest
  // component.
  LidMargins(const rig::Rig& head, const rig::Components& components, const render::Camera& camera);

  // The eye's frame from its corners in `points`; width 0 when a corner is missing.
  struct Frame {
    Eigen::Vector3d mid = Eigen::Vector3d::Zero(), along = Eigen::Vector3d::Zero(),
                    up = Eigen::Vector3d::Zero();
    double width = 0;
  };
  Frame frame(const Points& points, const Eye& e) const;

  // The margin vertex on `side` (+1 above the corners' line, -1 below) nearest to where `x` is
  // along the line (at most 10 % of the eye's width from it); -1 when there is none. A contour
  // vertex is on the margin when no contour vertex within 3 % of the width along the line is
  // nearer the line (that one is the lid's posterior margin, this its front rim).
  int margin(const Frame& f, int side, const Eigen::Vector3d& x) const;

  // The lid points of both eyes moved onto the margins.
  void snap(Points& points) const;

 private:
  Points rest_;
  Eigen::Vector3d forward_, up_;
  std::vector<int> contour_;  // skin vertices on the contour seen from the camera, or a border
};

}  // namespace facecast::rigbuild
