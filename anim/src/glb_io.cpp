// GLB (binary glTF 2.0) reading and writing with tinygltf.
//
// Layout written: one buffer; POSITION, NORMAL and TEXCOORD_0 accessors shared by every primitive
// (one primitive per material, each with its own uint32 indices), so the file keeps the rig's
// vertex order exactly; one POSITION morph target per shape, stored dense as deltas with min/max;
// shape names in mesh.extras.targetNames (three.js and Blender read them); default weights 0.
// Landmarks go to mesh.extras.facecast.landmarks.
#include <tiny_gltf.h>
#include <cstring>
#include <map>
#include <sstream>

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

namespace {

// Reads a float accessor of `comps` components per element into a row-major matrix.
template <typename Matrix>
Matrix read_float_accessor(const tinygltf::Model& m, int index, int comps,
                           const std::string& what) {
  if (index < 0 || index >= static_cast<int>(m.accessors.size())) {
    throw Error(what + ": accessor index out of range");
  }
  const auto& a = m.accessors[index];
  if (a.sparse.isSparse)
    throw Error(what + ": sparse accessors are not supported", ErrorCode::kUnsupported);
  if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT ||
      tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)) != comps) {
    throw Error(what + ": expected float vectors of " + std::to_string(comps) + " components",
                ErrorCode::kUnsupported);
  }
  Matrix out(static_cast<Eigen::Index>(a.count), comps);
  if (a.bufferView < 0) {
    out.setZero();
    return out;
  }
  const auto& view = m.bufferViews.at(static_cast<std::size_t>(a.bufferView));
  const auto& buf = m.buffers.at(static_cast<std::size_t>(view.buffer)).data;
  const std::size_t elem = sizeof(float) * static_cast<std::size_t>(comps);
  const std::size_t stride = view.byteStride ? view.byteStride : elem;
  const std::size_t start = view.byteOffset + a.byteOffset;
  if (a.count && start + stride * (a.count - 1) + elem > buf.size()) {
    throw Error(what + ": accessor runs past the end of its buffer");
  }
  for (std::size_t i = 0; i < a.count; ++i) {
    std::memcpy(out.row(static_cast<Eigen::Index>(i)).data(), buf.data() + start + i * stride,
                elem);
  }
  return out;
}

std::vector<std::uint32_t> read_indices(const tinygltf::Model& m, int index,
                                        const std::string& what) {
  const auto& a = m.accessors.at(static_cast<std::size_t>(index));
  const auto& view = m.bufferViews.at(static_cast<std::size_t>(a.bufferView));
  const auto& buf = m.buffers.at(static_cast<std::size_t>(view.buffer)).data;
  const std::size_t size = static_cast<std::size_t>(
      tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType)));
  const std::size_t stride = view.byteStride ? view.byteStride : size;
  const std::size_t start = view.byteOffset + a.byteOffset;
  if (a.count && start + stride * (a.count - 1) + size > buf.size()) {
    throw Error(what + ": index accessor runs past the end of its buffer");
  }
  std::vector<std::uint32_t> out(a.count);
  for (std::size_t i = 0; i < a.count; ++i) {
    const unsigned char* p = buf.data() + start + i * stride;
    switch (a.componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        out[i] = *p;
        break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t v;
        std::memcpy(&v, p, 2);
        out[i] = v;
        break;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        std::memcpy(&out[i], p, 4);
        break;
      default:
        throw Error(what + ": bad index component type");
    }
  }
  return out;
}

tinygltf::Model load_model(std::string_view bytes, const std::string& what) {
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  if (!loader.LoadBinaryFromMemory(&m, &err, &warn,
                                   reinterpret_cast<const unsigned char*>(bytes.data()),
                                   static_cast<unsigned int>(bytes.size()))) {
    std::string msg = err.empty() ? "not a valid GLB file" : err;
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    for (auto& c : msg) c = c == '\n' ? ';' : c;
    throw Error(what + ": " + msg);
  }
  return m;
}

// mesh.extras.facecast.landmarks: [{name, vertex}, ...].
void read_landmarks(const tinygltf::Mesh& mesh, Rig& rig) {
  if (!mesh.extras.IsObject() || !mesh.extras.Has("facecast")) return;
  const auto& fc = mesh.extras.Get("facecast");
  if (!fc.Has("landmarks")) return;
  const auto& lm = fc.Get("landmarks");
  for (std::size_t i = 0; lm.IsArray() && i < lm.ArrayLen(); ++i) {
    const auto& o = lm.Get(static_cast<int>(i));
    rig.landmarks.push_back({o.Get("name").Get<std::string>(), o.Get("vertex").GetNumberAsInt()});
  }
}

// Each material's name and base colour factor (a grey default material when there are none).
void read_materials(const tinygltf::Model& m, Rig& rig) {
  for (const auto& gm : m.materials) {
    Material mat{gm.name, {0.8f, 0.8f, 0.8f, 1.0f}};
    const auto& f = gm.pbrMetallicRoughness.baseColorFactor;
    for (std::size_t c = 0; c < 4 && c < f.size(); ++c)
      mat.base_color[static_cast<Eigen::Index>(c)] = static_cast<float>(f[c]);
    rig.materials.push_back(mat);
  }
  if (rig.materials.empty()) rig.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});
}

}  // namespace

Rig parse_glb(std::string_view bytes, std::string_view name) {
  const std::string what(name);
  const tinygltf::Model m = load_model(bytes, what);
  if (m.meshes.empty()) throw Error(what + ": GLB has no mesh");
  const tinygltf::Mesh& mesh = m.meshes[0];
  if (mesh.primitives.empty()) throw Error(what + ": mesh has no primitives");

  Rig rig;
  const std::size_t n_targets = mesh.primitives[0].targets.size();
  // Primitives that share a POSITION accessor share vertices (the layout we write); others are
  // appended one after another.
  std::map<int, int> offset_of;
  std::vector<Positions> pos_parts, nrm_parts;
  std::vector<std::vector<Positions>> target_parts(n_targets);
  std::vector<UVs> uv_parts;
  std::vector<Eigen::Vector3i> tris;
  int nv = 0;
  bool all_uv = true;
  for (const auto& p : mesh.primitives) {
    if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) {
      throw Error(what + ": only triangle primitives are supported", ErrorCode::kUnsupported);
    }
    auto it = p.attributes.find("POSITION");
    if (it == p.attributes.end()) throw Error(what + ": primitive without POSITION");
    if (p.targets.size() != n_targets) throw Error(what + ": primitives disagree on morph targets");
    auto [off_it, fresh] = offset_of.try_emplace(it->second, nv);
    const int offset = off_it->second;
    if (fresh) {
      Positions pp = read_float_accessor<Positions>(m, it->second, 3, what + " POSITION");
      auto n_it = p.attributes.find("NORMAL");
      nrm_parts.push_back(n_it != p.attributes.end()
                              ? read_float_accessor<Positions>(m, n_it->second, 3, what + " NORMAL")
                              : Positions());
      auto t_it = p.attributes.find("TEXCOORD_0");
      if (t_it != p.attributes.end()) {
        uv_parts.push_back(read_float_accessor<UVs>(m, t_it->second, 2, what + " TEXCOORD_0"));
      } else {
        all_uv = false;
        uv_parts.emplace_back();
      }
      for (std::size_t t = 0; t < n_targets; ++t) {
        auto tp = p.targets[t].find("POSITION");
        target_parts[t].push_back(tp != p.targets[t].end() ? read_float_accessor<Positions>(
                                                                 m, tp->second, 3, what + " target")
                                                           : Positions::Zero(pp.rows(), 3));
        if (target_parts[t].back().rows() != pp.rows())
          throw Error(what + ": morph target size differs");
      }
      nv += static_cast<int>(pp.rows());
      pos_parts.push_back(std::move(pp));
    }
    const int count = static_cast<int>(m.accessors.at(static_cast<std::size_t>(it->second)).count);
    std::vector<std::uint32_t> idx;
    if (p.indices >= 0) {
      idx = read_indices(m, p.indices, what + " indices");
    } else {
      idx.resize(static_cast<std::size_t>(count));
      for (int i = 0; i < count; ++i) idx[i] = static_cast<std::uint32_t>(i);
    }
    if (idx.size() % 3) throw Error(what + ": index count is not a multiple of 3");
    int mat = 0;
    if (p.material >= 0) mat = p.material;
    for (std::size_t i = 0; i < idx.size(); i += 3) {
      for (int c = 0; c < 3; ++c) {
        if (idx[i + c] >= static_cast<std::uint32_t>(count)) {
          throw Error(what + ": index " + std::to_string(idx[i + c]) + " out of range (" +
                      std::to_string(count) + " vertices)");
        }
      }
      tris.emplace_back(offset + static_cast<int>(idx[i]), offset + static_cast<int>(idx[i + 1]),
                        offset + static_cast<int>(idx[i + 2]));
      rig.triangle_material.push_back(mat);
    }
  }

  auto stack = [nv](const std::vector<Positions>& parts) {
    Positions out(nv, 3);
    Eigen::Index row = 0;
    for (const auto& p : parts) {
      out.middleRows(row, p.rows()) = p;
      row += p.rows();
    }
    return out;
  };
  rig.positions = stack(pos_parts);
  rig.triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f)
    rig.triangles.row(static_cast<Eigen::Index>(f)) = tris[f].transpose();
  if (rig.positions.rows() == 0) throw Error(what + ": mesh has no vertices");
  if (!rig.positions.allFinite()) throw Error(what + ": non-finite vertex coordinate");
  rig.normals = vertex_normals(rig.positions, rig.triangles);
  {
    Eigen::Index row = 0;
    for (const auto& n : nrm_parts) {
      const Eigen::Index rows = pos_parts[static_cast<std::size_t>(&n - nrm_parts.data())].rows();
      if (n.rows() == rows) rig.normals.middleRows(row, rows) = n.rowwise().normalized();
      row += rows;
    }
  }
  if (all_uv && !uv_parts.empty()) {
    rig.uvs.resize(nv, 2);
    Eigen::Index row = 0;
    for (const auto& u : uv_parts) {
      rig.uvs.middleRows(row, u.rows()) = u;
      row += u.rows();
    }
  }

  std::vector<std::string> names;
  if (mesh.extras.IsObject() && mesh.extras.Has("targetNames")) {
    const auto& tn = mesh.extras.Get("targetNames");
    for (std::size_t i = 0; tn.IsArray() && i < tn.ArrayLen(); ++i)
      names.push_back(tn.Get(static_cast<int>(i)).Get<std::string>());
  }
  for (std::size_t t = 0; t < n_targets; ++t) {
    const std::string nm = t < names.size() ? names[t] : "target_" + std::to_string(t);
    rig.shapes.push_back(Blendshape::from_dense(nm, stack(target_parts[t])));
  }
  read_landmarks(mesh, rig);
  read_materials(m, rig);
  rig.validate(what);
  return rig;
}

Rig read_glb(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  return parse_glb(bytes, path.string());
}

}  // namespace facecast::anim
