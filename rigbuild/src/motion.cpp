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

}  // namespace

std::vector<Points> copy_motion(const Points& rest, const Correspondence& c,
                                const TemplateShapes& source, const Placement& placement) {
  // Each virtual edge follows the copy: the target gap e changes as the template gap r does,
  // e' = e + (r' - r) = copy_a - copy_b (docs/algorithms.md#virtual-edges); the change is not
  // scaled by |e| / |r|, which breaks translations such as jawForward at thin mouth corners.
  const std::vector<int> prescribed = placement.prescribed();
  std::vector<Points> copied(source.size(), rest);
  parallel_for(source.size(), [&](std::size_t k) {
    for (Eigen::Index v = 0; v < rest.rows(); ++v) {
      const SurfacePoint& sp = c.vertex_map[static_cast<std::size_t>(v)];
      copied[k].row(v) += c.alignment.scale * (sp.on(source.shapes[k]) - sp.on(source.rest)) *
                          c.alignment.R.transpose();
    }
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
