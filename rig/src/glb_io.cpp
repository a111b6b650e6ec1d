// GLB (binary glTF 2.0) reading and writing with tinygltf.
//
// Layout written: one buffer; one mesh, or one per Rig::meshes range (consecutive vertices, so the
// file keeps the rig's vertex order), or with GlbOptions::mesh_per_group one per Rig group with
// the vertices its triangles use, in rig order; in a mesh, POSITION, NORMAL, TEXCOORD_0 (and
// JOINTS_0/WEIGHTS_0 for a skinned rig) accessors shared by every primitive (one primitive per
// material, each with its own uint32 indices), so a one-mesh file keeps the rig's vertex order
// exactly; one POSITION morph target per shape (per group: the shapes that move it), as deltas
// with min/max, sparse (the rows that move) when fewer than half the rows move; shape names in
// mesh.extras.targetNames (three.js and Blender read them); default weights 0. Landmarks go to
// mesh.extras.facecast.landmarks. Textures are written as the Rig holds them (encoded bytes),
// materials as glTF metallic-roughness with KHR_texture_transform; the skeleton as joint nodes at
// their rest origins with one skin.
#include <tiny_gltf.h>
#include <map>
#include <sstream>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"

namespace facecast::rig {
namespace {

constexpr const char* kGenerator = "facecast";

class GlbWriter {
 public:
  tinygltf::Model model;

  GlbWriter() { model.buffers.emplace_back(); }

  int add_view(const void* data, std::size_t bytes, int target) {
    auto& buf = model.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buf.size();
    view.byteLength = bytes;
    view.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    model.bufferViews.push_back(view);
    return static_cast<int>(model.bufferViews.size()) - 1;
  }

  template <typename Matrix>
  int add_float_accessor(const Matrix& m, int type, bool with_bounds) {
    tinygltf::Accessor a;
    a.bufferView = add_view(m.data(), static_cast<std::size_t>(m.size()) * sizeof(float),
                            TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = static_cast<std::size_t>(m.rows());
    a.type = type;
    if (with_bounds) {
      for (Eigen::Index c = 0; c < m.cols(); ++c) {
        a.minValues.push_back(m.rows() ? m.col(c).minCoeff() : 0.0);
        a.maxValues.push_back(m.rows() ? m.col(c).maxCoeff() : 0.0);
      }
    }
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
  }

  // A morph target as a sparse accessor (no bufferView: zeros, then the rows that move) when
  // fewer than half its rows move; dense otherwise. min/max over all rows, as POSITION needs.
  int add_target_accessor(const Positions& d) {
    std::vector<std::uint32_t> rows;
    for (Eigen::Index r = 0; r < d.rows(); ++r)
      if (!d.row(r).isZero(0.0f)) rows.push_back(static_cast<std::uint32_t>(r));
    if (2 * rows.size() >= static_cast<std::size_t>(d.rows()))
      return add_float_accessor(d, TINYGLTF_TYPE_VEC3, true);
    if (rows.empty()) rows.push_back(0);  // a sparse accessor holds at least one row
    Positions values(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i)
      values.row(static_cast<Eigen::Index>(i)) = d.row(rows[i]);
    tinygltf::Accessor a;
    a.bufferView = -1;
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = static_cast<std::size_t>(d.rows());
    a.type = TINYGLTF_TYPE_VEC3;
    for (Eigen::Index c = 0; c < 3; ++c) {
      a.minValues.push_back(d.rows() ? d.col(c).minCoeff() : 0.0);
      a.maxValues.push_back(d.rows() ? d.col(c).maxCoeff() : 0.0);
    }
    a.sparse.isSparse = true;
    a.sparse.count = static_cast<int>(rows.size());
    a.sparse.indices.bufferView = add_view(rows.data(), rows.size() * sizeof(std::uint32_t), 0);
    a.sparse.indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    a.sparse.indices.byteOffset = 0;
    a.sparse.values.byteOffset = 0;
    a.sparse.values.bufferView =
        add_view(values.data(), static_cast<std::size_t>(values.size()) * sizeof(float), 0);
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
  }

  int add_int_accessor(const void* data, Eigen::Index count, int component, int type) {
    tinygltf::Accessor a;
    const auto bytes = static_cast<std::size_t>(count) *
                       static_cast<std::size_t>(tinygltf::GetComponentSizeInBytes(component) *
                                                tinygltf::GetNumComponentsInType(type));
    a.bufferView = add_view(data, bytes, TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = component;
    a.count = static_cast<std::size_t>(count);
    a.type = type;
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
  }

  int add_index_accessor(const std::vector<std::uint32_t>& idx) {
    tinygltf::Accessor a;
    a.bufferView = add_view(idx.data(), idx.size() * sizeof(std::uint32_t),
                            TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    a.count = idx.size();
    a.type = TINYGLTF_TYPE_SCALAR;
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
  }
};

tinygltf::Value string_array(const std::vector<std::string>& items) {
  tinygltf::Value::Array arr;
  for (const auto& s : items) arr.emplace_back(s);
  return tinygltf::Value(std::move(arr));
}

}  // namespace

namespace {

tinygltf::Value landmark_extras(const std::vector<Landmark>& landmarks) {
  tinygltf::Value::Array marks;
  for (const auto& l : landmarks) {
    tinygltf::Value::Object o;
    o["name"] = tinygltf::Value(l.name);
    o["vertex"] = tinygltf::Value(l.vertex);
    marks.emplace_back(std::move(o));
  }
  tinygltf::Value::Object fc;
  fc["landmarks"] = tinygltf::Value(std::move(marks));
  return tinygltf::Value(std::move(fc));
}

// A textureInfo from a TextureRef; KHR_texture_transform when it is not the identity.
template <typename Info>
void set_texture(Info& info, const TextureRef& ref, bool& transformed) {
  info.index = ref.texture;
  if (ref.texture < 0) return;
  if (ref.offset.isZero() && ref.scale.isOnes() && ref.rotation == 0.0f) return;
  tinygltf::Value::Object t;
  t["offset"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(double(ref.offset[0])),
                                                       tinygltf::Value(double(ref.offset[1]))});
  t["scale"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(double(ref.scale[0])),
                                                      tinygltf::Value(double(ref.scale[1]))});
  t["rotation"] = tinygltf::Value(double(ref.rotation));
  info.extensions["KHR_texture_transform"] = tinygltf::Value(std::move(t));
  transformed = true;
}

// Images (bytes as they are), samplers, textures and PBR materials.
void add_materials(GlbWriter& w, const Rig& rig) {
  tinygltf::Model& m = w.model;
  bool webp = false;
  for (const auto& t : rig.textures) {
    tinygltf::Image im;
    im.name = t.name;
    im.mimeType = t.mime_type.empty() ? "image/png" : t.mime_type;
    im.bufferView = w.add_view(t.bytes.data(), t.bytes.size(), 0);
    m.images.push_back(im);
    tinygltf::Sampler s;
    s.wrapS = t.repeat_s ? TINYGLTF_TEXTURE_WRAP_REPEAT : TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    s.wrapT = t.repeat_t ? TINYGLTF_TEXTURE_WRAP_REPEAT : TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    s.magFilter = t.nearest ? TINYGLTF_TEXTURE_FILTER_NEAREST : TINYGLTF_TEXTURE_FILTER_LINEAR;
    m.samplers.push_back(s);
    tinygltf::Texture tex;
    tex.name = t.name;
    tex.sampler = static_cast<int>(m.images.size()) - 1;
    if (im.mimeType == "image/webp") {  // no fallback image: the extension is required
      tinygltf::Value::Object source;
      source["source"] = tinygltf::Value(tex.sampler);
      tex.extensions["EXT_texture_webp"] = tinygltf::Value(std::move(source));
      webp = true;
    } else {
      tex.source = tex.sampler;
    }
    m.textures.push_back(tex);
  }
  bool transformed = false, unlit = false, strength = false;
  for (const auto& mat : rig.materials) {
    tinygltf::Material gm;
    gm.name = mat.name;
    auto& pbr = gm.pbrMetallicRoughness;
    pbr.baseColorFactor = {mat.base_color[0], mat.base_color[1], mat.base_color[2],
                           mat.base_color[3]};
    pbr.metallicFactor = mat.metallic;
    pbr.roughnessFactor = mat.roughness;
    // Emissive over 1 keeps its strength in KHR_materials_emissive_strength.
    const float brightest = mat.emissive.maxCoeff();
    const float scale = brightest > 1.0f ? brightest : 1.0f;
    gm.emissiveFactor = {mat.emissive[0] / scale, mat.emissive[1] / scale, mat.emissive[2] / scale};
    if (scale > 1.0f) {
      tinygltf::Value::Object e;
      e["emissiveStrength"] = tinygltf::Value(double(scale));
      gm.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(std::move(e));
      strength = true;
    }
    if (mat.unlit) {
      gm.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object{});
      unlit = true;
    }
    gm.alphaMode = mat.alpha_mode == AlphaMode::kMask    ? "MASK"
                   : mat.alpha_mode == AlphaMode::kBlend ? "BLEND"
                   : mat.base_color[3] < 1.0f            ? "BLEND"
                                                         : "OPAQUE";
    if (mat.alpha_mode == AlphaMode::kMask) gm.alphaCutoff = mat.alpha_cutoff;
    gm.doubleSided = mat.double_sided;
    set_texture(pbr.baseColorTexture, mat.base_color_texture, transformed);
    set_texture(pbr.metallicRoughnessTexture, mat.metallic_roughness_texture, transformed);
    set_texture(gm.normalTexture, mat.normal_texture, transformed);
    gm.normalTexture.scale = mat.normal_texture.strength;
    set_texture(gm.occlusionTexture, mat.occlusion_texture, transformed);
    gm.occlusionTexture.strength = mat.occlusion_texture.strength;
    set_texture(gm.emissiveTexture, mat.emissive_texture, transformed);
    m.materials.push_back(gm);
  }
  if (transformed) m.extensionsUsed.push_back("KHR_texture_transform");
  if (unlit) m.extensionsUsed.push_back("KHR_materials_unlit");
  if (strength) m.extensionsUsed.push_back("KHR_materials_emissive_strength");
  if (webp) {
    m.extensionsUsed.push_back("EXT_texture_webp");
    m.extensionsRequired.push_back("EXT_texture_webp");
  }
}

// The skeleton as joint nodes (each at its rest origin relative to its parent) and a skin whose
// inverse bind matrices undo the rest origins. Returns the root joints.
std::vector<int> add_skeleton(GlbWriter& w, const Skeleton& sk) {
  tinygltf::Model& m = w.model;
  const int first = static_cast<int>(m.nodes.size());
  const auto nj = sk.joint_names.size();
  std::vector<int> roots;
  Eigen::Matrix<float, Eigen::Dynamic, 16, Eigen::RowMajor> ibm(static_cast<Eigen::Index>(nj), 16);
  for (std::size_t j = 0; j < nj; ++j) {
    tinygltf::Node n;
    n.name = sk.joint_names[j];
    const int parent = sk.parent[j];
    const Eigen::Vector3f t =
        sk.rest_origin[j] -
        (parent >= 0 ? sk.rest_origin[static_cast<std::size_t>(parent)] : Eigen::Vector3f::Zero());
    n.translation = {t.x(), t.y(), t.z()};
    m.nodes.push_back(n);
    Eigen::Matrix4f inv = Eigen::Matrix4f::Identity();
    inv.block<3, 1>(0, 3) = -sk.rest_origin[j];
    ibm.row(static_cast<Eigen::Index>(j)) =
        Eigen::Map<const Eigen::Matrix<float, 1, 16>>(inv.data());
    if (parent < 0) roots.push_back(first + static_cast<int>(j));
  }
  for (std::size_t j = 0; j < nj; ++j)
    if (sk.parent[j] >= 0)
      m.nodes[static_cast<std::size_t>(first + sk.parent[j])].children.push_back(
          first + static_cast<int>(j));
  tinygltf::Skin skin;
  for (std::size_t j = 0; j < nj; ++j) skin.joints.push_back(first + static_cast<int>(j));
  tinygltf::Accessor a;
  a.bufferView = w.add_view(ibm.data(), static_cast<std::size_t>(ibm.size()) * sizeof(float), 0);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.count = nj;
  a.type = TINYGLTF_TYPE_MAT4;
  m.accessors.push_back(a);
  skin.inverseBindMatrices = static_cast<int>(m.accessors.size()) - 1;
  m.skins.push_back(skin);
  return roots;
}

// One mesh of the rig's vertices `verts` (rows, in order) and faces `faces`: shared vertex
// accessors, one primitive per material; the shapes that move these vertices (all shapes when
// `all_shapes`) as dense morph targets.
tinygltf::Mesh add_mesh(GlbWriter& w, const Rig& rig, const std::vector<int>& verts,
                        const std::vector<int>& faces, bool all_shapes) {
  std::vector<int> local(static_cast<std::size_t>(rig.vertex_count()), -1);
  for (std::size_t i = 0; i < verts.size(); ++i)
    local[static_cast<std::size_t>(verts[i])] = static_cast<int>(i);
  const auto rows = [&](const auto& mat) {
    std::decay_t<decltype(mat)> out(static_cast<Eigen::Index>(verts.size()), mat.cols());
    for (std::size_t i = 0; i < verts.size(); ++i)
      out.row(static_cast<Eigen::Index>(i)) = mat.row(verts[i]);
    return out;
  };
  std::map<std::string, int> attributes;
  attributes["POSITION"] = w.add_float_accessor(rows(rig.positions), TINYGLTF_TYPE_VEC3, true);
  attributes["NORMAL"] = w.add_float_accessor(rows(rig.normals), TINYGLTF_TYPE_VEC3, false);
  if (rig.uvs.rows())
    attributes["TEXCOORD_0"] = w.add_float_accessor(rows(rig.uvs), TINYGLTF_TYPE_VEC2, false);
  if (rig.joints.rows()) {
    const Eigen::Matrix<std::uint16_t, Eigen::Dynamic, 4, Eigen::RowMajor> j =
        rows(rig.joints).cast<std::uint16_t>();
    attributes["JOINTS_0"] = w.add_int_accessor(
        j.data(), j.rows(), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4);
    attributes["WEIGHTS_0"] =
        w.add_float_accessor(rows(rig.joint_weights), TINYGLTF_TYPE_VEC4, false);
  }
  std::vector<int> targets;
  std::vector<std::string> names;
  for (const auto& s : rig.shapes) {
    const Positions d = rows(s.dense(rig.vertex_count()));
    if (!all_shapes && d.isZero(0.0f)) continue;
    targets.push_back(w.add_target_accessor(d));
    names.push_back(s.name);
  }
  tinygltf::Mesh mesh;
  std::map<int, std::vector<std::uint32_t>> per_material;
  for (const int f : faces)
    for (int c = 0; c < 3; ++c)
      per_material[rig.triangle_material[static_cast<std::size_t>(f)]].push_back(
          static_cast<std::uint32_t>(local[static_cast<std::size_t>(rig.triangles(f, c))]));
  for (const auto& [material, idx] : per_material) {
    tinygltf::Primitive p;
    p.attributes = attributes;
    p.indices = w.add_index_accessor(idx);
    p.material = material;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    for (int t : targets) p.targets.push_back({{"POSITION", t}});
    mesh.primitives.push_back(std::move(p));
  }
  mesh.weights.assign(targets.size(), 0.0);
  tinygltf::Value::Object extras;
  extras["targetNames"] = string_array(names);
  std::vector<Landmark> marks;
  for (const auto& l : rig.landmarks)
    if (local[static_cast<std::size_t>(l.vertex)] >= 0)
      marks.push_back({l.name, local[static_cast<std::size_t>(l.vertex)]});
  if (!marks.empty()) extras["facecast"] = landmark_extras(marks);
  mesh.extras = tinygltf::Value(std::move(extras));
  return mesh;
}

}  // namespace

std::string glb_bytes(const Rig& rig, const GlbOptions& options) {
  rig.validate();
  GlbWriter w;
  tinygltf::Model& m = w.model;
  m.asset.version = "2.0";
  m.asset.generator = kGenerator;
  add_materials(w, rig);
  const bool skinned = rig.joints.rows() > 0;
  std::vector<int> scene_nodes = skinned ? add_skeleton(w, rig.skeleton) : std::vector<int>{};

  // The meshes: one of all vertices in rig order, or one per group (its vertices in rig order).
  std::vector<std::vector<int>> faces(1), verts(1);
  std::vector<std::string> names{"face"};
  bool every_shape = true;  // rig meshes list every shape (the view then keeps the rig's order)
  if (options.mesh_per_group &&
      rig.triangle_group.size() == static_cast<std::size_t>(rig.triangle_count()) &&
      !rig.groups.empty()) {
    faces.assign(rig.groups.size(), {});
    names = rig.groups;
    every_shape = false;  // a group lists the shapes that move it
    for (int f = 0; f < rig.triangle_count(); ++f)
      faces[static_cast<std::size_t>(rig.triangle_group[static_cast<std::size_t>(f)])].push_back(f);
    verts.assign(rig.groups.size(), {});
    for (std::size_t g = 0; g < faces.size(); ++g) {
      std::vector<char> used(static_cast<std::size_t>(rig.vertex_count()), 0);
      for (const int f : faces[g])
        for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(rig.triangles(f, c))] = 1;
      for (int v = 0; v < rig.vertex_count(); ++v)
        if (used[static_cast<std::size_t>(v)]) verts[g].push_back(v);
    }
  } else if (!rig.meshes.empty()) {
    faces.assign(rig.meshes.size(), {});
    verts.assign(rig.meshes.size(), {});
    names.clear();
    for (const auto& r : rig.meshes) names.push_back(r.name);
    for (int f = 0; f < rig.triangle_count(); ++f)
      faces[static_cast<std::size_t>(rig.mesh_of(rig.triangles(f, 0)))].push_back(f);
    for (std::size_t k = 0; k < rig.meshes.size(); ++k)
      for (int i = 0; i < rig.meshes[k].vertex_count; ++i)
        verts[k].push_back(rig.meshes[k].first_vertex + i);
  } else {
    for (int f = 0; f < rig.triangle_count(); ++f) faces[0].push_back(f);
    for (int v = 0; v < rig.vertex_count(); ++v) verts[0].push_back(v);
  }
  for (std::size_t g = 0; g < faces.size(); ++g) {
    if (faces[g].empty()) continue;
    tinygltf::Mesh mesh = add_mesh(w, rig, verts[g], faces[g], every_shape);
    mesh.name = names[g];
    m.meshes.push_back(std::move(mesh));
    tinygltf::Node node;
    node.name = names[g];
    node.mesh = static_cast<int>(m.meshes.size()) - 1;
    if (skinned) node.skin = 0;
    m.nodes.push_back(node);
    scene_nodes.push_back(static_cast<int>(m.nodes.size()) - 1);
  }
  tinygltf::Scene scene;
  scene.nodes = scene_nodes;
  m.scenes.push_back(scene);
  m.defaultScene = 0;

  std::ostringstream out;
  tinygltf::TinyGLTF gltf;
  if (!gltf.WriteGltfSceneToStream(&m, out, false, true)) {
    throw Error("GLB serialization failed", ErrorCode::kInternal);
  }
  return std::move(out).str();
}

std::string glb_bytes(const Rig& rig) {
  return glb_bytes(rig, GlbOptions{});
}

void write_glb(const std::filesystem::path& path, const Rig& rig) {
  write_file_atomic(path, glb_bytes(rig));
}

Rig parse_glb(std::string_view bytes, std::string_view name, const DecodeLimits& limits) {
  return make_view(AvatarDocument::parse(bytes, name, limits)).rig;
}

Rig read_glb(const std::filesystem::path& path, const DecodeLimits& limits) {
  return make_view(AvatarDocument::read(path, limits)).rig;
}

}  // namespace facecast::rig
