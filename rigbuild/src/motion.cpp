// The template's motion: its shapes and gradients, which target vertices they move, and the
// motion copied onto the target vertex by vertex. See docs/algorithms.md#deformation-transfer.
#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {

TemplateShapes template_shapes(const anim::Rig& tmpl) {
  TemplateShapes s;
  s.rest = tmpl.positions.cast<double>();
  s.faces = tmpl.triangles;
  const auto rest_inv = rest_frames_inverse(s.rest, s.faces, "template");
  s.shapes.resize(tmpl.shapes.size());
  s.gradients.resize(tmpl.shapes.size());
  parallel_for(tmpl.shapes.size(), [&](std::size_t k) {  // independent: all cores
    s.shapes[k] = s.rest;
    const auto& shape = tmpl.shapes[k];
    for (std::size_t i = 0; i < shape.vertices.size(); ++i) {
      s.shapes[k].row(shape.vertices[i]) +=
          shape.deltas.row(static_cast<Eigen::Index>(i)).cast<double>();
    }
    source_gradients(rest_inv, s.shapes[k], s.faces, s.gradients[k]);
  });
  return s;
}

Moved classify_motion(const Correspondence& c, const TemplateShapes& source,
                      double still_tolerance) {
  const double still = still_tolerance * diagonal(source.rest);
  const std::size_t nv = c.vertex_map.size();
  Moved moved(source.size(), std::vector<char>(nv, 0));
  parallel_for(source.size(), [&](std::size_t k) {
    for (std::size_t v = 0; v < nv; ++v) {
      const SurfacePoint& sp = c.vertex_map[v];
      moved[k][v] = (sp.on(source.shapes[k]) - sp.on(source.rest)).norm() >= still;
    }
  });
  return moved;
}

namespace {

// Where placed vertex v goes in shape k: the neutral position for a fixed vertex; for a rigid or
// anchor vertex, its part's rigid motion about the part's own pivot (in the target's frame and
// units: the correspondence's similarity).
Eigen::RowVector3d placed_at(const Points& rest, const Correspondence& c,
                             const Placement& placement, int v, std::size_t k) {
  const int f = placement.part[static_cast<std::size_t>(v)];
  if (placement.role[static_cast<std::size_t>(v)] == Role::kFixed || f < 0) return rest.row(v);
  const PlacedPart& part = placement.parts[static_cast<std::size_t>(f)];
  const Similarity& m = part.motion[k];
  const Eigen::Matrix3d& R = c.alignment.R;
  const Eigen::Matrix3d turn = R * m.R * R.transpose();
  const Eigen::RowVector3d pivot_shift =
      (m.R * part.src_pivot.transpose() + m.t).transpose() - part.src_pivot;
  return (rest.row(v) - part.pivot) * turn.transpose() + part.pivot +
         c.alignment.scale * pivot_shift * R.transpose();
}

// The members of each floating part (docs/algorithms.md#rigid-parts), anchors included.
std::vector<std::vector<int>> floating_members(const Placement& placement) {
  std::vector<std::vector<int>> out(placement.parts.size());
  for (std::size_t v = 0; v < placement.part.size(); ++v) {
    const int f = placement.part[v];
    if (f >= 0 && placement.parts[static_cast<std::size_t>(f)].kind == PlacedPart::Kind::kFloating)
      out[static_cast<std::size_t>(f)].push_back(static_cast<int>(v));
  }
  return out;
}

// A floating part of another topology moves as a whole: the members whose mapped points shape k
// leaves still while it moves others take the copied displacement of their nearest moving member
// (in the neutral). A lid modelled as a shell maps its front onto the template's lid and its back
// onto still template points (the eyeball, or nothing like it); copied apart, the front layer
// passes through the back, and the contacts then hold the lid open
// (docs/algorithms.md#torn-layers). Where the motion fades out, the nearest moving member barely
// moves, so still edges stay still.
void follow_moving_members(const std::vector<int>& members, const std::vector<char>& moved,
                           const Points& rest, Points& copied) {
  std::vector<int> moving;
  for (int v : members)
    if (moved[static_cast<std::size_t>(v)]) moving.push_back(v);
  if (moving.empty() || moving.size() == members.size()) return;
  Points at(static_cast<Eigen::Index>(moving.size()), 3);
  for (std::size_t i = 0; i < moving.size(); ++i)
    at.row(static_cast<Eigen::Index>(i)) = rest.row(moving[i]);
  const PointIndex index(std::move(at));
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (int v : members) {
    if (moved[static_cast<std::size_t>(v)]) continue;
    index.nearest(rest.row(v).data(), 1, idx, d2);
    const int u = moving[idx[0]];
    copied.row(v) = rest.row(v) + copied.row(u) - rest.row(u);
  }
}

}  // namespace

std::vector<Points> copy_motion(const Points& rest, const Correspondence& c,
                                const TemplateShapes& source, const Placement& placement,
                                const Moved& moved) {
  // Each virtual edge follows the copy: the target gap e changes as the template gap r does,
  // e' = e + (r' - r) = copy_a - copy_b (docs/algorithms.md#virtual-edges); the change is not
  // scaled by |e| / |r|, which breaks translations such as jawForward at thin mouth corners.
  const std::vector<int> prescribed = placement.prescribed();
  const std::vector<std::vector<int>> floating =
      placement.parts_move_whole ? floating_members(placement) : std::vector<std::vector<int>>{};
  std::vector<Points> copied(source.size(), rest);
  parallel_for(source.size(), [&](std::size_t k) {
    for (Eigen::Index v = 0; v < rest.rows(); ++v) {
      const SurfacePoint& sp = c.vertex_map[static_cast<std::size_t>(v)];
      copied[k].row(v) += c.alignment.scale * (sp.on(source.shapes[k]) - sp.on(source.rest)) *
                          c.alignment.R.transpose();
    }
    for (const auto& members : floating) follow_moving_members(members, moved[k], rest, copied[k]);
    // Placed vertices have their places; the copy takes them too, so the edges and contacts at
    // them measure from where they are.
    for (const int v : prescribed) copied[k].row(v) = placed_at(rest, c, placement, v, k);
  });
  return copied;
}

std::vector<Points> edge_vectors(const std::vector<Points>& copied,
                                 const std::vector<VirtualEdge>& edges) {
  std::vector<Points> out(edges.empty() ? 0 : copied.size());
  parallel_for(out.size(), [&](std::size_t k) {
    out[k].resize(static_cast<Eigen::Index>(edges.size()), 3);
    for (std::size_t i = 0; i < edges.size(); ++i)
      out[k].row(static_cast<Eigen::Index>(i)) =
          copied[k].row(edges[i].a) - copied[k].row(edges[i].b);
  });
  return out;
}

}  // namespace facecast::rigbuild
