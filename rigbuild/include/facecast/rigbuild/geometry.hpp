#pragma once
// The least-squares fit of one point set onto another.
#include <Eigen/Core>

#include "facecast/rig/mesh.hpp"

namespace facecast::rigbuild {

// The mesh vocabulary is rig's (facecast/rig/mesh.hpp); the builder computes in Points.
using rig::Points;
using rig::Triangles;

/// x -> scale * R x + t (a rigid motion when scale is 1).
struct Similarity {
  double scale = 1.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double rms = 0;  // from procrustes(): the RMS distance of the moved points from their partners

  /// Every row of `p` (#N by 3) moved.
  Points apply(const Points& p) const;
  /// One point moved.
  Eigen::RowVector3d apply(const Eigen::RowVector3d& p) const;
};

/// The similarity that moves the rows of `from` closest to the rows of `to` (#N by 3 each, rows
/// paired) in the least-squares sense: without scale the rigid motion (Kabsch), with scale the
/// similarity (Umeyama). See docs/algorithms.md#procrustes.
Similarity procrustes(const Points& from, const Points& to, bool with_scale);

}  // namespace facecast::rigbuild
