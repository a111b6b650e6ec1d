// The test avatar (see test_avatar_file.hpp), built with tinygltf.
#include "test_avatar_file.hpp"

#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <cstring>
#include <sstream>
#include <vector>

namespace facecast::test {
namespace {

// 2x2 RGB PNGs: a skin tone and a flat normal map.
const unsigned char kPng[2][73] = {
    {0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
     0x52, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x02, 0x00, 0x00, 0x00, 0xfd,
     0xd4, 0x9a, 0x73, 0x00, 0x00, 0x00, 0x10, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x38,
     0x31, 0xad, 0x02, 0x88, 0x18, 0x20, 0x14, 0x00, 0x34, 0xb6, 0x07, 0x59, 0x33, 0x47, 0x6a,
     0x96, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82},
    {0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
     0x52, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x02, 0x00, 0x00, 0x00, 0xfd,
     0xd4, 0x9a, 0x73, 0x00, 0x00, 0x00, 0x10, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x68,
     0x68, 0xf8, 0x0f, 0x44, 0x0c, 0x10, 0x0a, 0x00, 0x35, 0xf6, 0x07, 0xfd, 0x49, 0x28, 0x43,
     0xcc, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82}};

class Builder {
 public:
  tinygltf::Model m;
  Builder() { m.buffers.emplace_back(); }

  int view(const void* data, std::size_t bytes, int target = 0) {
    auto& buf = m.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = buf.size();
    v.byteLength = bytes;
    v.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    m.bufferViews.push_back(v);
    return static_cast<int>(m.bufferViews.size()) - 1;
  }

  template <typename T>
  int accessor(const std::vector<T>& values, int comps, int component, int type, bool bounds,
               int target = TINYGLTF_TARGET_ARRAY_BUFFER) {
    tinygltf::Accessor a;
    a.bufferView = view(values.data(), values.size() * sizeof(T), target);
    a.componentType = component;
    a.count = values.size() / static_cast<std::size_t>(comps);
    a.type = type;
    if (bounds) {
      for (int c = 0; c < comps; ++c) {
        double lo = 1e30, hi = -1e30;
        for (std::size_t i = static_cast<std::size_t>(c); i < values.size(); i += comps) {
          lo = std::min(lo, static_cast<double>(values[i]));
          hi = std::max(hi, static_cast<double>(values[i]));
        }
        a.minValues.push_back(lo);
        a.maxValues.push_back(hi);
      }
    }
    m.accessors.push_back(a);
    return static_cast<int>(m.accessors.size()) - 1;
  }
  int vec3(const std::vector<float>& v) {
    return accessor(v, 3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, true);
  }
  int vec2(const std::vector<float>& v) {
    return accessor(v, 2, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, false);
  }
  int indices(const std::vector<std::uint16_t>& v) {
    return accessor(v, 1, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR, false,
                    TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  }

  // A w x h grid of quads in the plane z = `z`, from (x0, y0) with spacing `s`, facing +Z.
  struct Grid {
    std::vector<float> pos, nrm, uv;
    std::vector<std::uint16_t> idx;
  };
  static Grid grid(int w, int h, float x0, float y0, float z, float s) {
    Grid g;
    for (int j = 0; j <= h; ++j)
      for (int i = 0; i <= w; ++i) {
        g.pos.insert(g.pos.end(), {x0 + s * i, y0 + s * j, z + 0.01f * ((i * 7 + j * 3) % 5)});
        g.nrm.insert(g.nrm.end(), {0, 0, 1});
        g.uv.insert(g.uv.end(), {static_cast<float>(i) / w, static_cast<float>(j) / h});
      }
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        const auto a = static_cast<std::uint16_t>(j * (w + 1) + i);
        const auto b = static_cast<std::uint16_t>(a + 1), c = static_cast<std::uint16_t>(a + w + 1),
                   d = static_cast<std::uint16_t>(a + w + 2);
        g.idx.insert(g.idx.end(), {a, b, d, a, d, c});
      }
    return g;
  }

  int node(const std::string& name, std::vector<double> t, std::vector<int> children = {}) {
    tinygltf::Node n;
    n.name = name;
    n.translation = std::move(t);
    n.children = std::move(children);
    m.nodes.push_back(n);
    return static_cast<int>(m.nodes.size()) - 1;
  }
};

tinygltf::Value names(std::initializer_list<const char*> list) {
  tinygltf::Value::Array a;
  for (const char* n : list) a.emplace_back(std::string(n));
  tinygltf::Value::Object o;
  o["targetNames"] = tinygltf::Value(std::move(a));
  return tinygltf::Value(std::move(o));
}

}  // namespace

std::string test_avatar_png(int i) {
  return std::string(reinterpret_cast<const char*>(kPng[i]), sizeof kPng[i]);
}

// Images, samplers, textures and the four materials.
void add_materials(Builder& b) {
  auto& m = b.m;
  // Images and textures: the skin colour with a texture transform, a normal map.
  for (int i = 0; i < 2; ++i) {
    tinygltf::Image im;
    im.name = i ? "normal" : "skin";
    im.mimeType = "image/png";
    im.bufferView = b.view(kPng[i], sizeof kPng[i]);
    m.images.push_back(im);
    tinygltf::Texture t;
    t.source = i;
    t.sampler = 0;
    m.textures.push_back(t);
  }
  tinygltf::Sampler s;
  s.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  s.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  m.samplers.push_back(s);
  tinygltf::Material skin_mat;
  skin_mat.name = "Skin";
  skin_mat.pbrMetallicRoughness.baseColorTexture.index = 0;
  tinygltf::Value::Object tt;
  tt["offset"] =
      tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(0.25), tinygltf::Value(0.5)});
  tt["scale"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(2.0), tinygltf::Value(2.0)});
  tt["rotation"] = tinygltf::Value(0.5);
  skin_mat.pbrMetallicRoughness.baseColorTexture.extensions["KHR_texture_transform"] =
      tinygltf::Value(tt);
  skin_mat.pbrMetallicRoughness.roughnessFactor = 0.7;
  skin_mat.normalTexture.index = 1;
  skin_mat.normalTexture.scale = 0.8;
  tinygltf::Material lips = skin_mat;
  lips.name = "Lips";
  lips.pbrMetallicRoughness.baseColorFactor = {0.8, 0.3, 0.3, 1.0};
  tinygltf::Material teeth;
  teeth.name = "Teeth";
  teeth.pbrMetallicRoughness.baseColorFactor = {0.95, 0.95, 0.9, 1.0};
  tinygltf::Material hair;
  hair.name = "Hair";
  hair.alphaMode = "MASK";
  hair.alphaCutoff = 0.4;
  hair.doubleSided = true;
  hair.pbrMetallicRoughness.baseColorFactor = {0.2, 0.1, 0.05, 1.0};
  m.materials = {skin_mat, lips, teeth, hair};
  m.extensionsUsed = {"KHR_texture_transform"};
}

// Head and Teeth with morph targets, Hair and Body without.
void add_meshes(Builder& b) {
  auto& m = b.m;
  // Head: a 6x4 grid at the head's height, skinned to Head (lower rows to Neck), two primitives
  // (skin, lips) sharing its vertices; targets jawOpen (lower half down) and eyeBlinkLeft.
  {
    auto g = Builder::grid(6, 4, -0.3f, 1.5f, 0.1f, 0.1f);
    const int n = static_cast<int>(g.pos.size() / 3);
    std::vector<float> jaw(g.pos.size(), 0.0f), blink(g.pos.size(), 0.0f), weights;
    std::vector<std::uint8_t> js;
    for (int v = 0; v < n; ++v) {
      const float y = g.pos[v * 3 + 1];
      if (y < 1.65f) jaw[v * 3 + 1] = -0.05f * (1.65f - y) / 0.15f;
      if (y > 1.75f && g.pos[v * 3] > 0.05f) blink[v * 3 + 1] = -0.02f;
      const float w = y < 1.6f ? 0.5f : 1.0f;
      js.insert(js.end(), {3, 2, 0, 0});
      weights.insert(weights.end(), {w, 1.0f - w, 0.0f, 0.0f});
    }
    const int pos = b.vec3(g.pos), nrm = b.vec3(g.nrm), uv = b.vec2(g.uv);
    const int jt =
        b.accessor(js, 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC4, false);
    const int wt = b.accessor(weights, 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, false);
    const int t_jaw = b.vec3(jaw), t_blink = b.vec3(blink);
    tinygltf::Mesh mesh;
    mesh.name = "Head";
    const std::size_t half = g.idx.size() / 2;
    for (int part = 0; part < 2; ++part) {
      tinygltf::Primitive p;
      p.attributes = {{"POSITION", pos},
                      {"NORMAL", nrm},
                      {"TEXCOORD_0", uv},
                      {"JOINTS_0", jt},
                      {"WEIGHTS_0", wt}};
      std::vector<std::uint16_t> idx(
          g.idx.begin() + (part ? 0 : static_cast<long>(half)),
          g.idx.begin() + (part ? static_cast<long>(half) : static_cast<long>(g.idx.size())));
      p.indices = b.indices(idx);
      p.material = part;  // upper half skin, lower half lips
      p.mode = TINYGLTF_MODE_TRIANGLES;
      p.targets = {{{"POSITION", t_jaw}}, {{"POSITION", t_blink}}};
      mesh.primitives.push_back(p);
    }
    mesh.weights = {0.0, 0.0};
    mesh.extras = names({"jawOpen", "eyeBlinkLeft"});
    m.meshes.push_back(mesh);
  }
  // Teeth: a 2x1 strip in its node's space (the node under the Head joint places it), jawOpen
  // moves it down.
  {
    auto g = Builder::grid(2, 1, -0.05f, 0.0f, 0.0f, 0.05f);
    std::vector<float> jaw(g.pos.size(), 0.0f);
    for (std::size_t v = 0; v < g.pos.size() / 3; ++v) jaw[v * 3 + 1] = -0.04f;
    tinygltf::Mesh mesh;
    mesh.name = "Teeth";
    tinygltf::Primitive p;
    p.attributes = {{"POSITION", b.vec3(g.pos)}, {"NORMAL", b.vec3(g.nrm)}};
    p.indices = b.indices(g.idx);
    p.material = 2;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    p.targets = {{{"POSITION", b.vec3(jaw)}}};
    mesh.primitives.push_back(p);
    mesh.extras = names({"jawOpen"});
    m.meshes.push_back(mesh);
  }
  // Hair (a card, no morphs) and Body (skinned to Hips and Spine, no morphs).
  for (int k = 0; k < 2; ++k) {
    auto g = k == 0 ? Builder::grid(2, 2, -0.2f, 1.75f, 0.05f, 0.2f)
                    : Builder::grid(2, 3, -0.25f, 0.9f, 0.0f, 0.2f);
    tinygltf::Mesh mesh;
    mesh.name = k == 0 ? "Hair" : "Body";
    tinygltf::Primitive p;
    p.attributes = {
        {"POSITION", b.vec3(g.pos)}, {"NORMAL", b.vec3(g.nrm)}, {"TEXCOORD_0", b.vec2(g.uv)}};
    if (k == 1) {
      std::vector<std::uint8_t> js;
      std::vector<float> ws;
      for (std::size_t v = 0; v < g.pos.size() / 3; ++v) {
        js.insert(js.end(), {0, 1, 0, 0});
        ws.insert(ws.end(), {0.6f, 0.4f, 0, 0});
      }
      p.attributes["JOINTS_0"] =
          b.accessor(js, 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC4, false);
      p.attributes["WEIGHTS_0"] =
          b.accessor(ws, 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, false);
    }
    p.indices = b.indices(g.idx);
    p.material = k == 0 ? 3 : 0;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    mesh.primitives.push_back(p);
    m.meshes.push_back(mesh);
  }
}

std::string test_avatar_glb() {
  Builder b;
  auto& m = b.m;
  m.asset.version = "2.0";
  m.asset.generator = "facecast test avatar";

  // Skeleton: Hips (0,1,0) > Spine (0,0.3,0) > Neck (0,0.3,0) > Head (0,0.1,0); Head at y = 1.7.
  const int head_j = b.node("Head", {0, 0.1, 0});
  const int neck_j = b.node("Neck", {0, 0.3, 0}, {head_j});
  const int spine_j = b.node("Spine", {0, 0.3, 0}, {neck_j});
  const int hips_j = b.node("Hips", {0, 1.0, 0}, {spine_j});
  const std::vector<int> joints = {hips_j, spine_j, neck_j, head_j};
  const float joint_y[4] = {1.0f, 1.3f, 1.6f, 1.7f};
  std::vector<float> ibm;
  for (const float y : joint_y) {
    Eigen::Matrix4f inv = Eigen::Matrix4f::Identity();
    inv(1, 3) = -y;
    ibm.insert(ibm.end(), inv.data(), inv.data() + 16);
  }
  tinygltf::Skin skin;
  skin.name = "Armature";
  skin.joints = joints;
  skin.skeleton = hips_j;
  skin.inverseBindMatrices =
      b.accessor(ibm, 16, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_MAT4, false, 0);
  m.skins.push_back(skin);

  add_materials(b);
  add_meshes(b);

  // Mesh nodes: Head and Body skinned (at the root), Teeth under the Head joint, Hair at the root
  // with a translation.
  tinygltf::Node head_n;
  head_n.name = "HeadMesh";
  head_n.mesh = 0;
  head_n.skin = 0;
  m.nodes.push_back(head_n);
  tinygltf::Node teeth_n;
  teeth_n.name = "TeethMesh";
  teeth_n.mesh = 1;
  teeth_n.translation = {0, -0.1, 0.08};
  teeth_n.scale = {2, 2, 2};
  m.nodes.push_back(teeth_n);
  m.nodes[static_cast<std::size_t>(head_j)].children.push_back(static_cast<int>(m.nodes.size()) -
                                                               1);
  tinygltf::Node hair_n;
  hair_n.name = "HairMesh";
  hair_n.mesh = 2;
  hair_n.translation = {0, 0.02, 0};
  m.nodes.push_back(hair_n);
  tinygltf::Node body_n;
  body_n.name = "BodyMesh";
  body_n.mesh = 3;
  body_n.skin = 0;
  m.nodes.push_back(body_n);
  // Extras and an extension Facecast does not know, which must survive.
  tinygltf::Value::Object extra;
  extra["creator"] = tinygltf::Value(std::string("facecast tests"));
  m.nodes[static_cast<std::size_t>(hips_j)].extras = tinygltf::Value(extra);
  tinygltf::Value::Object ext;
  ext["answer"] = tinygltf::Value(42);
  m.nodes[static_cast<std::size_t>(hips_j)].extensions["EXT_facecast_test"] = tinygltf::Value(ext);
  m.extensionsUsed.push_back("EXT_facecast_test");

  // An animation turning the neck.
  std::vector<float> times = {0.0f, 1.0f}, rot = {0, 0, 0, 1, 0, 0.2588f, 0, 0.9659f};
  tinygltf::Animation anim;
  anim.name = "turn";
  tinygltf::AnimationSampler as;
  as.input = b.accessor(times, 1, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, true, 0);
  as.output = b.accessor(rot, 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, false, 0);
  as.interpolation = "LINEAR";
  anim.samplers.push_back(as);
  tinygltf::AnimationChannel ch;
  ch.sampler = 0;
  ch.target_node = neck_j;
  ch.target_path = "rotation";
  anim.channels.push_back(ch);
  m.animations.push_back(anim);

  tinygltf::Scene scene;
  scene.name = "Scene";
  scene.nodes = {hips_j, static_cast<int>(m.nodes.size()) - 4, static_cast<int>(m.nodes.size()) - 2,
                 static_cast<int>(m.nodes.size()) - 1};
  m.scenes.push_back(scene);
  m.defaultScene = 0;

  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  writer.WriteGltfSceneToStream(&m, out, false, true);
  return std::move(out).str();
}

}  // namespace facecast::test
