#pragma once
// Applying blendshape weights on the CPU: positions = neutral + sum_i w_i * delta_i, then normals.
//
// Cost: O(sum over shapes with w_i != 0 of the vertices they move) + O(#F) for normals. Deltas are
// sparse (most shapes move a small part of the face), so zero and small-support shapes are cheap.
#include <span>

#include "facecast/rig/rig.hpp"

namespace facecast::rig {

class Blender {
 public:
  /// Keeps a reference to `rig`, which must outlive the Blender.
  explicit Blender(const Rig& rig) : rig_(rig) {}

  /// `weights` holds one weight per rig shape (in rig order); throws Error on a size mismatch.
  /// `positions` and `normals` are resized to #V by 3 and overwritten.
  void apply(std::span<const float> weights, Positions& positions, Positions& normals) const;
  /// Positions only (no normals).
  void apply_positions(std::span<const float> weights, Positions& positions) const;

 private:
  const Rig& rig_;
};

}  // namespace facecast::rig
