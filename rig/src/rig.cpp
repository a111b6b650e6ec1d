#include "facecast/rig/rig.hpp"

#include <algorithm>
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/core/utf8.hpp"

namespace facecast::rig {

Blendshape Blendshape::from_dense(std::string name, const Positions& dense, float tolerance) {
  Blendshape s;
  s.name = std::move(name);
  for (Eigen::Index v = 0; v < dense.rows(); ++v) {
    if (dense.row(v).cwiseAbs().maxCoeff() > tolerance) s.vertices.push_back(static_cast<int>(v));
  }
  s.deltas.resize(static_cast<Eigen::Index>(s.vertices.size()), 3);
  for (std::size_t k = 0; k < s.vertices.size(); ++k) {
    s.deltas.row(static_cast<Eigen::Index>(k)) = dense.row(s.vertices[k]);
  }
  return s;
}

Positions Blendshape::dense(int vertex_count) const {
  Positions d = Positions::Zero(vertex_count, 3);
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    d.row(vertices[k]) = deltas.row(static_cast<Eigen::Index>(k));
  }
  return d;
}

float Blendshape::max_displacement() const {
  return deltas.rows() ? deltas.rowwise().norm().maxCoeff() : 0.0f;
}

int Rig::find_shape(std::string_view name) const {
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    if (shapes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<std::string> Rig::shape_names() const {
  std::vector<std::string> names;
  names.reserve(shapes.size());
  for (const auto& s : shapes) names.push_back(s.name);
  return names;
}

int Rig::mesh_of(int vertex) const {
  const auto it = std::upper_bound(meshes.begin(), meshes.end(), vertex,
                                   [](int v, const MeshRange& m) { return v < m.first_vertex; });
  return it == meshes.begin() ? -1 : static_cast<int>(it - meshes.begin()) - 1;
}

void Rig::validate(std::string_view what) const {
  const std::string w(what);
  const int nv = vertex_count();
  if (nv == 0) throw Error(w + ": mesh has no vertices");
  if (triangle_count() == 0) throw Error(w + ": mesh has no triangles");
  if (!positions.allFinite()) throw Error(w + ": non-finite vertex coordinate");
  if (normals.rows() != nv) throw Error(w + ": normal count differs from vertex count");
  if (uvs.rows() != 0 && uvs.rows() != nv) throw Error(w + ": UV count differs from vertex count");
  if (triangles.minCoeff() < 0 || triangles.maxCoeff() >= nv) {
    throw Error(w + ": triangle index out of range");
  }
  if (static_cast<int>(triangle_material.size()) != triangle_count()) {
    throw Error(w + ": per-triangle material count differs from triangle count");
  }
  if (materials.empty()) throw Error(w + ": no materials");
  for (int m : triangle_material) {
    if (m < 0 || m >= static_cast<int>(materials.size()))
      throw Error(w + ": material out of range");
  }
  for (const auto& s : shapes) {
    if (static_cast<Eigen::Index>(s.vertices.size()) != s.deltas.rows()) {
      throw Error(w + ": shape '" + s.name + "' has mismatched delta rows");
    }
    for (std::size_t k = 0; k < s.vertices.size(); ++k) {
      if (s.vertices[k] < 0 || s.vertices[k] >= nv || (k && s.vertices[k] <= s.vertices[k - 1])) {
        throw Error(w + ": shape '" + s.name + "' vertex list out of range or unsorted");
      }
    }
    if (!s.deltas.allFinite()) throw Error(w + ": shape '" + s.name + "' has a non-finite delta");
  }
  const auto check_name = [&](const std::string& kind, const std::string& name) {
    if (!is_valid_utf8(name)) throw Error(w + ": " + kind + " name is not valid UTF-8");
  };
  if (!meshes.empty()) {
    int next = 0;
    for (const auto& m : meshes) {
      check_name("mesh", m.name);
      if (m.first_vertex != next || m.vertex_count <= 0)
        throw Error(w + ": mesh '" + m.name + "' does not start where the previous one ends");
      next += m.vertex_count;
    }
    if (next != nv)
      throw Error(w + ": the meshes cover " + std::to_string(next) + " of " + std::to_string(nv) +
                  " vertices");
    for (int f = 0; f < triangle_count(); ++f) {
      const auto in = [&](int v) { return mesh_of(v); };
      if (in(triangles(f, 1)) != in(triangles(f, 0)) || in(triangles(f, 2)) != in(triangles(f, 0)))
        throw Error(w + ": triangle " + std::to_string(f) + " joins two meshes");
    }
  }
  for (const auto& m : materials) check_name("material", m.name);
  for (const auto& g : groups) check_name("group", g);
  for (const auto& s : shapes) check_name("shape", s.name);
  for (const auto& l : landmarks) {
    check_name("landmark", l.name);
    if (l.vertex < 0 || l.vertex >= nv) {
      throw Error(w + ": landmark '" + l.name + "' vertex " + std::to_string(l.vertex) +
                  " out of range");
    }
  }
  const int nt = static_cast<int>(textures.size());
  for (const auto& m : materials) {
    for (const TextureRef* t : {&m.base_color_texture, &m.metallic_roughness_texture,
                                &m.normal_texture, &m.occlusion_texture, &m.emissive_texture}) {
      if (t->texture < -1 || t->texture >= nt)
        throw Error(w + ": material '" + m.name + "' texture out of range");
    }
  }
  const int nj = static_cast<int>(skeleton.joint_names.size());
  if (skeleton.parent.size() != skeleton.joint_names.size() ||
      skeleton.rest_origin.size() != skeleton.joint_names.size())
    throw Error(w + ": skeleton joint arrays differ in length");
  for (int j = 0; j < nj; ++j) {
    if (skeleton.parent[j] < -1 || skeleton.parent[j] >= nj || skeleton.parent[j] == j)
      throw Error(w + ": skeleton joint " + std::to_string(j) + " has a bad parent");
  }
  if (skeleton.head < -1 || skeleton.head >= nj || skeleton.neck < -1 || skeleton.neck >= nj)
    throw Error(w + ": skeleton head or neck joint out of range");
  const auto& sb = skeleton.springs;
  const int nc = static_cast<int>(sb.colliders.size());
  for (const auto& c : sb.colliders)
    if (c.joint < -1 || c.joint >= nj || !(c.radius >= 0) || !c.offset.allFinite() ||
        !c.tail.allFinite())
      throw Error(w + ": bad spring collider");
  for (const auto& spring : sb.springs) {
    for (const auto& j : spring.joints)
      if (j.joint < 0 || j.joint >= nj || !j.tail.allFinite() || !j.gravity_dir.allFinite() ||
          !std::isfinite(j.hit_radius + j.stiffness + j.gravity_power + j.drag))
        throw Error(w + ": bad spring joint");
    for (const int c : spring.colliders)
      if (c < 0 || c >= nc) throw Error(w + ": spring collider index out of range");
  }
  if (joints.rows() != joint_weights.rows() || (joints.rows() != 0 && joints.rows() != nv))
    throw Error(w + ": joint count differs from vertex count");
  if (joints.rows() && (joints.minCoeff() < 0 || joints.maxCoeff() >= nj))
    throw Error(w + ": vertex joint index out of range");
  if (!joint_weights.allFinite()) throw Error(w + ": non-finite joint weight");
}

}  // namespace facecast::rig
