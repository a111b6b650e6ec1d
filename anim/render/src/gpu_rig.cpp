// Packing a rig for the GPU: morph deltas bucketed by vertex into a float texture, triangles
// grouped by material.
#include "gpu_rig.hpp"

#include <algorithm>
#include <numeric>

#include "facecast/core/error.hpp"

namespace facecast::render::detail {

PackedRig pack_rig(const anim::Rig& rig) {
  rig.validate("render rig");
  if (rig.shapes.size() > static_cast<std::size_t>(kMaxShapes))
    throw Error("renderer: " + std::to_string(rig.shapes.size()) + " shapes, at most " +
                    std::to_string(kMaxShapes) + " are supported",
                ErrorCode::kUnsupported);
  PackedRig p;
  const int nv = rig.vertex_count();
  p.shape_count = static_cast<int>(rig.shapes.size());
  p.positions.assign(rig.positions.data(), rig.positions.data() + rig.positions.size());
  p.normals.assign(rig.normals.data(), rig.normals.data() + rig.normals.size());

  // Per shape: position deltas and normal deltas (shape normals minus neutral normals) wherever
  // either is non-zero; then bucketed by vertex.
  struct Entry {
    int shape;
    Eigen::Vector3f dp, dn;
  };
  std::vector<std::vector<Entry>> per_vertex(static_cast<std::size_t>(nv));
  const anim::Positions base_n = anim::vertex_normals(rig.positions, rig.triangles);
  anim::Positions moved, moved_n;
  for (int s = 0; s < p.shape_count; ++s) {
    const auto& sh = rig.shapes[static_cast<std::size_t>(s)];
    moved = rig.positions;
    for (std::size_t i = 0; i < sh.vertices.size(); ++i)
      moved.row(sh.vertices[i]) += sh.deltas.row(static_cast<Eigen::Index>(i));
    anim::vertex_normals(moved, rig.triangles, moved_n);
    std::vector<char> touched(static_cast<std::size_t>(nv), 0);
    for (int v : sh.vertices) touched[static_cast<std::size_t>(v)] = 1;
    std::size_t k = 0;
    for (int v = 0; v < nv; ++v) {
      const Eigen::Vector3f dn = (moved_n.row(v) - base_n.row(v)).transpose();
      const bool moves = touched[static_cast<std::size_t>(v)] != 0;
      if (!moves && dn.squaredNorm() < 1e-8f) continue;
      Eigen::Vector3f dp = Eigen::Vector3f::Zero();
      if (moves) {
        while (sh.vertices[k] != v) ++k;
        dp = sh.deltas.row(static_cast<Eigen::Index>(k)).transpose();
      }
      per_vertex[static_cast<std::size_t>(v)].push_back({s, dp, dn});
    }
  }
  p.morph.resize(static_cast<std::size_t>(nv) * 2);
  std::size_t entries = 0;
  for (int v = 0; v < nv; ++v) {
    p.morph[2 * v] = static_cast<std::int32_t>(entries);
    p.morph[2 * v + 1] = static_cast<std::int32_t>(per_vertex[static_cast<std::size_t>(v)].size());
    entries += per_vertex[static_cast<std::size_t>(v)].size();
  }
  p.delta_rows = std::max<int>(
      1, static_cast<int>((entries * kTexelsPerEntry + kDeltaWidth - 1) / kDeltaWidth));
  p.deltas.assign(static_cast<std::size_t>(kDeltaWidth) * p.delta_rows * 4, 0.0f);
  std::size_t e = 0;
  for (const auto& list : per_vertex)
    for (const auto& en : list) {
      float* t = &p.deltas[e * kTexelsPerEntry * 4];
      t[0] = en.dp.x(), t[1] = en.dp.y(), t[2] = en.dp.z(), t[3] = static_cast<float>(en.shape);
      t[4] = en.dn.x(), t[5] = en.dn.y(), t[6] = en.dn.z(), t[7] = 0;
      ++e;
    }

  std::vector<int> order(static_cast<std::size_t>(rig.triangle_count()));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return rig.triangle_material[static_cast<std::size_t>(a)] <
           rig.triangle_material[static_cast<std::size_t>(b)];
  });
  for (std::size_t i = 0; i < order.size();) {
    const int m = rig.triangle_material[static_cast<std::size_t>(order[i])];
    PackedRig::Range r;
    r.first = p.indices.size();
    r.color = rig.materials[static_cast<std::size_t>(m)].base_color.head<3>();
    for (; i < order.size() && rig.triangle_material[static_cast<std::size_t>(order[i])] == m; ++i)
      for (int c = 0; c < 3; ++c)
        p.indices.push_back(static_cast<std::uint32_t>(rig.triangles(order[i], c)));
    r.count = p.indices.size() - r.first;
    p.ranges.push_back(r);
  }
  return p;
}

}  // namespace facecast::render::detail
