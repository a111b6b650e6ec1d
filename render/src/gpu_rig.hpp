#pragma once
// Private: a rig laid out for the GPU. The constants here are the one definition of the layout:
// the packing (gpu_rig.cpp), the upload (renderer.cpp) and the GLSL (shaders.cpp, which #defines
// them at the top of the shader source) all read them.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "facecast/rig/body.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::render::detail {

/// Vertex attribute locations. Position and normal come interleaved from one buffer that each frame
/// rewrites (the blended mesh); the others are static.
constexpr int kPositionAttribute = 0, kNormalAttribute = 1, kUvAttribute = 2, kTangentAttribute = 3,
              kSkinAttribute = 4, kSkinWeightAttribute = 5;
/// The most entries of the body's skinning palette (BodySkin), the vertex shader's u_palette (sized
/// per rig): 128 matrices are 512 of the vertex shader's uniform vectors, within the 1024 that
/// llvmpipe and NVIDIA's drivers give (OpenGL 3.3 guarantees 256: a rig that needs more than 64
/// entries, a body with long spring chains, needs a desktop driver).
constexpr int kPaletteSize = 128;
/// Floats per vertex in the blended buffer: position xyz, normal xyz.
constexpr int kBlendedStride = 6;
/// Texture units: one per material texture slot, then the background.
enum TextureSlot {
  kBaseColorSlot,
  kMetallicRoughnessSlot,
  kNormalSlot,
  kOcclusionSlot,
  kEmissiveSlot,
  kSlotCount
};
constexpr int kFirstMaterialUnit = 0, kBackgroundUnit = kFirstMaterialUnit + kSlotCount;

/// A decoded texture as the GPU takes it: RGBA8 rows from the top, sRGB or linear.
struct PackedTexture {
  int width = 0, height = 0;
  bool srgb = false, repeat_s = true, repeat_t = true, nearest = false;
  std::vector<std::uint8_t> rgba;
};

/// Where a material's occlusion is read: its own texture's red channel (glTF), the red channel of
/// its metallic-roughness texture (the same image: an ORM texture, sampled once), or the alpha
/// channel of its normal map or, opaque, of its base colour, where pack_rig copied it (one
/// texture sample fewer per pixel: about a tenth of a textured frame on llvmpipe).
enum OcclusionSource {
  kOwnOcclusion,
  kOcclusionInRoughnessRed,
  kOcclusionInNormalAlpha,
  kOcclusionInBaseAlpha
};

/// A material's uniforms. uv_transform maps (u, v, 1) to the sampled coordinates.
struct PackedMaterial {
  Eigen::Vector4f base_color{1, 1, 1, 1};  // linear
  Eigen::Vector3f emissive{0, 0, 0};
  float metallic = 0, roughness = 1, alpha_cutoff = 0.5f, normal_scale = 1, occlusion_strength = 1;
  rig::AlphaMode alpha_mode = rig::AlphaMode::kOpaque;
  bool double_sided = false;  // else back faces are culled (glTF: counter-clockwise is front)
  bool unlit = false;         // KHR_materials_unlit: the base colour, no lighting
  bool toon = false;          // MToon (rig::Toon): the fields below
  Eigen::Vector3f shade_color{0, 0, 0}, rim_color{0, 0, 0};
  Eigen::Vector4f toon_params{0, 0.9f, 5, 0};      // shift, toony, rim fresnel power, rim lift
  int texture[kSlotCount] = {-1, -1, -1, -1, -1};  // into PackedRig::textures, -1: none
  OcclusionSource occlusion = kOwnOcclusion;  // not kOwnOcclusion: texture[kOcclusionSlot] is -1
  Eigen::Matrix3f uv_transform[kSlotCount];
};

/// How the body pose moves the vertices: linear blend skinning over a small palette. Entry 0
/// stays; entry g > 0 is the motion of joint group_joint[g], one of the joints a BodyPose turns
/// (rig::BodyJoints) or a spring joint (rig::SpringSim; the chains' first joints first when they
/// do not all fit), and carries every joint below it up to the next such joint. Per vertex up to
/// four entries and their weights (PackedRig::skin_groups, skin_weights). Without a skeleton with
/// a head joint, every vertex is entry 1: the whole rig turned with the head about `pivot`.
struct BodySkin {
  bool skinned = false;
  rig::Skeleton skeleton;  // parents, origins and springs (the rig's, posed as drawn at rest)
  rig::BodyJoints joints;
  std::vector<int> group_joint;  // palette entry -> joint; entry 0 (and 1 unskinned): -1
  int head_group = 1;            // the head's entry
  int influences = 1;            // the most entries any vertex blends (1-4)
  Eigen::Vector3f pivot{0, 0, 0};
};

/// One shape's sparse deltas: the vertices it moves or whose normal it changes, and per vertex
/// kBlendedStride floats (position delta, normal delta).
struct PackedMorph {
  std::vector<std::uint32_t> vertices;
  std::vector<float> deltas;
};

/// The rig packed once on the CPU, shared read-only by every GL context.
struct PackedRig {
  std::vector<float> neutral;          // #V * kBlendedStride: position, normal
  std::vector<float> uvs;              // #V * 2 (zeros without UVs)
  std::vector<float> tangents;         // #V * 4 (xyz, handedness); empty without normal maps
  std::vector<float> skin_groups;      // #V * 4: palette entries (BodySkin)
  std::vector<float> skin_weights;     // #V * 4: their weights
  std::vector<PackedMorph> morphs;     // per shape
  std::vector<std::uint32_t> indices;  // triangles sorted by material
  struct Range {
    std::size_t first = 0, count = 0;   // into `indices`
    int material = 0;                   // into `materials`
    Eigen::Vector3f centroid{0, 0, 0};  // of its vertices, to sort blended ranges by depth
  };
  std::vector<Range> ranges;
  // The same ranges simplified (add_lod): drawn while a pixel at the camera's target is at least
  // lod_error / lod_pixels wide; empty without a level of detail.
  std::vector<Range> lod_ranges;
  float lod_error = 0;  // the simplification's error in the neutral, rig units
  std::vector<PackedMaterial> materials;
  std::vector<PackedTexture> textures;
  BodySkin body;
  int shape_count = 0;
};

/// Per shape, the vertices it moves or whose normal it changes (position and normal deltas);
/// triangles grouped by material; textures decoded (an image used both as colour and as data is
/// decoded once, uploaded twice). Throws Error for an invalid rig or an undecodable texture.
PackedRig pack_rig(const rig::Rig& rig);

/// The level of detail (lod.cpp): appends to `p.indices` each range simplified within `max_error`
/// (rig units) of the neutral, with what the shapes fold or move off the simplified surface kept,
/// as `p.lod_ranges`; `p.lod_error` = max_error. The simplified triangles use the same vertices,
/// so the blend is unchanged.
void add_lod(PackedRig& p, float max_error);

/// The blended mesh for `weights` into `out` (#V * kBlendedStride): the neutral plus w_s times
/// the deltas of every shape with w_s != 0. Costs the non-zero shapes' entries, not the mesh.
void blend(const PackedRig& p, std::span<const float> weights, std::vector<float>& out);

}  // namespace facecast::render::detail
