// The automatic camera: which vertices are the face, and a look-at camera in front of them
// (docs/algorithms.md#rendering).
#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

#include "facecast/render/renderer.hpp"

namespace facecast::render {
namespace {

struct Box {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = Eigen::Vector3f::Constant(-1e30f);
  void add(const Eigen::Vector3f& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool empty() const { return lo.x() > hi.x(); }
  Eigen::Vector3f size() const { return hi - lo; }
  Eigen::Vector3f centre() const { return 0.5f * (lo + hi); }
};

// The vertices of the head: see frame_avatar.
std::vector<char> head_vertices(const rig::Rig& rig) {
  const int nv = rig.vertex_count();
  std::vector<char> moved(static_cast<std::size_t>(nv), 0), head = moved;
  for (const auto& s : rig.shapes)
    for (int v : s.vertices) moved[static_cast<std::size_t>(v)] = 1;
  const auto comps = rig::connected_components(nv, rig.triangles);
  std::vector<int> moved_in(static_cast<std::size_t>(std::max(comps.count, 0)), 0);
  for (int v = 0; v < nv; ++v)
    if (moved[static_cast<std::size_t>(v)] && comps.label[static_cast<std::size_t>(v)] >= 0)
      ++moved_in[static_cast<std::size_t>(comps.label[static_cast<std::size_t>(v)])];
  const auto best = std::max_element(moved_in.begin(), moved_in.end());
  if (best != moved_in.end() && *best > 0) {
    // The face: that component and those welded to it, sharing a vertex position (a face split
    // at its primitives' seams, skin and lips, as tools that index each primitive on its own
    // write it); not the teeth or eyes inside it.
    const auto label = [&](int v) { return comps.label[static_cast<std::size_t>(v)]; };
    std::vector<char> face(moved_in.size(), 0);
    face[static_cast<std::size_t>(best - moved_in.begin())] = 1;
    const auto key = [&](int v) {
      const Eigen::RowVector3f p = rig.positions.row(v);
      return std::tuple{p.x(), p.y(), p.z()};
    };
    for (bool grew = true; grew;) {
      grew = false;
      std::set<std::tuple<float, float, float>> at;
      for (int v = 0; v < nv; ++v)
        if (label(v) >= 0 && face[static_cast<std::size_t>(label(v))]) at.insert(key(v));
      for (int v = 0; v < nv; ++v) {
        const int c = label(v);
        if (c < 0 || face[static_cast<std::size_t>(c)] ||
            moved_in[static_cast<std::size_t>(c)] == 0 || !at.count(key(v)))
          continue;
        face[static_cast<std::size_t>(c)] = 1;
        grew = true;
      }
    }
    const auto on_face = [&](int v) {
      return label(v) >= 0 && face[static_cast<std::size_t>(label(v))];
    };
    Box all, shapes;
    for (int v = 0; v < nv; ++v) {
      if (!on_face(v)) continue;
      all.add(rig.positions.row(v).transpose());
      if (moved[static_cast<std::size_t>(v)]) shapes.add(rig.positions.row(v).transpose());
    }
    // A whole body with the face's shapes on it: keep the region around what the shapes move.
    const bool body = all.size().y() > 2.5f * shapes.size().y();
    const Eigen::Vector3f c = shapes.centre(), half = 0.75f * shapes.size();
    for (int v = 0; v < nv; ++v) {
      if (!on_face(v)) continue;
      const Eigen::Vector3f p = rig.positions.row(v).transpose();
      head[static_cast<std::size_t>(v)] =
          !body || ((p - c).cwiseAbs().array() <= half.array()).head<2>().all();
    }
    return head;
  }
  const rig::Skeleton& sk = rig.skeleton;
  if (sk.head >= 0 && rig.joints.rows() == nv) {
    bool any = false;
    for (int v = 0; v < nv; ++v) {
      float w = 0;
      for (int k = 0; k < 4; ++k) {
        int j = rig.joints(v, k);
        while (j >= 0 && j != sk.head) j = sk.parent[static_cast<std::size_t>(j)];
        if (j == sk.head) w += rig.joint_weights(v, k);
      }
      any |= (head[static_cast<std::size_t>(v)] = w >= 0.5f) != 0;
    }
    if (any) return head;
  }
  for (int v = 0; v < nv; ++v)
    head[static_cast<std::size_t>(v)] = comps.label[static_cast<std::size_t>(v)] == comps.largest;
  return head;
}

}  // namespace

Camera frame_avatar(const rig::Rig& rig, float aspect, const RenderOptions& options) {
  const std::vector<char> head = head_vertices(rig);
  Box whole, all_head;
  for (int v = 0; v < rig.vertex_count(); ++v) {
    const Eigen::Vector3f p = rig.positions.row(v).transpose();
    whole.add(p);
    if (head[static_cast<std::size_t>(v)]) all_head.add(p);
  }
  // The front half of the head.
  Box front;
  const float mid_z = all_head.centre().z();
  for (int v = 0; v < rig.vertex_count(); ++v)
    if (head[static_cast<std::size_t>(v)] && rig.positions(v, 2) >= mid_z)
      front.add(rig.positions.row(v).transpose());
  Box framed = front.empty() ? whole : front;
  if (options.framing == Framing::kBust) {
    const Eigen::Vector3f s = framed.size(), c = framed.centre();
    framed.add({c.x() - 1.4f * s.x(), framed.lo.y() - 1.2f * s.y(), c.z()});
    framed.add({c.x() + 1.4f * s.x(), framed.lo.y(), c.z()});
  } else if (options.framing == Framing::kFull) {
    framed = whole;
  }
  Camera c;
  c.fov_y_deg = options.fov_y_deg;
  const Eigen::Vector3f centre = framed.centre();
  const float t = std::tan(0.5f * options.fov_y_deg * 3.14159265f / 180.0f);
  const float h = framed.size().y() * options.margin, w = framed.size().x() * options.margin;
  const float dist = std::max(0.5f * h / t, 0.5f * w / (t * aspect));
  c.target = centre;
  c.eye = Eigen::Vector3f(centre.x(), centre.y(), framed.hi.z() + dist);
  c.near_plane = std::max(0.01f, 0.2f * dist);
  // Past the farthest vertex with room to spare (a flat mesh's lies exactly at eye - dist).
  c.far_plane = framed.hi.z() + dist - whole.lo.z() + whole.size().z() + 0.05f * dist;
  return c;
}

}  // namespace facecast::render
