// The Rig as a view of an avatar document (see avatar_view.hpp): parts read in node order,
// placed in the bind pose, merged; morph targets merged by name.
#include "facecast/rig/avatar_view.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "avatar_view_detail.hpp"
#include "facecast/core/error.hpp"
#include "gltf_accessors.hpp"

namespace facecast::rig {
namespace {

using detail::read_floats;
using detail::read_uints;
using JointRows = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;
using WeightRows = Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor>;

// One primitive's vertices in rig space.
struct PartData {
  ViewPart part;
  Positions pos, nrm;
  UVs uv;
  std::vector<Eigen::Matrix3f> lin;  // per vertex: rig-from-file linear map
  JointRows joints;                  // skeleton indices (filled for skinned parts)
  WeightRows weights;
  std::vector<std::string> target_names;
  std::vector<Positions> targets;  // rig-space deltas
};

std::vector<std::string> names_in(const tinygltf::Value& extras) {
  std::vector<std::string> out;
  if (!extras.IsObject() || !extras.Has("targetNames")) return out;
  const auto& tn = extras.Get("targetNames");
  for (std::size_t i = 0; tn.IsArray() && i < tn.ArrayLen(); ++i) {
    const auto& v = tn.Get(static_cast<int>(i));
    out.push_back(v.IsString() ? v.Get<std::string>() : "target_" + std::to_string(i));
  }
  return out;
}

class ViewBuilder {
 public:
  // A document read from a file keeps to its limits: every accessor read and per-vertex array
  // is charged to a budget of its size decoded (what the view reads: compressed data unpacked).
  ViewBuilder(const AvatarDocument& doc, const ViewOptions& opt)
      : m_(doc.model()),
        what_(doc.name()),
        g_(detail::node_graph(m_, what_)),
        opt_(opt),
        budget_(view_budget(doc)) {}

  static detail::DecodeBudget view_budget(const AvatarDocument& doc) {
    if (!doc.source_bytes()) return {};
    if (doc.decoded_bytes() <= doc.source_bytes())
      return detail::DecodeBudget(doc.limits(), doc.source_bytes());
    return detail::DecodeBudget(doc.limits(), doc.decoded_bytes(), 0, "decoded file");
  }

  AvatarView build() {
    bool any_targets = false;
    for (const auto& mesh : m_.meshes)
      for (const auto& p : mesh.primitives) any_targets |= !p.targets.empty();
    const int head = opt_.all_meshes || any_targets ? -1 : head_joint_node();
    for (const int node : g_.order) {
      const int mi = m_.nodes[static_cast<std::size_t>(node)].mesh;
      if (mi < 0) continue;
      if (static_cast<std::size_t>(mi) >= m_.meshes.size())
        throw Error(what_ + ": nodes[" + std::to_string(node) + "] names mesh " +
                    std::to_string(mi) + ", which does not exist");
      const auto& mesh = m_.meshes[static_cast<std::size_t>(mi)];
      bool has_targets = false;
      for (const auto& p : mesh.primitives) has_targets |= !p.targets.empty();
      if (!opt_.all_meshes && any_targets && !has_targets) continue;
      if (head >= 0 && !on_head(node, head)) continue;
      for (std::size_t pi = 0; pi < mesh.primitives.size(); ++pi)
        add_primitive(node, mi, static_cast<int>(pi));
    }
    if (tris_.empty()) throw Error(what_ + ": the glTF has no triangle mesh");
    return assemble();
  }

 private:
  // The node of the skeleton's head joint (a skin joint named as find_joint knows), or -1.
  int head_joint_node() const {
    std::vector<int> joints;
    std::vector<std::string> names;
    for (const auto& skin : m_.skins)
      for (const int j : skin.joints)
        if (j >= 0 && static_cast<std::size_t>(j) < m_.nodes.size()) {
          joints.push_back(j);
          names.push_back(m_.nodes[static_cast<std::size_t>(j)].name);
        }
    const int k = find_joint(names, "head");
    return k < 0 ? -1 : joints[static_cast<std::size_t>(k)];
  }

  bool under(int node, int ancestor) const {
    for (int n = node; n >= 0; n = g_.parent[static_cast<std::size_t>(n)])
      if (n == ancestor) return true;
    return false;
  }

  // Without morph targets anywhere, the face is what the head carries: a mesh under the head
  // joint (teeth, eyes placed by a node), or a skinned mesh whose first primitive puts at least
  // half its skin weight on the head joint and the joints under it (head, eyes, lashes); not the
  // body, clothes or hands.
  bool on_head(int node, int head) const {
    if (under(node, head)) return true;
    const auto& n = m_.nodes[static_cast<std::size_t>(node)];
    if (n.skin < 0 || static_cast<std::size_t>(n.skin) >= m_.skins.size()) return false;
    const auto& prim = m_.meshes[static_cast<std::size_t>(n.mesh)].primitives;
    if (prim.empty()) return false;
    const auto j_it = prim[0].attributes.find("JOINTS_0");
    const auto w_it = prim[0].attributes.find("WEIGHTS_0");
    if (j_it == prim[0].attributes.end() || w_it == prim[0].attributes.end()) return false;
    const auto& joints = m_.skins[static_cast<std::size_t>(n.skin)].joints;
    std::vector<char> joint_on_head(joints.size());  // once per joint, not per vertex
    for (std::size_t k = 0; k < joints.size(); ++k) joint_on_head[k] = under(joints[k], head);
    const std::string at = what_ + ": meshes[" + std::to_string(n.mesh) + "]";
    const auto j = read_uints(m_, j_it->second, 4, at + " JOINTS_0", &budget_);
    const auto w = read_floats(m_, w_it->second, 4, at + " WEIGHTS_0", &budget_);
    if (j.size() != static_cast<std::size_t>(w.rows()) * 4) return false;
    double on = 0, total = 0;
    for (Eigen::Index v = 0; v < w.rows(); ++v)
      for (int c = 0; c < 4; ++c) {
        const std::uint32_t k = j[static_cast<std::size_t>(v) * 4 + static_cast<std::size_t>(c)];
        total += w(v, c);
        if (k < joints.size() && joint_on_head[k]) on += w(v, c);
      }
    return total > 0 && on >= 0.5 * total;
  }

  int group_of(int mesh) {
    const auto [it, fresh] = group_of_.try_emplace(mesh, static_cast<int>(groups_.size()));
    if (fresh) {
      const auto& nm = m_.meshes[static_cast<std::size_t>(mesh)].name;
      groups_.push_back(nm.empty() ? "mesh" + std::to_string(mesh) : nm);
    }
    return it->second;
  }

  void add_primitive(int node, int mi, int pi) {
    const auto& prim =
        m_.meshes[static_cast<std::size_t>(mi)].primitives[static_cast<std::size_t>(pi)];
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN)
      return;  // points and lines are not part of a face
    const std::string at =
        what_ + " meshes[" + std::to_string(mi) + "].primitives[" + std::to_string(pi) + "]";
    const auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) throw Error(at + ": primitive without POSITION");
    const auto [it, fresh] =
        owner_.try_emplace({node, pos_it->second}, static_cast<int>(parts_.size()));
    PartData data;
    data.part = {node,           mi,    pi,   m_.meshes[static_cast<std::size_t>(mi)].name, 0, 0,
                 pos_it->second, false, fresh};
    if (fresh) {
      read_part(data, prim, at);
      data.part.first_vertex = vertex_count_;
      vertex_count_ += data.part.vertex_count;
    } else {
      const auto& owner = parts_[static_cast<std::size_t>(it->second)].part;
      data.part.first_vertex = owner.first_vertex;
      data.part.vertex_count = owner.vertex_count;
      data.part.skinned = owner.skinned;
    }
    append_triangles(prim, mode, data.part,
                     fresh ? data.lin : parts_[static_cast<std::size_t>(it->second)].lin, at);
    parts_.push_back(std::move(data));
  }

  // The rig-from-file map per vertex: the node's world transform, or linear blend skinning with
  // the joints where the file's nodes hold them (glTF ignores a skinned mesh's node transform).
  void place(PartData& d, const tinygltf::Primitive& prim, const std::string& at,
             std::vector<Eigen::Vector3f>& shift) {
    const auto& node = m_.nodes[static_cast<std::size_t>(d.part.node)];
    const auto n = static_cast<std::size_t>(d.pos.rows());
    const auto j_it = prim.attributes.find("JOINTS_0");
    const auto w_it = prim.attributes.find("WEIGHTS_0");
    if (node.skin < 0 || j_it == prim.attributes.end() || w_it == prim.attributes.end()) {
      const Eigen::Matrix4f& w = g_.world[static_cast<std::size_t>(d.part.node)];
      d.lin.assign(n, w.topLeftCorner<3, 3>());
      shift.assign(n, w.block<3, 1>(0, 3));
      return;
    }
    if (static_cast<std::size_t>(node.skin) >= m_.skins.size())
      throw Error(at + ": skin " + std::to_string(node.skin) + " does not exist");
    const auto& skin = m_.skins[static_cast<std::size_t>(node.skin)];
    std::vector<Eigen::Matrix4f> joint_matrix;
    detail::FloatRows ibm;
    if (skin.inverseBindMatrices >= 0) {
      ibm = read_floats(m_, skin.inverseBindMatrices, 16, at + " inverseBindMatrices", &budget_);
      if (static_cast<std::size_t>(ibm.rows()) < skin.joints.size())
        throw Error(at + ": fewer inverse bind matrices than joints");
    }
    std::vector<int> global(skin.joints.size());
    for (std::size_t k = 0; k < skin.joints.size(); ++k) {
      const int jn = skin.joints[k];
      if (jn < 0 || static_cast<std::size_t>(jn) >= m_.nodes.size())
        throw Error(at + ": skin joint " + std::to_string(jn) + " does not exist");
      Eigen::Matrix4f inv = Eigen::Matrix4f::Identity();
      if (ibm.rows())
        inv = Eigen::Map<const Eigen::Matrix4f>(ibm.row(static_cast<Eigen::Index>(k)).data());
      joint_matrix.push_back(g_.world[static_cast<std::size_t>(jn)] * inv);
      const auto [jt, fresh] = joint_index_.try_emplace(jn, static_cast<int>(joint_nodes_.size()));
      if (fresh) joint_nodes_.push_back(jn);
      global[k] = jt->second;
    }
    const auto joints = read_uints(m_, j_it->second, 4, at + " JOINTS_0", &budget_);
    const auto weights = read_floats(m_, w_it->second, 4, at + " WEIGHTS_0", &budget_);
    if (joints.size() != n * 4 || static_cast<std::size_t>(weights.rows()) != n)
      throw Error(at + ": JOINTS_0/WEIGHTS_0 counts differ from POSITION");
    d.part.skinned = true;
    d.joints.resize(static_cast<Eigen::Index>(n), 4);
    d.weights.resize(static_cast<Eigen::Index>(n), 4);
    d.lin.resize(n);
    shift.resize(n);
    for (std::size_t v = 0; v < n; ++v) {
      Eigen::Matrix4f sum = Eigen::Matrix4f::Zero();
      const float total = weights.row(static_cast<Eigen::Index>(v)).sum();
      for (int c = 0; c < 4; ++c) {
        const float w =
            total > 0 ? weights(static_cast<Eigen::Index>(v), c) / total : (c == 0 ? 1.0f : 0.0f);
        std::uint32_t j = joints[v * 4 + static_cast<std::size_t>(c)];
        if (j >= skin.joints.size()) {
          if (w != 0) throw Error(at + ": joint index " + std::to_string(j) + " out of range");
          j = 0;
        }
        if (skin.joints.empty()) throw Error(at + ": skin without joints");
        sum += w * joint_matrix[j];
        d.joints(static_cast<Eigen::Index>(v), c) = global[j];
        d.weights(static_cast<Eigen::Index>(v), c) = w;
      }
      d.lin[v] = sum.topLeftCorner<3, 3>();
      shift[v] = sum.block<3, 1>(0, 3);
    }
  }

  void read_part(PartData& d, const tinygltf::Primitive& prim, const std::string& at) {
    const auto attr = [&](const char* name) {
      const auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    d.pos = read_floats(m_, attr("POSITION"), 3, at + " POSITION", &budget_);
    const Eigen::Index n = d.pos.rows();
    d.part.vertex_count = static_cast<int>(n);
    // Per vertex: its map and shift here, its row of the merged rig (positions, normals, UVs,
    // joints, weights, the map again) in assemble().
    budget_.charge(detail::product(static_cast<std::size_t>(n), 2 * 48 + 56), at, "vertex data");
    std::vector<Eigen::Vector3f> shift;
    place(d, prim, at, shift);
    for (Eigen::Index v = 0; v < n; ++v)
      d.pos.row(v) = (d.lin[static_cast<std::size_t>(v)] * d.pos.row(v).transpose() +
                      shift[static_cast<std::size_t>(v)])
                         .transpose();
    if (attr("NORMAL") >= 0) {
      d.nrm = read_floats(m_, attr("NORMAL"), 3, at + " NORMAL", &budget_);
      if (d.nrm.rows() != n)
        throw Error(at + " NORMAL: " + std::to_string(d.nrm.rows()) + " elements for " +
                    std::to_string(n) + " positions");
      for (Eigen::Index v = 0; v < n; ++v) {
        // Normals go through the inverse transpose; a degenerate map (a zero scale) keeps them.
        const Eigen::Matrix3f& l = d.lin[static_cast<std::size_t>(v)];
        if (std::abs(l.determinant()) > 1e-12f)
          d.nrm.row(v) =
              (l.inverse().transpose() * d.nrm.row(v).transpose()).normalized().transpose();
      }
    }
    if (attr("TEXCOORD_0") >= 0) {
      d.uv = read_floats(m_, attr("TEXCOORD_0"), 2, at + " TEXCOORD_0", &budget_);
      if (d.uv.rows() != n)
        throw Error(at + " TEXCOORD_0: " + std::to_string(d.uv.rows()) + " elements for " +
                    std::to_string(n) + " positions");
    }
    std::vector<std::string> names = names_in(prim.extras);
    if (names.empty()) names = names_in(m_.meshes[static_cast<std::size_t>(d.part.mesh)].extras);
    for (std::size_t t = 0; t < prim.targets.size(); ++t) {
      const auto tp = prim.targets[t].find("POSITION");
      if (tp == prim.targets[t].end())
        budget_.charge(detail::product(static_cast<std::size_t>(n), 12), at, "morph target");
      Positions delta = Positions::Zero(n, 3);
      if (tp != prim.targets[t].end()) {
        delta = read_floats(m_, tp->second, 3, at + " target " + std::to_string(t), &budget_);
        if (delta.rows() != n)
          throw Error(at + ": morph target " + std::to_string(t) + " size differs from POSITION");
        for (Eigen::Index v = 0; v < n; ++v)
          delta.row(v) =
              (d.lin[static_cast<std::size_t>(v)] * delta.row(v).transpose()).transpose();
      }
      d.target_names.push_back(t < names.size() ? names[t] : "target_" + std::to_string(t));
      d.targets.push_back(std::move(delta));
    }
  }

  // A vertex whose map mirrors (negative determinant) turns its triangles' winding back, so that
  // counter-clockwise stays the front face in the rig as glTF defines it in the file.
  void append_triangles(const tinygltf::Primitive& prim, int mode, const ViewPart& part,
                        const std::vector<Eigen::Matrix3f>& lin, const std::string& at) {
    const auto count = static_cast<std::uint32_t>(part.vertex_count);
    std::vector<std::uint32_t> idx;
    if (prim.indices >= 0) {
      idx = read_uints(m_, prim.indices, 1, at + " indices", &budget_);
    } else {
      idx.resize(count);
      for (std::uint32_t i = 0; i < count; ++i) idx[i] = i;
    }
    for (const auto i : idx)
      if (i >= count)
        throw Error(at + ": index " + std::to_string(i) + " out of range (" +
                    std::to_string(count) + " vertices)");
    if (mode == TINYGLTF_MODE_TRIANGLES && idx.size() % 3)
      throw Error(at + ": index count is not a multiple of 3");
    // Per triangle (a strip or fan makes one per index): corners, material, group, and the rig's
    // row of them.
    const std::size_t triangles = mode == TINYGLTF_MODE_TRIANGLES ? idx.size() / 3 : idx.size();
    budget_.charge(detail::product(triangles, 2 * 20), at, "triangles");
    const int material =
        prim.material >= 0 && static_cast<std::size_t>(prim.material) < m_.materials.size()
            ? prim.material
            : static_cast<int>(m_.materials.size());  // the default material
    const int group = group_of(part.mesh);
    const auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
      if (a < lin.size() && lin[a].determinant() < 0) std::swap(b, c);
      tris_.emplace_back(part.first_vertex + static_cast<int>(a),
                         part.first_vertex + static_cast<int>(b),
                         part.first_vertex + static_cast<int>(c));
      tri_material_.push_back(material);
      tri_group_.push_back(group);
    };
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (std::size_t i = 0; i + 2 < idx.size(); i += 3) add(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (std::size_t i = 0; i + 2 < idx.size(); ++i)
        i % 2 ? add(idx[i + 1], idx[i], idx[i + 2]) : add(idx[i], idx[i + 1], idx[i + 2]);
    } else {
      for (std::size_t i = 1; i + 1 < idx.size(); ++i) add(idx[0], idx[i], idx[i + 1]);
    }
  }

  AvatarView assemble();
  void add_shapes(AvatarView& view);
  void add_skin(Rig& rig);

  const tinygltf::Model& m_;
  std::string what_;
  detail::NodeGraph g_;
  ViewOptions opt_;
  mutable detail::DecodeBudget budget_;
  std::vector<PartData> parts_;
  std::map<std::pair<int, int>, int> owner_;  // (node, POSITION accessor) -> part
  std::map<int, int> group_of_, joint_index_;
  std::vector<std::string> groups_;
  std::vector<int> joint_nodes_;
  std::vector<Eigen::Vector3i> tris_;
  std::vector<int> tri_material_, tri_group_;
  int vertex_count_ = 0;
};

AvatarView ViewBuilder::assemble() {
  AvatarView view;
  Rig& rig = view.rig;
  const Eigen::Index nv = vertex_count_;
  rig.positions.resize(nv, 3);
  bool any_uv = false;
  for (const auto& d : parts_) any_uv |= d.part.owner && d.uv.rows() > 0;
  if (any_uv) rig.uvs = UVs::Zero(nv, 2);
  view.to_rig.resize(static_cast<std::size_t>(nv));
  for (const auto& d : parts_) {
    if (!d.part.owner) continue;
    const Eigen::Index first = d.part.first_vertex, n = d.part.vertex_count;
    rig.positions.middleRows(first, n) = d.pos;
    if (d.uv.rows()) rig.uvs.middleRows(first, n) = d.uv;
    std::copy(d.lin.begin(), d.lin.end(), view.to_rig.begin() + first);
  }
  rig.triangles.resize(static_cast<Eigen::Index>(tris_.size()), 3);
  for (std::size_t f = 0; f < tris_.size(); ++f)
    rig.triangles.row(static_cast<Eigen::Index>(f)) = tris_[f].transpose();
  rig.normals = vertex_normals(rig.positions, rig.triangles);
  for (const auto& d : parts_)
    if (d.part.owner && d.nrm.rows())
      rig.normals.middleRows(d.part.first_vertex, d.part.vertex_count) = d.nrm;
  rig.triangle_material = tri_material_;
  rig.triangle_group = tri_group_;
  rig.groups = groups_;
  detail::read_materials(m_, rig);
  if (rig.materials.empty() ||
      std::find(tri_material_.begin(), tri_material_.end(),
                static_cast<int>(rig.materials.size())) != tri_material_.end())
    rig.materials.push_back(Material::solid("default"));  // for primitives without a material
  add_shapes(view);
  add_skin(rig);
  for (auto& d : parts_) view.parts.push_back(std::move(d.part));
  rig.validate(what_);
  return view;
}

void ViewBuilder::add_shapes(AvatarView& view) {
  Rig& rig = view.rig;
  const Eigen::Index nv = vertex_count_;
  std::vector<std::string> order;
  std::map<int, std::size_t> mesh_row;
  for (const auto& d : parts_) {
    if (!d.part.owner || d.targets.empty()) continue;
    auto [it, fresh] = mesh_row.try_emplace(d.part.mesh, view.meshes.size());
    if (fresh) view.meshes.push_back({d.part.mesh, d.part.mesh_name, 0, {}});
    ViewMesh& vm = view.meshes[it->second];
    vm.vertices += d.part.vertex_count;
    for (const auto& nm : d.target_names) {
      if (std::find(vm.targets.begin(), vm.targets.end(), nm) == vm.targets.end())
        vm.targets.push_back(nm);
      if (std::find(order.begin(), order.end(), nm) == order.end()) order.push_back(nm);
    }
  }
  Positions dense(nv, 3);
  for (const auto& name : order) {
    dense.setZero();
    for (const auto& d : parts_) {
      if (!d.part.owner) continue;
      for (std::size_t t = 0; t < d.targets.size(); ++t)
        if (d.target_names[t] == name)
          dense.middleRows(d.part.first_vertex, d.part.vertex_count) = d.targets[t];
    }
    rig.shapes.push_back(Blendshape::from_dense(name, dense));
  }
  for (const auto& e : detail::vrm_expressions(m_)) {
    if (rig.find_shape(e.name) >= 0 || e.binds.empty()) continue;
    dense.setZero();
    for (const auto& b : e.binds)
      for (const auto& d : parts_)
        if (d.part.owner && d.part.mesh == b.mesh && b.target >= 0 &&
            static_cast<std::size_t>(b.target) < d.targets.size())
          dense.middleRows(d.part.first_vertex, d.part.vertex_count) +=
              b.weight * d.targets[static_cast<std::size_t>(b.target)];
    rig.shapes.push_back(Blendshape::from_dense(e.name, dense));
    view.derived_shapes.push_back(e.name);
  }
  // Facecast's own landmarks (mesh.extras.facecast.landmarks), by vertex of each mesh's first part.
  std::set<int> meshes_done;
  for (const auto& d : parts_) {
    if (!d.part.owner || !meshes_done.insert(d.part.mesh).second) continue;
    const auto& ex = m_.meshes[static_cast<std::size_t>(d.part.mesh)].extras;
    if (!ex.IsObject() || !ex.Get("facecast").Get("landmarks").IsArray()) continue;
    const auto& lm = ex.Get("facecast").Get("landmarks");
    for (std::size_t i = 0; i < lm.ArrayLen(); ++i) {
      const auto& o = lm.Get(static_cast<int>(i));
      if (!o.Get("name").IsString() || !o.Get("vertex").IsInt() ||
          o.Get("vertex").GetNumberAsInt() < 0 ||
          o.Get("vertex").GetNumberAsInt() >= d.part.vertex_count)
        throw Error(what_ + ": malformed landmark in mesh " + d.part.mesh_name);
      rig.landmarks.push_back({o.Get("name").Get<std::string>(),
                               d.part.first_vertex + o.Get("vertex").GetNumberAsInt()});
    }
  }
}

// The skeleton over the skins' joints; unskinned parts follow the nearest joint above their node.
void ViewBuilder::add_skin(Rig& rig) {
  if (joint_nodes_.empty()) return;
  rig.skeleton = detail::read_skeleton(m_, g_, joint_nodes_);
  const Eigen::Index nv = vertex_count_;
  rig.joints = JointRows::Zero(nv, 4);
  rig.joint_weights = WeightRows::Zero(nv, 4);
  int root = 0;
  while (root + 1 < static_cast<int>(rig.skeleton.parent.size()) &&
         rig.skeleton.parent[static_cast<std::size_t>(root)] >= 0)
    ++root;
  for (const auto& d : parts_) {
    if (!d.part.owner) continue;
    const Eigen::Index first = d.part.first_vertex, n = d.part.vertex_count;
    if (d.part.skinned) {
      rig.joints.middleRows(first, n) = d.joints;
      rig.joint_weights.middleRows(first, n) = d.weights;
      continue;
    }
    int node = d.part.node, joint = -1;
    while (node >= 0 && joint < 0) {
      const auto it = joint_index_.find(node);
      joint = it == joint_index_.end() ? -1 : it->second;
      node = g_.parent[static_cast<std::size_t>(node)];
    }
    rig.joints.middleRows(first, n).col(0).setConstant(joint >= 0 ? joint : root);
    rig.joint_weights.middleRows(first, n).col(0).setOnes();
  }
}

}  // namespace

AvatarView make_view(const AvatarDocument& doc, const ViewOptions& options) {
  return ViewBuilder(doc, options).build();
}

}  // namespace facecast::rig
