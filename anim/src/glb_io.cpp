// GLB (binary glTF 2.0) reading and writing with tinygltf.
//
// Layout written: one buffer; POSITION, NORMAL and TEXCOORD_0 accessors shared by every primitive
// (one primitive per material, each with its own uint32 indices), so the file keeps the rig's
// vertex order exactly; one POSITION morph target per shape, stored dense as deltas with min/max;
// shape names in mesh.extras.targetNames (three.js and Blender read them); default weights 0.
// Landmarks go to mesh.extras.facecast.landmarks.
#include <tiny_gltf.h>
#include <sstream>

#include "facecast/anim/avatar_view.hpp"
#include "facecast/anim/rig_io.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"

namespace facecast::anim {
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

std::string glb_bytes(const Rig& rig) {
  rig.validate();
  GlbWriter w;
  tinygltf::Model& m = w.model;
  m.asset.version = "2.0";
  m.asset.generator = kGenerator;

  const int pos = w.add_float_accessor(rig.positions, TINYGLTF_TYPE_VEC3, true);
  const int nrm = w.add_float_accessor(rig.normals, TINYGLTF_TYPE_VEC3, false);
  const int uv = rig.uvs.rows() ? w.add_float_accessor(rig.uvs, TINYGLTF_TYPE_VEC2, false) : -1;

  std::vector<int> targets;
  Positions dense;
  for (const auto& s : rig.shapes) {
    dense = s.dense(rig.vertex_count());
    targets.push_back(w.add_float_accessor(dense, TINYGLTF_TYPE_VEC3, true));
  }

  for (const auto& mat : rig.materials) {
    tinygltf::Material gm;
    gm.name = mat.name;
    gm.pbrMetallicRoughness.baseColorFactor = {mat.base_color[0], mat.base_color[1],
                                               mat.base_color[2], mat.base_color[3]};
    gm.pbrMetallicRoughness.metallicFactor = 0.0;
    gm.pbrMetallicRoughness.roughnessFactor = 0.6;
    if (mat.base_color[3] < 1.0f) gm.alphaMode = "BLEND";
    m.materials.push_back(gm);
  }

  tinygltf::Mesh mesh;
  mesh.name = "face";
  std::vector<std::vector<std::uint32_t>> per_material(rig.materials.size());
  for (int f = 0; f < rig.triangle_count(); ++f) {
    auto& idx = per_material[static_cast<std::size_t>(rig.triangle_material[f])];
    for (int c = 0; c < 3; ++c) idx.push_back(static_cast<std::uint32_t>(rig.triangles(f, c)));
  }
  for (std::size_t mi = 0; mi < per_material.size(); ++mi) {
    if (per_material[mi].empty()) continue;
    tinygltf::Primitive p;
    p.attributes["POSITION"] = pos;
    p.attributes["NORMAL"] = nrm;
    if (uv >= 0) p.attributes["TEXCOORD_0"] = uv;
    p.indices = w.add_index_accessor(per_material[mi]);
    p.material = static_cast<int>(mi);
    p.mode = TINYGLTF_MODE_TRIANGLES;
    for (int t : targets) p.targets.push_back({{"POSITION", t}});
    mesh.primitives.push_back(std::move(p));
  }
  mesh.weights.assign(rig.shapes.size(), 0.0);

  tinygltf::Value::Object extras;
  extras["targetNames"] = string_array(rig.shape_names());
  if (!rig.landmarks.empty()) {
    tinygltf::Value::Array marks;
    for (const auto& l : rig.landmarks) {
      tinygltf::Value::Object o;
      o["name"] = tinygltf::Value(l.name);
      o["vertex"] = tinygltf::Value(l.vertex);
      marks.emplace_back(std::move(o));
    }
    tinygltf::Value::Object fc;
    fc["landmarks"] = tinygltf::Value(std::move(marks));
    extras["facecast"] = tinygltf::Value(std::move(fc));
  }
  mesh.extras = tinygltf::Value(std::move(extras));
  m.meshes.push_back(std::move(mesh));

  tinygltf::Node node;
  node.name = "face";
  node.mesh = 0;
  m.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  m.scenes.push_back(scene);
  m.defaultScene = 0;

  std::ostringstream out;
  tinygltf::TinyGLTF gltf;
  if (!gltf.WriteGltfSceneToStream(&m, out, false, true)) {
    throw Error("GLB serialization failed", ErrorCode::kInternal);
  }
  return std::move(out).str();
}

void write_glb(const std::filesystem::path& path, const Rig& rig) {
  write_file_atomic(path, glb_bytes(rig));
}

Rig parse_glb(std::string_view bytes, std::string_view name) {
  return make_view(AvatarDocument::parse(bytes, name)).rig;
}

Rig read_glb(const std::filesystem::path& path) {
  return make_view(AvatarDocument::read(path)).rig;
}

}  // namespace facecast::anim
