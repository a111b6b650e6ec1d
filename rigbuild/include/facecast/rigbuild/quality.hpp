#pragma once
// Measures of a built rig: error against ground-truth shapes, and the seed paper's gap measure.
#include <string>
#include <vector>

#include "facecast/anim/rig.hpp"
#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct ShapeError {
  std::string shape;
  double mean = 0, p99 = 0, max = 0;  // per-vertex Euclidean error, in mesh units
  double p99_percent = 0;             // p99 as % of the bounding-box diagonal
};

/// Per shape of `built`, the error of vertices [first, last) against `truth_neutral` + the truth
/// rig's delta of the same name (the ICT identity ground truth: the template's deltas).
std::vector<ShapeError> truth_errors(const anim::Rig& built, const anim::Positions& truth_neutral,
                                     const anim::Rig& truth_deltas, int first, int last);

/// Per shape, the error against a folder of ground-truth OBJs named like the shapes.
std::vector<ShapeError> truth_errors(const anim::Rig& built,
                                     const std::vector<anim::Positions>& truth);

}  // namespace facecast::rigbuild
