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
constexpr int kPositionAttribute = 0, kNormalAttribute = 1, kMorphAttribute = 2, kUvAttribute = 3,
              kTangentAttribute = 4, kSkinAttribute = 5;
/// Texture units: the morph deltas, then one per material texture slot, then the background.
enum TextureSlot {
  kBaseColorSlot,
  kMetallicRoughnessSlot,
  kNormalSlot,
  kOcclusionSlot,
  kEmissiveSlot,
  kSlotCount
};
constexpr int kDeltaUnit = 0, kFirstMaterialUnit = 1,
              kBackgroundUnit = kFirstMaterialUnit + kSlotCount;

/// A decoded texture as the GPU takes it: RGBA8 rows from the top, sRGB or linear.
struct PackedTexture {
  int width = 0, height = 0;
  bool srgb = false, repeat_s = true, repeat_t = true, nearest = false;
  std::vector<std::uint8_t> rgba;
};

/// A material's uniforms. uv_transform maps (u, v, 1) to the sampled coordinates.
struct PackedMaterial {
  Eigen::Vector4f base_color{1, 1, 1, 1};  // linear
  Eigen::Vector3f emissive{0, 0, 0};
  float metallic = 0, roughness = 1, alpha_cutoff = 0.5f, normal_scale = 1, occlusion_strength = 1;
  anim::AlphaMode alpha_mode = anim::AlphaMode::kOpaque;
  int texture[kSlotCount] = {-1, -1, -1, -1, -1};  // into PackedRig::textures, -1: none
  Eigen::Matrix3f uv_transform[kSlotCount];
};

/// How the head pose moves the vertices: per vertex (a_skin) the weight of the neck's motion
/// alone and of the head's motion (neck then head); the rest stays. Without a skeleton every
/// vertex follows the head, turned about `pivot`.
struct HeadJoints {
  bool skeleton = false;
  bool has_neck = false;
  Eigen::Vector3f neck{0, 0, 0}, head{0, 0, 0};  // pivots
};

/// The rig packed once on the CPU, shared read-only by every GL context.
struct PackedRig {
  std::vector<float> positions, normals;  // #V * 3
  std::vector<float> uvs;                 // #V * 2 (zeros without UVs)
  std::vector<float> tangents;            // #V * 4 (xyz, handedness); empty without normal maps
  std::vector<float> skin;                // #V * 2: neck-only weight, head weight
  std::vector<std::int32_t> morph;        // #V * 2: first entry, entry count
  std::vector<float> deltas;              // kDeltaWidth * delta_rows * 4 (RGBA32F texels)
  int delta_rows = 0;
  std::vector<std::uint32_t> indices;  // triangles sorted by material
  struct Range {
    std::size_t first = 0, count = 0;   // into `indices`
    int material = 0;                   // into `materials`
    Eigen::Vector3f centroid{0, 0, 0};  // of its vertices, to sort blended ranges by depth
  };
  std::vector<Range> ranges;
  std::vector<PackedMaterial> materials;
  std::vector<PackedTexture> textures;
  HeadJoints head;
  int shape_count = 0;
};

/// Per vertex, the shapes that move it or change its normal (position and normal deltas), in the
/// delta texture; triangles grouped by material; textures decoded (an image used both as colour
/// and as data is decoded once, uploaded twice). Throws Error for an invalid rig, an undecodable
/// texture or more than kMaxShapes shapes.
PackedRig pack_rig(const anim::Rig& rig);

}  // namespace facecast::render::detail
