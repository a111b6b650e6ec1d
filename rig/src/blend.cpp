#include "facecast/rig/blend.hpp"

#include "facecast/core/error.hpp"

namespace facecast::rig {

void Blender::apply_positions(std::span<const float> weights, Positions& positions) const {
  if (weights.size() != rig_.shapes.size()) {
    throw Error("blend: " + std::to_string(weights.size()) + " weights for " +
                std::to_string(rig_.shapes.size()) + " shapes");
  }
  positions = rig_.positions;
  float* out = positions.data();
  for (std::size_t i = 0; i < weights.size(); ++i) {
    const float w = weights[i];
    if (w == 0.0f) continue;
    const Blendshape& s = rig_.shapes[i];
    const float* d = s.deltas.data();
    const int* v = s.vertices.data();
    const std::size_t n = s.vertices.size();
    for (std::size_t k = 0; k < n; ++k) {
      float* p = out + 3 * static_cast<std::size_t>(v[k]);
      p[0] += w * d[3 * k];
      p[1] += w * d[3 * k + 1];
      p[2] += w * d[3 * k + 2];
    }
  }
}

void Blender::apply(std::span<const float> weights, Positions& positions,
                    Positions& normals) const {
  apply_positions(weights, positions);
  vertex_normals(positions, rig_.triangles, normals);
}

}  // namespace facecast::rig
