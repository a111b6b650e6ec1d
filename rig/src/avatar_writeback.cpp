// Writing a view's shapes back into the document (see avatar_view.hpp: write_back). Deltas go
// through the inverse of the map that brought each vertex into the rig; new data is appended to
// the first buffer; nothing else in the document changes.
#include <Eigen/LU>
#include <cstring>
#include <map>

#include "avatar_view_detail.hpp"
#include "facecast/core/error.hpp"
#include "gltf_accessors.hpp"

namespace facecast::rig {
namespace {

constexpr float kUnchanged = 1e-6f;

class Writer {
 public:
  explicit Writer(tinygltf::Model& m) : m_(m) {
    if (m_.buffers.empty()) m_.buffers.emplace_back();
  }

  // A VEC3 float accessor of `deltas` (rows of a morph target), with min/max; a zero accessor
  // without data when `deltas` is all zeros of `count` rows.
  int add_target(const Positions& deltas) {
    tinygltf::Accessor a;
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.type = TINYGLTF_TYPE_VEC3;
    a.count = static_cast<std::size_t>(deltas.rows());
    for (int c = 0; c < 3; ++c) {
      a.minValues.push_back(deltas.rows() ? deltas.col(c).minCoeff() : 0.0);
      a.maxValues.push_back(deltas.rows() ? deltas.col(c).maxCoeff() : 0.0);
    }
    if (!deltas.isZero(0.0f)) {
      auto& buf = m_.buffers[0].data;
      while (buf.size() % 4) buf.push_back(0);
      tinygltf::BufferView view;
      view.buffer = 0;
      view.byteOffset = buf.size();
      view.byteLength = static_cast<std::size_t>(deltas.size()) * sizeof(float);
      const auto* p = reinterpret_cast<const unsigned char*>(deltas.data());
      buf.insert(buf.end(), p, p + view.byteLength);
      m_.bufferViews.push_back(view);
      a.bufferView = static_cast<int>(m_.bufferViews.size()) - 1;
    }
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size()) - 1;
  }

 private:
  tinygltf::Model& m_;
};

// The mesh's target names: mesh.extras.targetNames, else the first primitive's.
std::vector<std::string> target_names(const tinygltf::Mesh& mesh) {
  for (const tinygltf::Value* ex :
       {&mesh.extras, mesh.primitives.empty() ? nullptr : &mesh.primitives[0].extras}) {
    if (!ex || !ex->IsObject() || !ex->Get("targetNames").IsArray()) continue;
    std::vector<std::string> out;
    const auto& tn = ex->Get("targetNames");
    for (std::size_t i = 0; i < tn.ArrayLen(); ++i)
      out.push_back(tn.Get(static_cast<int>(i)).IsString()
                        ? tn.Get(static_cast<int>(i)).Get<std::string>()
                        : "");
    return out;
  }
  return {};
}

void set_names(tinygltf::Value& extras, const std::vector<std::string>& names) {
  tinygltf::Value::Object o =
      extras.IsObject() ? extras.Get<tinygltf::Value::Object>() : tinygltf::Value::Object{};
  tinygltf::Value::Array arr;
  for (const auto& n : names) arr.emplace_back(n);
  o["targetNames"] = tinygltf::Value(std::move(arr));
  extras = tinygltf::Value(std::move(o));
}

}  // namespace

void write_back(AvatarDocument& doc, const AvatarView& view, const Rig& rig) {
  tinygltf::Model& m = doc.model();
  if (rig.vertex_count() != view.rig.vertex_count())
    throw Error(doc.name() + ": the rig has " + std::to_string(rig.vertex_count()) +
                " vertices, the view " + std::to_string(view.rig.vertex_count()));
  // The owner part of each (mesh, POSITION accessor): where that primitive's vertices are.
  std::map<int, std::map<int, const ViewPart*>> parts_of_mesh;
  for (const auto& p : view.parts)
    if (p.owner) parts_of_mesh[p.mesh].try_emplace(p.position_accessor, &p);
  std::vector<Eigen::Matrix3f> from_rig(view.to_rig.size());
  for (std::size_t v = 0; v < from_rig.size(); ++v) from_rig[v] = view.to_rig[v].inverse();

  Writer w(m);
  for (const auto& shape : rig.shapes) {
    if (std::find(view.derived_shapes.begin(), view.derived_shapes.end(), shape.name) !=
        view.derived_shapes.end())
      continue;
    const Positions dense = shape.dense(rig.vertex_count());
    for (auto& [mi, parts] : parts_of_mesh) {
      tinygltf::Mesh& mesh = m.meshes[static_cast<std::size_t>(mi)];
      std::map<int, Positions> local;  // POSITION accessor -> file-space deltas
      bool moves = false;
      for (const auto& [acc, part] : parts) {
        Positions d(part->vertex_count, 3);
        for (int v = 0; v < part->vertex_count; ++v) {
          const auto row = static_cast<std::size_t>(part->first_vertex + v);
          d.row(v) =
              (from_rig[row] * dense.row(static_cast<Eigen::Index>(row)).transpose()).transpose();
        }
        if (!d.allFinite())
          throw Error(doc.name() + ": shape '" + shape.name + "' cannot go back into mesh " +
                      mesh.name + " (its node transform is degenerate)");
        moves |= !d.isZero(0.0f);
        local.emplace(acc, std::move(d));
      }
      std::vector<std::string> names = target_names(mesh);
      const auto it = std::find(names.begin(), names.end(), shape.name);
      if (it != names.end()) {
        const auto t = static_cast<std::size_t>(it - names.begin());
        std::map<int, int> written;
        for (auto& prim : mesh.primitives) {
          const auto pos = prim.attributes.find("POSITION");
          if (pos == prim.attributes.end() || t >= prim.targets.size() || !local.count(pos->second))
            continue;
          const auto old = prim.targets[t].find("POSITION");
          const Positions& d = local.at(pos->second);
          if (old != prim.targets[t].end()) {
            const auto cur = detail::read_floats(m, old->second, 3, doc.name() + " target");
            if (cur.rows() == d.rows() && (cur - d).cwiseAbs().maxCoeff() <= kUnchanged) continue;
          }
          auto [wt, fresh] = written.try_emplace(pos->second, -1);
          if (fresh) wt->second = w.add_target(d);
          prim.targets[t]["POSITION"] = wt->second;
        }
        continue;
      }
      if (!moves) continue;
      std::map<int, int> written;
      for (auto& prim : mesh.primitives) {
        const auto pos = prim.attributes.find("POSITION");
        const int acc = pos == prim.attributes.end() ? -1 : pos->second;
        auto [wt, fresh] = written.try_emplace(acc, -1);
        if (fresh) {
          const auto lt = local.find(acc);
          const std::size_t count = acc >= 0 ? detail::accessor_at(m, acc, doc.name()).count : 0;
          wt->second = w.add_target(lt != local.end()
                                        ? lt->second
                                        : Positions::Zero(static_cast<Eigen::Index>(count), 3));
        }
        prim.targets.push_back({{"POSITION", wt->second}});
      }
      const bool names_on_primitives = !mesh.extras.Get("targetNames").IsArray() && !names.empty();
      names.resize(mesh.primitives.empty() ? 0 : mesh.primitives[0].targets.size() - 1);
      names.push_back(shape.name);
      if (names_on_primitives) {
        for (auto& prim : mesh.primitives) set_names(prim.extras, names);
      } else {
        set_names(mesh.extras, names);
      }
      if (!mesh.weights.empty()) mesh.weights.resize(names.size(), 0.0);
      for (auto& node : m.nodes)
        if (node.mesh == mi && !node.weights.empty()) node.weights.resize(names.size(), 0.0);
    }
  }
}

}  // namespace facecast::rig
