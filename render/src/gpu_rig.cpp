// Packing a rig for the GPU: sparse morph deltas per shape (blended on the CPU each frame),
// triangles grouped by material, materials and their decoded textures, tangents for normal maps,
// and the head pose's per-vertex weights from the skeleton.
#include "gpu_rig.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"

namespace facecast::render::detail {
namespace {

using rig::Rig;

// Per shape: position deltas and normal deltas (shape normals minus neutral normals) wherever
// either is non-zero.
void pack_morphs(const Rig& rig, PackedRig& p) {
  const int nv = rig.vertex_count();
  const rig::Positions base_n = rig::vertex_normals(rig.positions, rig.triangles);
  rig::Positions moved, moved_n;
  std::vector<char> touched(static_cast<std::size_t>(nv));
  for (const auto& sh : rig.shapes) {
    moved = rig.positions;
    for (std::size_t i = 0; i < sh.vertices.size(); ++i)
      moved.row(sh.vertices[i]) += sh.deltas.row(static_cast<Eigen::Index>(i));
    rig::vertex_normals(moved, rig.triangles, moved_n);
    std::fill(touched.begin(), touched.end(), 0);
    for (int v : sh.vertices) touched[static_cast<std::size_t>(v)] = 1;
    PackedMorph& m = p.morphs.emplace_back();
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
      m.vertices.push_back(static_cast<std::uint32_t>(v));
      m.deltas.insert(m.deltas.end(), {dp.x(), dp.y(), dp.z(), dn.x(), dn.y(), dn.z()});
    }
  }
}

// uv' = offset + R(rotation) * (scale .* uv), as a 3x3 matrix on (u, v, 1) (KHR_texture_transform).
Eigen::Matrix3f uv_matrix(const rig::TextureRef& t) {
  Eigen::Matrix3f m = Eigen::Matrix3f::Identity();
  const float c = std::cos(t.rotation), s = std::sin(t.rotation);
  m(0, 0) = c * t.scale.x();
  m(0, 1) = s * t.scale.y();
  m(1, 0) = -s * t.scale.x();
  m(1, 1) = c * t.scale.y();
  m(0, 2) = t.offset.x();
  m(1, 2) = t.offset.y();
  return m;
}

// Materials with their textures decoded; each (image, colour space) pair is uploaded once.
void pack_materials(const Rig& rig, PackedRig& p) {
  std::map<std::pair<int, bool>, int> uploaded;
  std::map<int, Image> decoded;
  const auto texture = [&](const rig::TextureRef& ref, bool srgb) {
    if (ref.texture < 0) return -1;
    const auto key = std::make_pair(ref.texture, srgb);
    if (auto it = uploaded.find(key); it != uploaded.end()) return it->second;
    const rig::Texture& t = rig.textures[static_cast<std::size_t>(ref.texture)];
    auto it = decoded.find(ref.texture);
    if (it == decoded.end())
      it =
          decoded
              .emplace(ref.texture, decode_image(t.bytes, "texture " + std::to_string(ref.texture) +
                                                              " '" + t.name + "'"))
              .first;
    PackedTexture pt;
    pt.width = it->second.width;
    pt.height = it->second.height;
    pt.srgb = srgb;
    pt.repeat_s = t.repeat_s;
    pt.repeat_t = t.repeat_t;
    pt.nearest = t.nearest;
    pt.rgba = it->second.pixels;
    p.textures.push_back(std::move(pt));
    return uploaded[key] = static_cast<int>(p.textures.size()) - 1;
  };
  for (const rig::Material& m : rig.materials) {
    PackedMaterial pm;
    pm.base_color = m.base_color;
    pm.emissive = m.emissive;
    pm.metallic = m.metallic;
    pm.roughness = m.roughness;
    pm.alpha_mode = m.alpha_mode;
    pm.alpha_cutoff = m.alpha_cutoff;
    pm.double_sided = m.double_sided;
    pm.unlit = m.unlit;
    if (m.toon) {
      pm.toon = true;
      pm.shade_color = m.toon->shade_color;
      pm.rim_color = m.toon->rim_color;
      pm.toon_params << m.toon->shading_shift, m.toon->shading_toony, m.toon->rim_fresnel_power,
          m.toon->rim_lift;
    }
    pm.normal_scale = m.normal_texture.strength;
    pm.occlusion_strength = m.occlusion_texture.strength;
    const rig::TextureRef* refs[kSlotCount] = {&m.base_color_texture, &m.metallic_roughness_texture,
                                               &m.normal_texture, &m.occlusion_texture,
                                               &m.emissive_texture};
    for (int slot = 0; slot < kSlotCount; ++slot) {
      const bool srgb = slot == kBaseColorSlot || slot == kEmissiveSlot;
      pm.texture[slot] = rig.uvs.rows() ? texture(*refs[slot], srgb) : -1;
      pm.uv_transform[slot] = uv_matrix(*refs[slot]);
    }
    p.materials.push_back(pm);
  }
}

// Each material's occlusion folded into a texture it samples anyway (OcclusionSource): the
// metallic-roughness texture when it is the same image, else a copy of its normal map or (opaque)
// base colour with the occlusion's red channel in its alpha, when the two images have the same
// size, UV transform and sampling (then their filtered values match texel for texel). Textures
// nothing samples any more are dropped.
void fold_occlusion(PackedRig& p) {
  std::map<std::pair<int, int>, int> folded;  // (carrier, occlusion) -> the carrier's copy
  for (PackedMaterial& m : p.materials) {
    const int occlusion = m.texture[kOcclusionSlot];
    if (occlusion < 0) continue;
    const auto same_sampling = [&](int slot) {
      const int t = m.texture[slot];
      if (t < 0 || !m.uv_transform[slot].isApprox(m.uv_transform[kOcclusionSlot])) return false;
      const PackedTexture &a = p.textures[static_cast<std::size_t>(t)],
                          &b = p.textures[static_cast<std::size_t>(occlusion)];
      return a.width == b.width && a.height == b.height && a.repeat_s == b.repeat_s &&
             a.repeat_t == b.repeat_t && a.nearest == b.nearest;
    };
    if (m.texture[kMetallicRoughnessSlot] == occlusion && same_sampling(kMetallicRoughnessSlot)) {
      m.occlusion = kOcclusionInRoughnessRed;
    } else {
      int carrier = -1;
      if (same_sampling(kNormalSlot)) {
        carrier = kNormalSlot;
        m.occlusion = kOcclusionInNormalAlpha;
      } else if (m.alpha_mode == rig::AlphaMode::kOpaque && same_sampling(kBaseColorSlot)) {
        carrier = kBaseColorSlot;
        m.occlusion = kOcclusionInBaseAlpha;
      } else {
        continue;
      }
      const auto key = std::make_pair(m.texture[carrier], occlusion);
      auto it = folded.find(key);
      if (it == folded.end()) {
        PackedTexture copy = p.textures[static_cast<std::size_t>(key.first)];
        const auto& red = p.textures[static_cast<std::size_t>(occlusion)].rgba;
        for (std::size_t i = 3; i < copy.rgba.size(); i += 4) copy.rgba[i] = red[i - 3];
        p.textures.push_back(std::move(copy));
        it = folded.emplace(key, static_cast<int>(p.textures.size()) - 1).first;
      }
      m.texture[carrier] = it->second;
    }
    m.texture[kOcclusionSlot] = -1;
  }
  std::vector<int> index(p.textures.size(), -1);
  for (const PackedMaterial& m : p.materials)
    for (int t : m.texture)
      if (t >= 0) index[static_cast<std::size_t>(t)] = 0;
  std::vector<PackedTexture> kept;
  for (std::size_t t = 0; t < p.textures.size(); ++t)
    if (index[t] == 0) {
      index[t] = static_cast<int>(kept.size());
      kept.push_back(std::move(p.textures[t]));
    }
  p.textures = std::move(kept);
  for (PackedMaterial& m : p.materials)
    for (int& t : m.texture)
      if (t >= 0) t = index[static_cast<std::size_t>(t)];
}

// Per-vertex tangents from the UVs (the sum over a vertex's triangles of each triangle's
// d(position)/du, orthogonalised against the normal; w is the handedness of the UV frame).
void pack_tangents(const Rig& rig, PackedRig& p) {
  const int nv = rig.vertex_count();
  std::vector<Eigen::Vector3f> tu(static_cast<std::size_t>(nv), Eigen::Vector3f::Zero()), tv = tu;
  for (int f = 0; f < rig.triangle_count(); ++f) {
    const int a = rig.triangles(f, 0), b = rig.triangles(f, 1), c = rig.triangles(f, 2);
    const Eigen::Vector3f e1 = (rig.positions.row(b) - rig.positions.row(a)).transpose(),
                          e2 = (rig.positions.row(c) - rig.positions.row(a)).transpose();
    const Eigen::Vector2f d1 = (rig.uvs.row(b) - rig.uvs.row(a)).transpose(),
                          d2 = (rig.uvs.row(c) - rig.uvs.row(a)).transpose();
    const float det = d1.x() * d2.y() - d2.x() * d1.y();
    if (std::abs(det) < 1e-12f) continue;
    const Eigen::Vector3f u = (e1 * d2.y() - e2 * d1.y()) / det,
                          v = (e2 * d1.x() - e1 * d2.x()) / det;
    for (int k : {a, b, c}) {
      tu[static_cast<std::size_t>(k)] += u;
      tv[static_cast<std::size_t>(k)] += v;
    }
  }
  p.tangents.resize(static_cast<std::size_t>(nv) * 4);
  for (int v = 0; v < nv; ++v) {
    const Eigen::Vector3f n = rig.normals.row(v).transpose();
    Eigen::Vector3f t =
        tu[static_cast<std::size_t>(v)] - n * n.dot(tu[static_cast<std::size_t>(v)]);
    if (t.squaredNorm() < 1e-20f) t = n.unitOrthogonal();
    t.normalize();
    const float w = n.cross(t).dot(tv[static_cast<std::size_t>(v)]) < 0 ? -1.0f : 1.0f;
    float* o = &p.tangents[static_cast<std::size_t>(v) * 4];
    o[0] = t.x(), o[1] = t.y(), o[2] = t.z(), o[3] = w;
  }
}

// The body's palette (BodySkin): each joint's entry is that of the nearest joint at or above it
// that the body turns; each vertex's weights summed per entry. Without a skeleton with a head
// joint, every vertex turns with the head about a pivot at the centre of the mesh's bounds in x
// and z, 10 % above its bottom.
void pack_body(const Rig& rig, PackedRig& p) {
  const int nv = rig.vertex_count();
  const rig::Skeleton& sk = rig.skeleton;
  BodySkin& b = p.body;
  p.skin_groups.assign(static_cast<std::size_t>(nv) * 4, 0.0f);
  p.skin_weights.assign(static_cast<std::size_t>(nv) * 4, 0.0f);
  b.joints = rig::find_body_joints(sk);
  if (b.joints.head >= 0 && rig.joints.rows() == nv) {
    // A spine longer than the palette holds leans on its top joints only.
    auto& spine = b.joints.spine;
    const std::size_t room = kPaletteSize - 1 - (b.joints.all().size() - spine.size());
    if (spine.size() > room) spine.erase(spine.begin(), spine.end() - static_cast<long>(room));
    b.skinned = true;
    b.skeleton.parent = sk.parent;
    b.skeleton.rest_origin = sk.rest_origin;
    b.skeleton.springs = sk.springs;
    b.group_joint.assign(1, -1);
    const std::size_t nj = sk.parent.size();
    std::vector<int> entry(nj, -1);  // the palette entry of each turned joint
    for (const int j : b.joints.all()) {
      entry[static_cast<std::size_t>(j)] = static_cast<int>(b.group_joint.size());
      b.group_joint.push_back(j);
    }
    // Spring joints by their place in the chain (every first joint, then every second ...) while
    // the palette has room; a joint left out swings with the one above it.
    bool deeper = true;
    for (std::size_t k = 0; deeper && b.group_joint.size() < kPaletteSize; ++k) {
      deeper = false;  // some chain has a k-th joint
      for (const auto& spring : sk.springs.springs)
        if (k < spring.joints.size() && b.group_joint.size() < kPaletteSize) {
          const auto j = static_cast<std::size_t>(spring.joints[k].joint);
          deeper = true;
          if (entry[j] >= 0) continue;
          entry[j] = static_cast<int>(b.group_joint.size());
          b.group_joint.push_back(static_cast<int>(j));
        }
    }
    b.head_group = entry[static_cast<std::size_t>(b.joints.head)];
    std::vector<int> group(nj, 0);
    for (std::size_t j = 0; j < nj; ++j) {
      int a = static_cast<int>(j);
      for (std::size_t guard = 0; a >= 0 && entry[static_cast<std::size_t>(a)] < 0 && guard <= nj;
           ++guard)
        a = sk.parent[static_cast<std::size_t>(a)];
      group[j] = a >= 0 && entry[static_cast<std::size_t>(a)] >= 0
                     ? entry[static_cast<std::size_t>(a)]
                     : 0;
    }
    for (int v = 0; v < nv; ++v) {
      float* g = &p.skin_groups[4 * static_cast<std::size_t>(v)];
      float* w = &p.skin_weights[4 * static_cast<std::size_t>(v)];
      int used = 0;
      float total = 0;
      for (int k = 0; k < 4; ++k) {
        const int j = rig.joints(v, k);
        const float wk = rig.joint_weights(v, k);
        if (wk <= 0 || j < 0 || static_cast<std::size_t>(j) >= nj) continue;
        const auto e = static_cast<float>(group[static_cast<std::size_t>(j)]);
        int at = 0;
        while (at < used && g[at] != e) ++at;
        if (at == used) g[used++] = e;
        w[at] += wk;
        total += wk;
      }
      if (total <= 1e-6f) {
        w[0] = 1;  // entry 0: stays
        continue;
      }
      for (int k = 0; k < used; ++k) w[k] /= total;
      b.influences = std::max(b.influences, used);
    }
    return;
  }
  const Eigen::Vector3f lo = rig.positions.colwise().minCoeff().transpose();
  const Eigen::Vector3f hi = rig.positions.colwise().maxCoeff().transpose();
  b.pivot = {0.5f * (lo.x() + hi.x()), lo.y() + 0.1f * (hi.y() - lo.y()), 0.5f * (lo.z() + hi.z())};
  b.group_joint = {-1, -1};
  b.head_group = 1;
  for (int v = 0; v < nv; ++v) {
    p.skin_groups[4 * static_cast<std::size_t>(v)] = 1;
    p.skin_weights[4 * static_cast<std::size_t>(v)] = 1;
  }
}

void pack_ranges(const Rig& rig, PackedRig& p) {
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
    r.material = m;
    for (; i < order.size() && rig.triangle_material[static_cast<std::size_t>(order[i])] == m; ++i)
      for (int c = 0; c < 3; ++c) {
        const int v = rig.triangles(order[i], c);
        p.indices.push_back(static_cast<std::uint32_t>(v));
        r.centroid += rig.positions.row(v).transpose();
      }
    r.count = p.indices.size() - r.first;
    r.centroid /= static_cast<float>(std::max<std::size_t>(1, r.count));
    p.ranges.push_back(r);
  }
}

}  // namespace

PackedRig pack_rig(const Rig& rig) {
  rig.validate("render rig");
  PackedRig p;
  p.shape_count = static_cast<int>(rig.shapes.size());
  p.neutral.resize(static_cast<std::size_t>(rig.vertex_count()) * kBlendedStride);
  for (int v = 0; v < rig.vertex_count(); ++v)
    for (int c = 0; c < 3; ++c) {
      p.neutral[static_cast<std::size_t>(v) * kBlendedStride + c] = rig.positions(v, c);
      p.neutral[static_cast<std::size_t>(v) * kBlendedStride + 3 + c] = rig.normals(v, c);
    }
  if (rig.uvs.rows())
    p.uvs.assign(rig.uvs.data(), rig.uvs.data() + rig.uvs.size());
  else
    p.uvs.assign(static_cast<std::size_t>(rig.vertex_count()) * 2, 0.0f);
  pack_morphs(rig, p);
  pack_materials(rig, p);
  fold_occlusion(p);
  const bool normal_maps = std::any_of(p.materials.begin(), p.materials.end(),
                                       [](const auto& m) { return m.texture[kNormalSlot] >= 0; });
  if (normal_maps) pack_tangents(rig, p);
  pack_body(rig, p);
  pack_ranges(rig, p);
  return p;
}

void blend(const PackedRig& p, std::span<const float> weights, std::vector<float>& out) {
  out = p.neutral;
  const std::size_t n = std::min(weights.size(), p.morphs.size());
  for (std::size_t s = 0; s < n; ++s) {
    const float w = weights[s];
    if (w == 0.0f) continue;
    const PackedMorph& m = p.morphs[s];
    const float* d = m.deltas.data();
    for (const std::uint32_t v : m.vertices) {
      float* o = &out[static_cast<std::size_t>(v) * kBlendedStride];
      for (int c = 0; c < kBlendedStride; ++c) o[c] += w * d[c];
      d += kBlendedStride;
    }
  }
}

}  // namespace facecast::render::detail
