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

// Where an accessor's elements lie: `count` elements of `elem` bytes, `stride` apart, from
// `data` (nullptr: an accessor without a buffer view, all zeros). Every index and extent is
// checked before anything is read or allocated, without overflow, so a hostile file that declares
// a huge count or points past its buffers is a one-line error.
struct AccessorSpan {
  const unsigned char* data = nullptr;
  std::size_t stride = 0, count = 0;
};

AccessorSpan accessor_span(const tinygltf::Model& m, int index, std::size_t elem,
                           const std::string& what) {
  if (index < 0 || static_cast<std::size_t>(index) >= m.accessors.size())
    throw Error(what + ": accessor " + std::to_string(index) + " does not exist");
  const auto& a = m.accessors[static_cast<std::size_t>(index)];
  if (a.sparse.isSparse)
    throw Error(what + ": sparse accessors are not supported", ErrorCode::kUnsupported);
  AccessorSpan span;
  span.count = a.count;
  if (a.bufferView < 0) return span;
  if (static_cast<std::size_t>(a.bufferView) >= m.bufferViews.size())
    throw Error(what + ": buffer view " + std::to_string(a.bufferView) + " does not exist");
  const auto& view = m.bufferViews[static_cast<std::size_t>(a.bufferView)];
  if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= m.buffers.size())
    throw Error(what + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const auto& buf = m.buffers[static_cast<std::size_t>(view.buffer)].data;
  if (view.byteOffset > buf.size() || view.byteLength > buf.size() - view.byteOffset)
    throw Error(what + ": buffer view runs past the end of its buffer");
  span.stride = view.byteStride ? view.byteStride : elem;
  if (span.stride < elem) throw Error(what + ": byte stride is smaller than an element");
  const std::size_t room = view.byteLength < a.byteOffset ? 0 : view.byteLength - a.byteOffset;
  if (a.count && (room < elem || (a.count - 1) > (room - elem) / span.stride))
    throw Error(what + ": " + std::to_string(a.count) + " elements run past the end of the view");
  span.data = buf.data() + view.byteOffset + a.byteOffset;
  return span;
}

// Reads a float accessor of `comps` components per element into a row-major matrix.
template <typename Matrix>
Matrix read_float_accessor(const tinygltf::Model& m, int index, int comps,
                           const std::string& what) {
  const std::size_t elem = sizeof(float) * static_cast<std::size_t>(comps);
  const AccessorSpan span = accessor_span(m, index, elem, what);
  const auto& a = m.accessors[static_cast<std::size_t>(index)];
  if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT ||
      tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)) != comps) {
    throw Error(what + ": expected float vectors of " + std::to_string(comps) + " components",
                ErrorCode::kUnsupported);
  }
  Matrix out(static_cast<Eigen::Index>(span.count), comps);
  if (!span.data) {
    out.setZero();
    return out;
  }
  for (std::size_t i = 0; i < span.count; ++i)
    std::memcpy(out.row(static_cast<Eigen::Index>(i)).data(), span.data + i * span.stride, elem);
  return out;
}

std::vector<std::uint32_t> read_indices(const tinygltf::Model& m, int index,
                                        const std::string& what) {
  if (index < 0 || static_cast<std::size_t>(index) >= m.accessors.size())
    throw Error(what + ": accessor " + std::to_string(index) + " does not exist");
  const auto type = m.accessors[static_cast<std::size_t>(index)].componentType;
  if (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
      type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    throw Error(what + ": indices must be unsigned 8, 16 or 32 bit integers");
  const auto size =
      static_cast<std::size_t>(tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(type)));
  const AccessorSpan span = accessor_span(m, index, size, what);
  if (!span.data) throw Error(what + ": index accessor without a buffer view");
  std::vector<std::uint32_t> out(span.count);
  for (std::size_t i = 0; i < span.count; ++i) {
    const unsigned char* p = span.data + i * span.stride;
    if (size == 1) {
      out[i] = *p;
    } else if (size == 2) {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      out[i] = v;
    } else {
      std::memcpy(&out[i], p, 4);
    }
  }
  return out;
}

// Uploads reach parse_glb: it reads nothing outside the bytes it is given (a buffer or image URI
// pointing at a local file is an error) and leaves images undecoded (no decoder runs on them).
bool refuse_external_file(std::vector<unsigned char>*, std::string* err, const std::string& path,
                          void*) {
  if (err) *err = "external file '" + path + "' is not read from a GLB";
  return false;
}
bool no_file_exists(const std::string&, void*) {
  return false;
}
std::string path_as_is(const std::string& path, void*) {
  return path;
}
bool refuse_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err = "writing files while reading a GLB";
  return false;
}

bool keep_image_undecoded(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                          const unsigned char*, int, void*) {
  return true;
}

}  // namespace

namespace {

tinygltf::Model load_model(std::string_view bytes, const std::string& what) {
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{&no_file_exists, &path_as_is, &refuse_external_file, &refuse_write,
                           nullptr};
  loader.SetFsCallbacks(fs);
  loader.SetImageLoader(&keep_image_undecoded, nullptr);
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

// The vertices of a mesh's primitives, stacked. Primitives that share a POSITION accessor share
// vertices (the layout glb_bytes writes); others are appended one after another.
class MeshVertices {
 public:
  MeshVertices(const tinygltf::Model& m, std::size_t targets, std::string what)
      : m_(m), targets_(targets), what_(std::move(what)), target_(targets) {}

  /// The first row of the primitive's vertices, reading them when the accessor is new.
  int add(const tinygltf::Primitive& p, int position_accessor) {
    auto [it, fresh] = offset_of_.try_emplace(position_accessor, count_);
    if (!fresh) return it->second;
    Positions pp = read_float_accessor<Positions>(m_, position_accessor, 3, what_ + " POSITION");
    const auto n_it = p.attributes.find("NORMAL");
    nrm_.push_back(n_it != p.attributes.end()
                       ? read_float_accessor<Positions>(m_, n_it->second, 3, what_ + " NORMAL")
                       : Positions());
    const auto t_it = p.attributes.find("TEXCOORD_0");
    if (t_it != p.attributes.end()) {
      uv_.push_back(read_float_accessor<UVs>(m_, t_it->second, 2, what_ + " TEXCOORD_0"));
      if (uv_.back().rows() != pp.rows())
        throw Error(what_ + " TEXCOORD_0: " + std::to_string(uv_.back().rows()) + " elements for " +
                    std::to_string(pp.rows()) + " positions");
    } else {
      all_uv_ = false;
      uv_.emplace_back();
    }
    for (std::size_t t = 0; t < targets_; ++t) {
      const auto tp = p.targets[t].find("POSITION");
      target_[t].push_back(tp != p.targets[t].end() ? read_float_accessor<Positions>(
                                                          m_, tp->second, 3, what_ + " target")
                                                    : Positions::Zero(pp.rows(), 3));
      if (target_[t].back().rows() != pp.rows()) throw Error(what_ + ": morph target size differs");
    }
    count_ += static_cast<int>(pp.rows());
    pos_.push_back(std::move(pp));
    return it->second;
  }

  /// Positions, normals (read where given, else from the triangles), UVs and shapes into `rig`.
  void fill(Rig& rig, const std::vector<std::string>& names) const {
    rig.positions = stack(pos_);
    if (rig.positions.rows() == 0) throw Error(what_ + ": mesh has no vertices");
    if (!rig.positions.allFinite()) throw Error(what_ + ": non-finite vertex coordinate");
    rig.normals = vertex_normals(rig.positions, rig.triangles);
    Eigen::Index row = 0;
    for (std::size_t k = 0; k < pos_.size(); ++k) {
      const Eigen::Index rows = pos_[k].rows();
      if (nrm_[k].rows() == rows)
        rig.normals.middleRows(row, rows) = nrm_[k].rowwise().normalized();
      row += rows;
    }
    if (all_uv_ && !uv_.empty()) rig.uvs = stack(uv_);
    for (std::size_t t = 0; t < targets_; ++t) {
      const std::string nm = t < names.size() ? names[t] : "target_" + std::to_string(t);
      rig.shapes.push_back(Blendshape::from_dense(nm, stack(target_[t])));
    }
  }

 private:
  template <typename Matrix>
  Matrix stack(const std::vector<Matrix>& parts) const {
    Matrix out(count_, Matrix::ColsAtCompileTime);
    Eigen::Index row = 0;
    for (const auto& p : parts) {
      out.middleRows(row, p.rows()) = p;
      row += p.rows();
    }
    return out;
  }

  const tinygltf::Model& m_;
  std::size_t targets_;
  std::string what_;
  std::map<int, int> offset_of_;
  std::vector<Positions> pos_, nrm_;
  std::vector<std::vector<Positions>> target_;  // per morph target, per part
  std::vector<UVs> uv_;
  bool all_uv_ = true;
  int count_ = 0;
};

// A primitive's triangles, `offset` added to its indices, with its material.
void append_triangles(const tinygltf::Model& m, const tinygltf::Primitive& p, int offset,
                      int position_accessor, const std::string& what,
                      std::vector<Eigen::Vector3i>& tris, std::vector<int>& materials) {
  // The POSITION accessor was checked when its vertices were read.
  const int count =
      static_cast<int>(m.accessors[static_cast<std::size_t>(position_accessor)].count);
  std::vector<std::uint32_t> idx;
  if (p.indices >= 0) {
    idx = read_indices(m, p.indices, what + " indices");
  } else {
    idx.resize(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) idx[i] = static_cast<std::uint32_t>(i);
  }
  if (idx.size() % 3) throw Error(what + ": index count is not a multiple of 3");
  for (std::size_t i = 0; i < idx.size(); i += 3) {
    for (int c = 0; c < 3; ++c) {
      if (idx[i + c] >= static_cast<std::uint32_t>(count)) {
        throw Error(what + ": index " + std::to_string(idx[i + c]) + " out of range (" +
                    std::to_string(count) + " vertices)");
      }
    }
    tris.emplace_back(offset + static_cast<int>(idx[i]), offset + static_cast<int>(idx[i + 1]),
                      offset + static_cast<int>(idx[i + 2]));
    materials.push_back(p.material >= 0 ? p.material : 0);
  }
}

// mesh.extras: targetNames and Facecast's landmarks.
std::vector<std::string> read_extras(const tinygltf::Mesh& mesh, Rig& rig) {
  std::vector<std::string> names;
  if (!mesh.extras.IsObject()) return names;
  if (mesh.extras.Has("targetNames")) {
    const auto& tn = mesh.extras.Get("targetNames");
    for (std::size_t i = 0; tn.IsArray() && i < tn.ArrayLen(); ++i)
      names.push_back(tn.Get(static_cast<int>(i)).Get<std::string>());
  }
  if (mesh.extras.Has("facecast")) {
    const auto& fc = mesh.extras.Get("facecast");
    if (fc.Has("landmarks")) {
      const auto& lm = fc.Get("landmarks");
      for (std::size_t i = 0; lm.IsArray() && i < lm.ArrayLen(); ++i) {
        const auto& o = lm.Get(static_cast<int>(i));
        rig.landmarks.push_back(
            {o.Get("name").Get<std::string>(), o.Get("vertex").GetNumberAsInt()});
      }
    }
  }
  return names;
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
  MeshVertices vertices(m, n_targets, what);
  std::vector<Eigen::Vector3i> tris;
  for (const auto& p : mesh.primitives) {
    if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) {
      throw Error(what + ": only triangle primitives are supported", ErrorCode::kUnsupported);
    }
    const auto it = p.attributes.find("POSITION");
    if (it == p.attributes.end()) throw Error(what + ": primitive without POSITION");
    if (p.targets.size() != n_targets) throw Error(what + ": primitives disagree on morph targets");
    const int offset = vertices.add(p, it->second);
    append_triangles(m, p, offset, it->second, what, tris, rig.triangle_material);
  }
  rig.triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f)
    rig.triangles.row(static_cast<Eigen::Index>(f)) = tris[f].transpose();
  vertices.fill(rig, read_extras(mesh, rig));

  for (const auto& gm : m.materials) {
    Material mat = Material::solid(gm.name);
    const auto& f = gm.pbrMetallicRoughness.baseColorFactor;
    for (std::size_t c = 0; c < 4 && c < f.size(); ++c)
      mat.base_color[static_cast<Eigen::Index>(c)] = static_cast<float>(f[c]);
    rig.materials.push_back(mat);
  }
  if (rig.materials.empty()) rig.materials.push_back(Material::solid("default"));
  rig.validate(what);
  return rig;
}

Rig read_glb(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  return parse_glb(bytes, path.string());
}

}  // namespace facecast::anim
