// The template's motion: its shapes and gradients, which target vertices they move, and the
// motion copied onto the target vertex by vertex. See docs/algorithms.md#deformation-transfer.
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>

#include "facecast/core/error.hpp"
#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {

TemplateShapes template_shapes(const rig::Rig& tmpl, const std::atomic<bool>* abandon) {
  const auto t0 = std::chrono::steady_clock::now();
  TemplateShapes s;
  s.rest = rig::to_points(tmpl.positions);
  s.faces = tmpl.triangles;
  const auto rest_inv = rest_frames_inverse(s.rest, s.faces, "template");
  s.shapes.resize(tmpl.shapes.size());
  s.gradients.resize(tmpl.shapes.size());
  parallel_for(tmpl.shapes.size(), [&](std::size_t k) {  // independent: all cores
    if (abandon && *abandon) return;
    s.shapes[k] = s.rest;
    const auto& shape = tmpl.shapes[k];
    for (std::size_t i = 0; i < shape.vertices.size(); ++i) {
      s.shapes[k].row(shape.vertices[i]) +=
          shape.deltas.row(static_cast<Eigen::Index>(i)).cast<double>();
    }
    source_gradients(rest_inv, s.shapes[k], s.faces, s.gradients[k]);
  });
  if (abandon && *abandon) throw Error("template shapes: abandoned");
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
  // Each virtual edge follows the copy's change of its gap (edge_vectors below).
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

namespace {

// The template's gap at a virtual edge (the vector between the points its ends map to) in the
// target's frame and units, in the neutral (`at` = source.rest) or a shape.
Eigen::RowVector3d template_gap(const Correspondence& c, const VirtualEdge& ve, const Points& at) {
  return c.alignment.scale *
         (c.vertex_map[static_cast<std::size_t>(ve.a)].on(at) -
          c.vertex_map[static_cast<std::size_t>(ve.b)].on(at)) *
         c.alignment.R.transpose();
}

}  // namespace

std::vector<Points> edge_vectors(const Points& rest, const Correspondence& c,
                                 const TemplateShapes& source, const std::vector<Points>& copied,
                                 const std::vector<VirtualEdge>& edges, double gap_scale_limit) {
  // docs/algorithms.md#gap-scaling. The copy changes the target gap e by the template's change
  // d = r' - r (r: the template gap between the points the ends map to). A translation across a
  // gap (jawForward at a thin mouth corner) keeps its size, but a closing gap (a blink) closes by
  // the template's length: too far across a narrower eye, not far enough across a wider one. So
  // as far as the template gap closes, the change is taken relative to the gap: turned from r's
  // direction onto e's (q) and scaled by s = |e| / |r| (clamped to [1 / limit, limit]),
  //   e' = e + (1 - closed) d + closed s q d,   closed = clamp(1 - |r'| / |r|, 0, 1),
  // so a template gap that closes entirely gives e' = s q r'. A gap that opens or passes through
  // itself (|r'| >= |r|), or whose direction differs from e's by more than 60 degrees, keeps d.
  std::vector<Points> out(edges.empty() ? 0 : copied.size());
  const double tiny = 1e-9 * diagonal(rest);
  std::vector<Eigen::RowVector3d> gap(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) gap[i] = template_gap(c, edges[i], source.rest);
  parallel_for(out.size(), [&](std::size_t k) {
    out[k].resize(static_cast<Eigen::Index>(edges.size()), 3);
    for (std::size_t i = 0; i < edges.size(); ++i) {
      const VirtualEdge& ve = edges[i];
      const Eigen::RowVector3d e = rest.row(ve.a) - rest.row(ve.b);
      const Eigen::RowVector3d change = copied[k].row(ve.a) - copied[k].row(ve.b) - e;
      const Eigen::RowVector3d& r = gap[i];
      Eigen::RowVector3d want = e + change;
      // Gaps that do not correspond (more than 60 degrees apart, or a point) keep the copy.
      if (gap_scale_limit > 1 && r.norm() > tiny && e.norm() > tiny &&
          e.normalized().dot(r.normalized()) > 0.5) {
        const double s = std::clamp(e.norm() / r.norm(), 1 / gap_scale_limit, gap_scale_limit);
        const double closed =
            std::clamp(1 - template_gap(c, ve, source.shapes[k]).norm() / r.norm(), 0.0, 1.0);
        const Eigen::Quaterniond q =
            Eigen::Quaterniond::FromTwoVectors(r.transpose(), e.transpose());
        want = e + (1 - closed) * change + closed * s * (q * change.transpose()).transpose();
      }
      out[k].row(static_cast<Eigen::Index>(i)) = want;
    }
  });
  return out;
}

}  // namespace facecast::rigbuild
