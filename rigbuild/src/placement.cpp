// Placing the target's components: which vertices stay, which move rigidly with a template part,
// which float, which ride on the skin. See docs/algorithms.md#rigid-parts.
#include <algorithm>
#include <map>
#include <optional>

#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {

std::vector<int> Placement::prescribed() const {
  std::vector<int> out;
  for (std::size_t v = 0; v < role.size(); ++v)
    if (role[v] == Role::kFixed || role[v] == Role::kRigid || role[v] == Role::kAnchor)
      out.push_back(static_cast<int>(v));
  return out;
}

int Placement::fixed_count() const {
  return static_cast<int>(std::count(role.begin(), role.end(), Role::kFixed));
}

namespace {

const char* placement_name(PlacedPart::Kind kind) {
  switch (kind) {
    case PlacedPart::Kind::kRigid:
      return "rigid";
    case PlacedPart::Kind::kAttached:
      return "attached";
    case PlacedPart::Kind::kFloating:
      break;
  }
  return "floating";
}

// What a placed part needs from the rest of the build.
struct PartContext {
  const Points& rest;
  const Triangles& faces;
  const MeshParts& parts;
  const Correspondence& c;
  const TemplateShapes& source;
  double rigid_tolerance;
  const RigidParts* rigid;                         // another topology: the template's rigid parts
  const SurfaceQuery* skin;                        // another topology: the skin's surface
  double median_edge = 0;                          // another topology: of the target
  const std::vector<TemplateEye>* eyes = nullptr;  // another topology: the template's eyeballs
};

// A separate eyeball mesh of another topology (docs/algorithms.md#eyes): a component that is a
// ball where a template eyeball is (the aligned centres closer than the larger radius, the radii
// within a factor 2) turns with that eyeball's motion about its own centre. nullopt: not an eye.
std::optional<PlacedPart> place_eye(const PartContext& x, int component) {
  const auto& mem = x.parts.members[static_cast<std::size_t>(component)];
  Points at(static_cast<Eigen::Index>(mem.size()), 3);
  for (std::size_t i = 0; i < mem.size(); ++i)
    at.row(static_cast<Eigen::Index>(i)) = x.rest.row(mem[i]);
  const std::optional<Sphere> found = ball(at);
  if (!found) return std::nullopt;
  const Sphere& s = *found;
  const TemplateEye* best = nullptr;
  double nearest = std::numeric_limits<double>::max();
  for (const TemplateEye& eye : *x.eyes) {
    const double r = x.c.alignment.scale * eye.sphere.radius;
    const double d = (x.c.alignment.apply(eye.sphere.centre) - s.centre).norm();
    if (d > std::max(r, s.radius) || s.radius > 2 * r || 2 * s.radius < r || d >= nearest) continue;
    best = &eye;
    nearest = d;
  }
  if (!best) return std::nullopt;
  PlacedPart part;
  part.kind = PlacedPart::Kind::kRigid;
  part.component = component;
  part.anchor = mem[0];
  part.pivot = s.centre;
  part.src_pivot = best->sphere.centre;
  part.motion = best->motion;
  return part;
}

// The template's rigid part that most of the members map onto, when at least a third of them
// map onto one: another topology's teeth sit partly on the template's gums and lips, so the points
// they map to do not move rigidly.
const std::vector<Similarity>* landed_part(const PartContext& x, const std::vector<int>& mem) {
  std::map<int, int> votes;
  for (int v : mem) {
    const SurfacePoint& sp = x.c.vertex_map[static_cast<std::size_t>(v)];
    Eigen::Index heaviest = 0;
    sp.w.maxCoeff(&heaviest);
    if (const int p = x.rigid->of_vertex[static_cast<std::size_t>(sp.v[heaviest])]; p >= 0)
      ++votes[p];
  }
  int landed = 0;
  auto best_part = votes.end();
  for (auto it = votes.begin(); it != votes.end(); ++it) {
    landed += it->second;
    if (best_part == votes.end() || it->second > best_part->second) best_part = it;
  }
  if (3 * landed < static_cast<int>(mem.size())) return nullptr;
  return &x.rigid->motion[static_cast<std::size_t>(best_part->first)];
}

// Another topology's thin parts that lie on the skin (eyelashes on the lids: most of their
// vertices within a median edge of it) are carried by it, each vertex with its closest skin
// triangle as it sat on it in the neutral; transferred on their own through the template's lashes
// and lids they leave the lids. Empty when the part does not lie on the skin.
std::vector<std::array<int, 3>> carrier(const PartContext& x, const std::vector<int>& mem) {
  std::vector<std::array<int, 3>> under;
  std::size_t on_skin = 0;
  for (int v : mem) {
    const auto hit = x.skin->closest(x.rest.row(v).transpose(), Eigen::Vector3d::Zero(), 16);
    under.push_back({x.faces(hit.triangle, 0), x.faces(hit.triangle, 1), x.faces(hit.triangle, 2)});
    on_skin += hit.dist <= x.median_edge;
  }
  if (2 * on_skin < mem.size()) under.clear();
  return under;
}

// A component that no still vertex holds: the rigid fit of the template points it maps to, per
// shape, about its own pivot; rigid when every fit is within the tolerance.
PlacedPart place_part(const PartContext& x, int component) {
  const auto& mem = x.parts.members[static_cast<std::size_t>(component)];
  PlacedPart part;
  part.component = component;
  const auto n = static_cast<Eigen::Index>(mem.size());
  Points from(n, 3), tgt(n, 3), to(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    from.row(i) = x.c.vertex_map[static_cast<std::size_t>(mem[i])].on(x.source.rest);
    tgt.row(i) = x.rest.row(mem[i]);
  }
  part.src_pivot = from.colwise().mean();
  part.pivot = tgt.colwise().mean();
  const double size = std::max(diagonal(from), 1e-12);
  bool rigid = true;
  for (std::size_t k = 0; k < x.source.size(); ++k) {
    for (Eigen::Index i = 0; i < n; ++i)
      to.row(i) = x.c.vertex_map[static_cast<std::size_t>(mem[i])].on(x.source.shapes[k]);
    part.motion.push_back(procrustes(from, to, false));
    if (part.motion.back().rms > x.rigid_tolerance * size) rigid = false;
  }
  if (!rigid && x.rigid) {
    if (const auto* motion = landed_part(x, mem)) {
      rigid = true;
      part.motion = *motion;
    }
  }
  // The anchor: the member closest to the pivot.
  part.anchor = mem[0];
  double best = std::numeric_limits<double>::max();
  for (int v : mem) {
    const double d = (x.rest.row(v) - part.pivot).squaredNorm();
    if (d < best) {
      best = d;
      part.anchor = v;
    }
  }
  if (!rigid && x.skin && component != x.parts.skin) part.carrier = carrier(x, mem);
  part.kind = rigid                  ? PlacedPart::Kind::kRigid
              : part.carrier.empty() ? PlacedPart::Kind::kFloating
                                     : PlacedPart::Kind::kAttached;
  return part;
}

std::vector<int> triangles_of(const Triangles& faces, const MeshParts& parts, int component) {
  std::vector<int> out;
  for (Eigen::Index t = 0; t < faces.rows(); ++t)
    if (parts.of(faces(t, 0)) == component) out.push_back(static_cast<int>(t));
  return out;
}

}  // namespace

Placement place_components(const rig::Rig& tmpl, const TargetMesh& mesh,
                           const std::optional<TemplateParts>& template_parts,
                           const Correspondence& c, const TemplateShapes& source,
                           const Moved& moved, const BuildOptions& options) {
  const bool same_topology = !template_parts.has_value();
  const MeshParts& parts = mesh.parts;
  const auto nv = static_cast<std::size_t>(mesh.rest.rows());
  Placement p;
  p.parts_move_whole = !same_topology;
  p.role.assign(nv, Role::kFree);
  p.part.assign(nv, -1);
  for (std::size_t v = 0; v < nv; ++v) {
    const bool ever = std::any_of(moved.begin(), moved.end(), [&](auto& m) { return m[v]; });
    if (!ever || parts.of(static_cast<int>(v)) < 0) p.role[v] = Role::kFixed;
  }
  for (int v : options.fixed) p.role[static_cast<std::size_t>(v)] = Role::kFixed;

  std::optional<RigidParts> rigid;
  std::optional<SurfaceQuery> skin;
  std::optional<std::vector<TemplateEye>> eyes;
  PartContext x{mesh.rest, mesh.faces, parts, c, source, options.rigid_tolerance, nullptr, nullptr};
  if (!same_topology) {
    x.median_edge = mesh.graph.median_edge_length();
    x.rigid = &rigid.emplace(rigid_parts(tmpl, *template_parts, source, options.rigid_tolerance));
    x.skin = &skin.emplace(mesh.rest, mesh.faces, triangles_of(mesh.faces, parts, parts.skin));
    x.eyes = &eyes.emplace(template_eyes(tmpl, source, *rigid, options.eye_look));
  }
  const auto fixed = [&](int v) { return p.role[static_cast<std::size_t>(v)] == Role::kFixed; };
  p.components.resize(parts.members.size());
  for (std::size_t comp = 0; comp < parts.members.size(); ++comp) {
    const auto& mem = parts.members[comp];
    auto& info = p.components[comp];
    info.vertices = static_cast<int>(mem.size());
    // Same topology: a component with still vertices is held by them. Another topology maps the
    // small parts (teeth, eyes, lashes) less exactly, and a few still vertices would tear them:
    // only the skin is held that way; the others are placed unless all of them are still.
    std::optional<PlacedPart> eye;
    if (x.eyes && static_cast<int>(comp) != parts.skin) eye = place_eye(x, static_cast<int>(comp));
    const bool any_still = std::any_of(mem.begin(), mem.end(), fixed);
    const bool all_still = std::all_of(mem.begin(), mem.end(), fixed);
    if (!eye &&
        (all_still || (any_still && (same_topology || static_cast<int>(comp) == parts.skin)))) {
      info.placement = all_still ? "fixed" : "anchored";
      continue;
    }
    PlacedPart part = eye ? std::move(*eye) : place_part(x, static_cast<int>(comp));
    info.placement = eye ? "eye" : placement_name(part.kind);
    const bool whole = part.kind == PlacedPart::Kind::kRigid;
    for (int v : mem) {
      p.role[static_cast<std::size_t>(v)] = whole ? Role::kRigid : Role::kFloating;
      p.part[static_cast<std::size_t>(v)] = static_cast<int>(p.parts.size());
    }
    if (!whole) p.role[static_cast<std::size_t>(part.anchor)] = Role::kAnchor;
    p.parts.push_back(std::move(part));
  }
  return p;
}

void carry_attached(const Placement& placement, const MeshParts& parts, const Points& rest,
                    std::vector<Points>& solved) {
  for (const auto& part : placement.parts) {
    if (part.kind != PlacedPart::Kind::kAttached) continue;
    const auto& mem = parts.members[static_cast<std::size_t>(part.component)];
    parallel_for(solved.size(), [&](std::size_t k) {
      for (std::size_t i = 0; i < mem.size(); ++i)
        solved[k].row(mem[i]) = carried(rest, solved[k], rest.row(mem[i]), part.carrier[i]);
    });
  }
}

}  // namespace facecast::rigbuild
