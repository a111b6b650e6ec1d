#pragma once
// Private: a rig laid out for the GPU. The constants here are the one definition of the layout:
// the packing (gpu_rig.cpp), the upload (renderer.cpp) and the GLSL (shaders.cpp, which #defines
// them at the top of the shader source) all read them.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "facecast/anim/rig.hpp"

namespace facecast::render::detail {

/// Length of the shader's weight array: the most shapes a rig may have.
constexpr int kMaxShapes = 256;
/// Texels per morph entry in the delta texture: (position delta, shape index), (normal delta, 0).
constexpr int kTexelsPerEntry = 2;
/// Texels per row of the delta texture; a multiple of kTexelsPerEntry, so an entry's texels stay
/// on one row.
constexpr int kDeltaWidth = 4096;
static_assert(kDeltaWidth % kTexelsPerEntry == 0);
/// Vertex attribute locations.
constexpr int kPositionAttribute = 0, kNormalAttribute = 1, kMorphAttribute = 2;

/// The rig packed once on the CPU, shared read-only by every GL context.
struct PackedRig {
  std::vector<float> positions, normals;  // #V * 3
  std::vector<std::int32_t> morph;        // #V * 2: first entry, entry count
  std::vector<float> deltas;              // kDeltaWidth * delta_rows * 4 (RGBA32F texels)
  int delta_rows = 0;
  std::vector<std::uint32_t> indices;  // triangles sorted by material
  struct Range {
    std::size_t first = 0, count = 0;  // into `indices`
    Eigen::Vector3f color;             // linear base colour of the material
  };
  std::vector<Range> ranges;
  int shape_count = 0;
};

/// Per vertex, the shapes that move it or change its normal (position and normal deltas), in the
/// delta texture; triangles grouped by material. Throws Error for an invalid rig or more than
/// kMaxShapes shapes.
PackedRig pack_rig(const anim::Rig& rig);

}  // namespace facecast::render::detail
