// The view's non-geometry parts: node transforms, materials and textures, the skeleton, VRM
// expressions.
#include <algorithm>
#include <cctype>
#include <cmath>

#include "avatar_view_detail.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/vrm_names.hpp"

namespace facecast::rig {
namespace detail {
namespace {

Eigen::Matrix4f local_matrix(const tinygltf::Node& n) {
  Eigen::Matrix4f out = Eigen::Matrix4f::Identity();
  if (n.matrix.size() == 16) {
    for (int i = 0; i < 16; ++i) out(i % 4, i / 4) = static_cast<float>(n.matrix[i]);
    return out;
  }
  Eigen::Affine3f t = Eigen::Affine3f::Identity();
  if (n.translation.size() == 3)
    t.translate(
        Eigen::Vector3f(n.translation[0], n.translation[1], n.translation[2]).cast<float>());
  if (n.rotation.size() == 4)
    t.rotate(
        Eigen::Quaternionf(static_cast<float>(n.rotation[3]), static_cast<float>(n.rotation[0]),
                           static_cast<float>(n.rotation[1]), static_cast<float>(n.rotation[2]))
            .normalized());
  if (n.scale.size() == 3)
    t.scale(Eigen::Vector3f(n.scale[0], n.scale[1], n.scale[2]).cast<float>());
  return t.matrix();
}

TextureRef texture_ref(int index, const tinygltf::ExtensionMap& ext, double strength) {
  TextureRef r;
  r.texture = index;
  r.strength = static_cast<float>(strength);
  const auto it = ext.find("KHR_texture_transform");
  if (index < 0 || it == ext.end() || !it->second.IsObject()) return r;
  const auto& t = it->second;
  const auto pair = [&](const char* key, Eigen::Vector2f& out) {
    if (!t.Has(key) || !t.Get(key).IsArray() || t.Get(key).ArrayLen() != 2) return;
    for (int c = 0; c < 2; ++c)
      if (t.Get(key).Get(c).IsNumber())
        out[c] = static_cast<float>(t.Get(key).Get(c).GetNumberAsDouble());
  };
  pair("offset", r.offset);
  pair("scale", r.scale);
  if (t.Has("rotation") && t.Get("rotation").IsNumber())
    r.rotation = static_cast<float>(t.Get("rotation").GetNumberAsDouble());
  return r;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The humanoid's bones and their nodes from VRM 1.0 (extensions.VRMC_vrm.humanoid.humanBones.
// <bone>.node) or VRM 0.x (extensions.VRM.humanoid.humanBones[]: {bone, node}); the bone names
// are the same in both but for VRM 0.x's thumbs ("leftThumbProximal" is 1.0's
// "leftThumbMetacarpal" and so on down the finger), renamed here to 1.0's.
std::vector<std::pair<std::string, int>> vrm_bones(const tinygltf::Model& m) {
  std::vector<std::pair<std::string, int>> out;
  if (const auto it = m.extensions.find("VRMC_vrm"); it != m.extensions.end()) {
    const auto& bones = it->second.Get("humanoid").Get("humanBones");
    for (const auto& key : bones.IsObject() ? bones.Keys() : std::vector<std::string>{})
      if (const auto& b = bones.Get(key); b.IsObject() && b.Get("node").IsInt())
        out.emplace_back(key, b.Get("node").GetNumberAsInt());
    return out;
  }
  if (const auto it = m.extensions.find("VRM"); it != m.extensions.end()) {
    const auto& bones = it->second.Get("humanoid").Get("humanBones");
    for (std::size_t i = 0; bones.IsArray() && i < bones.ArrayLen(); ++i) {
      const auto& b = bones.Get(static_cast<int>(i));
      if (!b.Get("bone").IsString() || !b.Get("node").IsInt()) continue;
      std::string name = b.Get("bone").Get<std::string>();
      for (const auto& [from, to] : {std::pair{"ThumbProximal", "ThumbMetacarpal"},
                                     std::pair{"ThumbIntermediate", "ThumbProximal"}})
        if (const auto at = name.find(from); at != std::string::npos) {
          name.replace(at, std::string(from).size(), to);
          break;
        }
      out.emplace_back(name, b.Get("node").GetNumberAsInt());
    }
  }
  return out;
}

}  // namespace

NodeGraph node_graph(const tinygltf::Model& m, const std::string& what) {
  const std::size_t n = m.nodes.size();
  NodeGraph g;
  g.world.assign(n, Eigen::Matrix4f::Identity());
  g.parent.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    for (const int c : m.nodes[i].children) {
      if (c < 0 || static_cast<std::size_t>(c) >= n || g.parent[static_cast<std::size_t>(c)] >= 0 ||
          static_cast<std::size_t>(c) == i)
        throw Error(what + ": nodes[" + std::to_string(i) + "] has a bad child " +
                    std::to_string(c));
      g.parent[static_cast<std::size_t>(c)] = static_cast<int>(i);
    }
  }
  std::vector<int> roots;
  if (!m.scenes.empty()) {
    const auto& s =
        m.scenes[m.defaultScene >= 0 && static_cast<std::size_t>(m.defaultScene) < m.scenes.size()
                     ? static_cast<std::size_t>(m.defaultScene)
                     : 0];
    roots = s.nodes;
  } else {
    for (std::size_t i = 0; i < n; ++i)
      if (g.parent[i] < 0) roots.push_back(static_cast<int>(i));
  }
  // A VRM 0.x figure faces -Z (UniVRM's export): turned half about +Y, x and z negated.
  Eigen::Matrix4f root = Eigen::Matrix4f::Identity();
  if (m.extensions.count("VRMC_vrm") == 0 && m.extensions.count("VRM") != 0)
    root.diagonal() << -1, 1, -1, 1;
  std::vector<char> seen(n, 0);
  std::vector<std::pair<int, Eigen::Matrix4f>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
    if (*it < 0 || static_cast<std::size_t>(*it) >= n ||
        g.parent[static_cast<std::size_t>(*it)] >= 0)
      throw Error(what + ": scene root " + std::to_string(*it) + " is not a root node");
    stack.emplace_back(*it, root);
  }
  while (!stack.empty()) {
    const auto [i, parent_world] = stack.back();
    stack.pop_back();
    const auto ui = static_cast<std::size_t>(i);
    if (seen[ui])
      throw Error(what + ": node graph has a cycle at nodes[" + std::to_string(i) + "]");
    seen[ui] = 1;
    g.world[ui] = parent_world * local_matrix(m.nodes[ui]);
    g.order.push_back(i);
    const auto& ch = m.nodes[ui].children;
    for (auto c = ch.rbegin(); c != ch.rend(); ++c) stack.emplace_back(*c, g.world[ui]);
  }
  // Nodes under a root that no scene lists are still placed (skins may name them).
  for (std::size_t i = 0; i < n; ++i) {
    if (seen[i] || g.parent[i] >= 0) continue;
    std::vector<std::pair<int, Eigen::Matrix4f>> rest{{static_cast<int>(i), root}};
    while (!rest.empty()) {
      const auto [k, pw] = rest.back();
      rest.pop_back();
      const auto uk = static_cast<std::size_t>(k);
      if (seen[uk])
        throw Error(what + ": node graph has a cycle at nodes[" + std::to_string(k) + "]");
      seen[uk] = 1;
      g.world[uk] = pw * local_matrix(m.nodes[uk]);
      for (const int c : m.nodes[uk].children) rest.emplace_back(c, g.world[uk]);
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!seen[i])
      throw Error(what + ": node graph has a cycle at nodes[" + std::to_string(i) + "]");
  return g;
}

// The image a texture samples: EXT_texture_webp's source first (WebP is decoded), then the core
// source (PNG/JPEG, the fallback of WebP and KTX2 textures), then KHR_texture_basisu's (a KTX2
// image, which the renderer refuses with the conversion to run); -1 when none.
int texture_source(const tinygltf::Texture& t) {
  const auto of = [&](const char* name) {
    const auto it = t.extensions.find(name);
    if (it == t.extensions.end() || !it->second.IsObject() || !it->second.Has("source") ||
        !it->second.Get("source").IsNumber())
      return -1;
    return it->second.Get("source").GetNumberAsInt();
  };
  if (const int webp = of("EXT_texture_webp"); webp >= 0) return webp;
  if (t.source >= 0) return t.source;
  return of("KHR_texture_basisu");
}

float number_or(const tinygltf::Value& o, const char* key, float fallback) {
  if (!o.IsObject() || !o.Has(key) || !o.Get(key).IsNumber()) return fallback;
  const double v = o.Get(key).GetNumberAsDouble();
  return std::isfinite(v) ? static_cast<float>(std::clamp(v, -1e4, 1e4)) : fallback;
}

// The first three numbers of o[key] (a colour), or `fallback`; `srgb` decodes them to linear.
Eigen::Vector3f colour_or(const tinygltf::Value& o, const char* key, Eigen::Vector3f fallback,
                          bool srgb = false) {
  if (!o.IsObject() || !o.Has(key) || !o.Get(key).IsArray() || o.Get(key).ArrayLen() < 3)
    return fallback;
  Eigen::Vector3f c;
  for (int k = 0; k < 3; ++k) {
    const auto& v = o.Get(key).Get(k);
    if (!v.IsNumber()) return fallback;
    const float x = std::clamp(static_cast<float>(v.GetNumberAsDouble()), 0.0f, 1e4f);
    c[k] = srgb ? srgb_to_linear(x) : x;
  }
  return c;
}

// MToon of material `index`: VRMC_materials_mtoon (VRM 1.0), else the VRM 0.x material
// properties of the same index with shader "VRM/MToon", whose _ShadeToony/_ShadeShift become
// MToon 1.0's toony and shift as UniVRM migrates them (the shading range [shift,
// lerp(1, shift, toony)]: toony = (2 - width) / 2, shift = -centre) and whose colours are sRGB.
std::optional<Toon> read_toon(const tinygltf::Model& m, std::size_t index) {
  const auto& gm = m.materials[index];
  if (const auto it = gm.extensions.find("VRMC_materials_mtoon"); it != gm.extensions.end()) {
    const auto& e = it->second;
    Toon t;
    t.shade_color = colour_or(e, "shadeColorFactor", t.shade_color);
    t.shading_shift = std::clamp(number_or(e, "shadingShiftFactor", 0.0f), -1.0f, 1.0f);
    t.shading_toony = std::clamp(number_or(e, "shadingToonyFactor", 0.9f), 0.0f, 1.0f);
    t.rim_color = colour_or(e, "parametricRimColorFactor", t.rim_color);
    t.rim_fresnel_power =
        std::clamp(number_or(e, "parametricRimFresnelPowerFactor", 5.0f), 0.0f, 100.0f);
    t.rim_lift = std::clamp(number_or(e, "parametricRimLiftFactor", 0.0f), -1.0f, 1.0f);
    return t;
  }
  const auto vrm = m.extensions.find("VRM");
  if (vrm == m.extensions.end()) return std::nullopt;
  const auto& props = vrm->second.Get("materialProperties");
  if (!props.IsArray() || index >= props.ArrayLen()) return std::nullopt;
  const auto& p = props.Get(static_cast<int>(index));
  if (!p.Get("shader").IsString() || p.Get("shader").Get<std::string>() != "VRM/MToon")
    return std::nullopt;
  const auto& f = p.Get("floatProperties");
  const auto& v = p.Get("vectorProperties");
  Toon t;
  const float shift0 = std::clamp(number_or(f, "_ShadeShift", 0.0f), -1.0f, 1.0f);
  const float toony0 = std::clamp(number_or(f, "_ShadeToony", 0.9f), 0.0f, 1.0f);
  const float lo = shift0, hi = 1.0f + (shift0 - 1.0f) * toony0;
  t.shading_toony = std::clamp((2.0f - (hi - lo)) * 0.5f, 0.0f, 1.0f);
  t.shading_shift = std::clamp(-(hi + lo) * 0.5f, -1.0f, 1.0f);
  t.shade_color = colour_or(v, "_ShadeColor", {0.97f, 0.81f, 0.86f}, true);
  t.rim_color = colour_or(v, "_RimColor", t.rim_color, true);
  t.rim_fresnel_power = std::clamp(number_or(f, "_RimFresnelPower", 1.0f), 0.0f, 100.0f);
  t.rim_lift = std::clamp(number_or(f, "_RimLift", 0.0f), -1.0f, 1.0f);
  return t;
}

void read_materials(const tinygltf::Model& m, Rig& rig) {
  for (const auto& t : m.textures) {
    Texture tex;
    tex.name = t.name;
    if (const int source = texture_source(t);
        source >= 0 && static_cast<std::size_t>(source) < m.images.size()) {
      const auto& im = m.images[static_cast<std::size_t>(source)];
      tex.mime_type = im.mimeType;
      if (im.bufferView >= 0 && static_cast<std::size_t>(im.bufferView) < m.bufferViews.size()) {
        const auto& v = m.bufferViews[static_cast<std::size_t>(im.bufferView)];
        if (v.buffer >= 0 && static_cast<std::size_t>(v.buffer) < m.buffers.size()) {
          const auto& b = m.buffers[static_cast<std::size_t>(v.buffer)].data;
          if (v.byteOffset <= b.size() && v.byteLength <= b.size() - v.byteOffset)
            tex.bytes.assign(reinterpret_cast<const char*>(b.data() + v.byteOffset), v.byteLength);
        }
      }
    }
    if (t.sampler >= 0 && static_cast<std::size_t>(t.sampler) < m.samplers.size()) {
      const auto& s = m.samplers[static_cast<std::size_t>(t.sampler)];
      tex.repeat_s = s.wrapS != TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
      tex.repeat_t = s.wrapT != TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
      tex.nearest = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    }
    rig.textures.push_back(std::move(tex));
  }
  const int nt = static_cast<int>(rig.textures.size());
  const auto index = [&](int i) { return i >= 0 && i < nt ? i : -1; };
  for (const auto& gm : m.materials) {
    Material mat = Material::solid(gm.name);
    const auto& pbr = gm.pbrMetallicRoughness;
    for (std::size_t c = 0; c < 4 && c < pbr.baseColorFactor.size(); ++c)
      mat.base_color[static_cast<Eigen::Index>(c)] = static_cast<float>(pbr.baseColorFactor[c]);
    mat.metallic = static_cast<float>(pbr.metallicFactor);
    mat.roughness = static_cast<float>(pbr.roughnessFactor);
    for (std::size_t c = 0; c < 3 && c < gm.emissiveFactor.size(); ++c)
      mat.emissive[static_cast<Eigen::Index>(c)] = static_cast<float>(gm.emissiveFactor[c]);
    if (const auto it = gm.extensions.find("KHR_materials_emissive_strength");
        it != gm.extensions.end())
      mat.emissive *= std::max(number_or(it->second, "emissiveStrength", 1.0f), 0.0f);
    mat.unlit = gm.extensions.count("KHR_materials_unlit") > 0;
    mat.toon = read_toon(m, static_cast<std::size_t>(&gm - m.materials.data()));
    mat.alpha_mode = gm.alphaMode == "MASK"    ? AlphaMode::kMask
                     : gm.alphaMode == "BLEND" ? AlphaMode::kBlend
                                               : AlphaMode::kOpaque;
    mat.alpha_cutoff = static_cast<float>(gm.alphaCutoff);
    mat.double_sided = gm.doubleSided;
    mat.base_color_texture =
        texture_ref(index(pbr.baseColorTexture.index), pbr.baseColorTexture.extensions, 1.0);
    mat.metallic_roughness_texture = texture_ref(index(pbr.metallicRoughnessTexture.index),
                                                 pbr.metallicRoughnessTexture.extensions, 1.0);
    mat.normal_texture = texture_ref(index(gm.normalTexture.index), gm.normalTexture.extensions,
                                     gm.normalTexture.scale);
    mat.occlusion_texture =
        texture_ref(index(gm.occlusionTexture.index), gm.occlusionTexture.extensions,
                    gm.occlusionTexture.strength);
    mat.emissive_texture =
        texture_ref(index(gm.emissiveTexture.index), gm.emissiveTexture.extensions, 1.0);
    rig.materials.push_back(std::move(mat));
  }
}

Skeleton read_skeleton(const tinygltf::Model& m, const NodeGraph& g,
                       const std::vector<int>& joint_nodes) {
  Skeleton s;
  std::map<int, int> index_of;
  for (const int node : joint_nodes) {
    index_of[node] = static_cast<int>(s.joint_names.size());
    const auto& nm = m.nodes[static_cast<std::size_t>(node)].name;
    s.joint_names.push_back(nm.empty() ? "joint" + std::to_string(node) : nm);
    s.rest_origin.push_back(g.world[static_cast<std::size_t>(node)].block<3, 1>(0, 3));
  }
  for (const int node : joint_nodes) {
    int p = g.parent[static_cast<std::size_t>(node)];
    while (p >= 0 && !index_of.count(p)) p = g.parent[static_cast<std::size_t>(p)];
    s.parent.push_back(p >= 0 ? index_of[p] : -1);
  }
  for (const auto& [bone, node] : vrm_bones(m))
    if (const auto it = index_of.find(node); it != index_of.end())
      s.humanoid.emplace_back(bone, it->second);
  s.vrm0 = m.extensions.count("VRMC_vrm") == 0 && m.extensions.count("VRM") != 0;
  s.springs = read_springs(m, g, index_of);
  s.head = s.humanoid_bone("head");
  s.neck = s.humanoid_bone("neck");
  if (s.head < 0) s.head = find_joint(s.joint_names, "head");
  if (s.neck < 0) s.neck = find_joint(s.joint_names, "neck");
  return s;
}

std::vector<Expression> vrm_expressions(const tinygltf::Model& m) {
  std::vector<Expression> out;
  if (const auto it = m.extensions.find("VRMC_vrm"); it != m.extensions.end()) {
    const auto& preset = it->second.Get("expressions").Get("preset");
    if (!preset.IsObject()) return out;
    for (const auto& key : preset.Keys()) {
      Expression e{key, {}};
      const auto& binds = preset.Get(key).Get("morphTargetBinds");
      for (std::size_t i = 0; binds.IsArray() && i < binds.ArrayLen(); ++i) {
        const auto& b = binds.Get(static_cast<int>(i));
        const int node = b.Get("node").IsInt() ? b.Get("node").GetNumberAsInt() : -1;
        if (node < 0 || static_cast<std::size_t>(node) >= m.nodes.size() || !b.Get("index").IsInt())
          continue;
        e.binds.push_back(
            {m.nodes[static_cast<std::size_t>(node)].mesh, b.Get("index").GetNumberAsInt(),
             static_cast<float>(b.Get("weight").IsNumber() ? b.Get("weight").GetNumberAsDouble()
                                                           : 1.0)});
      }
      out.push_back(std::move(e));
    }
    return out;
  }
  const auto it = m.extensions.find("VRM");
  if (it == m.extensions.end()) return out;
  // VRM 0.x preset names in VRM 1.0 naming, so one table (configs/anim/visemes_vrm.json) serves
  // both.
  const auto& groups = it->second.Get("blendShapeMaster").Get("blendShapeGroups");
  for (std::size_t g = 0; groups.IsArray() && g < groups.ArrayLen(); ++g) {
    const auto& grp = groups.Get(static_cast<int>(g));
    std::string name =
        grp.Get("presetName").IsString() ? lower(grp.Get("presetName").Get<std::string>()) : "";
    if (name.empty() || name == "unknown")
      name = grp.Get("name").IsString() ? grp.Get("name").Get<std::string>() : "";
    name = vrm1_name(name);
    if (name.empty()) continue;
    Expression e{name, {}};
    const auto& binds = grp.Get("binds");
    for (std::size_t i = 0; binds.IsArray() && i < binds.ArrayLen(); ++i) {
      const auto& b = binds.Get(static_cast<int>(i));
      if (!b.Get("mesh").IsInt() || !b.Get("index").IsInt()) continue;
      e.binds.push_back(
          {b.Get("mesh").GetNumberAsInt(), b.Get("index").GetNumberAsInt(),
           static_cast<float>(
               (b.Get("weight").IsNumber() ? b.Get("weight").GetNumberAsDouble() : 100.0) /
               100.0)});
    }
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace detail

int find_joint(const std::vector<std::string>& names, const char* role) {
  const std::string r = detail::lower(role);
  const std::vector<std::string> wanted = {
      r, "j_bip_c_" + r, "mixamorig" + r, "bip01_" + r, "bip01 " + r, "def-" + r};
  for (const auto& w : wanted) {
    for (std::size_t i = 0; i < names.size(); ++i) {
      std::string n = detail::lower(names[i]);
      if (const auto colon = n.rfind(':'); colon != std::string::npos) n = n.substr(colon + 1);
      if (n == w) return static_cast<int>(i);
    }
  }
  return -1;
}

}  // namespace facecast::rig
