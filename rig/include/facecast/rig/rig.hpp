#pragma once
// The Rig: a neutral mesh plus named blendshapes stored as sparse vertex deltas.
//
// Units are those of the source mesh (ICT FaceKit: centimetres); +Y up, the face looks along +Z.
// Vertex order is the order of the source file and is never changed by Facecast: expressions of the
// ICT FaceKit and marker files refer to vertices by index.
#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facecast/rig/mesh.hpp"

namespace facecast::rig {

/// An image a material samples, as stored in the file: encoded PNG, JPEG or WebP bytes (the
/// renderer decodes them; KTX2 it refuses), with its sampler's wrap and filter modes.
struct Texture {
  std::string name;
  std::string mime_type;                  // "image/png", "image/jpeg" or "image/webp"
  std::string bytes;                      // the encoded image
  bool repeat_s = true, repeat_t = true;  // REPEAT (or MIRRORED_REPEAT) vs CLAMP_TO_EDGE
  bool nearest = false;                   // NEAREST magnification instead of LINEAR
};

/// A material's use of a texture (glTF textureInfo with KHR_texture_transform folded in): the
/// UV set is transformed as uv' = offset + R(rotation) * (scale .* uv) before sampling.
struct TextureRef {
  int texture = -1;  // index into Rig::textures; -1: no texture
  Eigen::Vector2f offset{0.0f, 0.0f};
  Eigen::Vector2f scale{1.0f, 1.0f};
  float rotation = 0.0f;  // radians
  float strength = 1.0f;  // normalTexture.scale or occlusionTexture.strength; 1 otherwise
};

enum class AlphaMode { kOpaque, kMask, kBlend };

/// An sRGB-encoded value in [0, 1] as linear light (the sRGB transfer function's inverse).
inline float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

/// VRM's MToon (VRMC_materials_mtoon; VRM 0.x "VRM/MToon" through UniVRM's migration), drawn
/// approximately: the lit (base) and shade colours split by a toon ramp of each light,
/// shade = linearstep(-1 + toony, 1 - toony, n.l + shift), plus a parametric rim
/// rim_color * (1 - n.v + rim_lift)^rim_fresnel_power. Textures other than the base colour's
/// (shade multiply, shift, rim, matcap) and outlines are not drawn.
struct Toon {
  Eigen::Vector3f shade_color{0.0f, 0.0f, 0.0f};  // linear
  float shading_shift = 0.0f, shading_toony = 0.9f;
  Eigen::Vector3f rim_color{0.0f, 0.0f, 0.0f};  // linear
  float rim_fresnel_power = 5.0f, rim_lift = 0.0f;
};

/// A glTF metallic-roughness material. Colours are linear; textures hold sRGB base colour and
/// emissive, linear metallic (B) / roughness (G), tangent-space normals and occlusion (R).
struct Material {
  std::string name;
  Eigen::Vector4f base_color{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA
  float metallic = 0.0f;
  float roughness = 0.6f;
  Eigen::Vector3f emissive{0.0f, 0.0f, 0.0f};  // KHR_materials_emissive_strength folded in
  bool unlit = false;                          // KHR_materials_unlit: the base colour as it is
  std::optional<Toon> toon;                    // a VRM MToon material
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha_cutoff = 0.5f;  // for kMask
  bool double_sided = false;
  TextureRef base_color_texture, metallic_roughness_texture, normal_texture, occlusion_texture,
      emissive_texture;

  /// A plain coloured material without textures.
  static Material solid(std::string name,
                        const Eigen::Vector4f& color = Eigen::Vector4f(0.8f, 0.8f, 0.8f, 1.0f)) {
    Material m;
    m.name = std::move(name);
    m.base_color = color;
    return m;
  }
};

/// One simulated joint of a spring chain (VRMC_springBone, VRM 0.x secondaryAnimation): the joint
/// turns so that its tail, a point mass on a rod, trails the motion of the joint's parent.
struct SpringJoint {
  int joint = 0;                  // into the skeleton
  Eigen::Vector3f tail{0, 0, 0};  // the tail at rest: the next joint's origin, or 7 cm on (VRM 0.x)
  float hit_radius = 0, stiffness = 1, gravity_power = 0, drag = 0.5f;
  Eigen::Vector3f gravity_dir{0, -1, 0};  // in the rig's axes
};

/// A sphere (a capsule when `capsule`: from `offset` to `tail`) that spring tails stay out of,
/// carried by `joint` (-1: fixed); positions at rest in the rig's axes.
struct SpringCollider {
  int joint = -1;
  Eigen::Vector3f offset{0, 0, 0}, tail{0, 0, 0};
  float radius = 0;
  bool capsule = false;
};

/// The spring bones of an avatar: chains simulated root first, in order.
struct SpringBones {
  struct Spring {
    std::vector<SpringJoint> joints;  // root first; each carries the ones after it
    std::vector<int> colliders;       // into `colliders`
  };
  std::vector<Spring> springs;
  std::vector<SpringCollider> colliders;
  bool empty() const { return springs.empty(); }
};

/// The skeleton of a skinned avatar, in the rig's (bind pose) coordinates. The rig's vertices are
/// already skinned to the rest pose; the renderer moves only the joints the head pose turns.
struct Skeleton {
  std::vector<std::string> joint_names;
  std::vector<int> parent;                   // -1 for a root
  std::vector<Eigen::Vector3f> rest_origin;  // each joint's origin in the bind pose
  int head = -1;                             // the head joint, or -1
  int neck = -1;                             // the neck joint, or -1
  // The VRM humanoid's bones (VRM 1.0 names: "leftUpperArm" ...) and their joints, when the file
  // has them; `vrm0`: a VRM 0.x file (its figure, facing -Z in the file, was turned to face +Z).
  std::vector<std::pair<std::string, int>> humanoid;
  bool vrm0 = false;
  SpringBones springs;  // hair and clothes that swing (spring_sim.hpp)
  /// The joint of a humanoid bone, or -1.
  int humanoid_bone(std::string_view bone) const {
    for (const auto& [name, joint] : humanoid)
      if (name == bone) return joint;
    return -1;
  }
};

/// A blendshape: the vertices it moves (ascending, unique) and their deltas from the neutral.
struct Blendshape {
  std::string name;
  std::vector<int> vertices;
  Positions deltas;  // vertices.size() by 3

  /// Builds the sparse form from #V by 3 deltas, keeping rows whose largest |component| >
  /// tolerance.
  static Blendshape from_dense(std::string name, const Positions& dense, float tolerance = 0.0f);
  /// #V by 3 deltas with zeros where the shape does not move.
  Positions dense(int vertex_count) const;
  /// Largest vertex displacement (Euclidean length of a delta).
  float max_displacement() const;
};

/// A named vertex: a landmark or a marker.
struct Landmark {
  std::string name;
  int vertex = 0;
};

/// One glTF mesh of a rig written as several (the head, teeth, eyes ... as real avatars have them):
/// a consecutive range of vertices, and the triangles on them.
struct MeshRange {
  std::string name;
  int first_vertex = 0, vertex_count = 0;
};

struct Rig {
  Positions positions;                 // #V by 3, the neutral face
  Positions normals;                   // #V by 3, unit length
  UVs uvs;                             // #V by 2, or 0 rows when the mesh has none
  Triangles triangles;                 // #F by 3
  std::vector<int> triangle_material;  // #F, index into materials
  std::vector<Material> materials;     // at least one
  std::vector<int> triangle_group;     // #F, index into groups (OBJ "g"); may be empty
  std::vector<std::string> groups;
  std::vector<Blendshape> shapes;
  std::vector<Landmark> landmarks;
  std::vector<Texture> textures;  // images the materials sample (through uvs)
  /// The meshes the rig is written as, covering every vertex in order; empty: one mesh.
  std::vector<MeshRange> meshes;
  Skeleton skeleton;  // empty when the avatar is not skinned
  /// #V by 4 joint indices into skeleton and their weights (summing to 1), or 0 rows when the
  /// avatar is not skinned.
  Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> joints;
  Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> joint_weights;

  int vertex_count() const { return static_cast<int>(positions.rows()); }
  int triangle_count() const { return static_cast<int>(triangles.rows()); }
  /// Index of the shape named `name`, or -1.
  int find_shape(std::string_view name) const;
  std::vector<std::string> shape_names() const;
  /// Index into `meshes` of the range holding `vertex` (-1 without meshes).
  int mesh_of(int vertex) const;
  /// Checks sizes, index ranges and finiteness; throws facecast::Error naming `what` and the
  /// problem.
  void validate(std::string_view what = "rig") const;
};

}  // namespace facecast::rig
