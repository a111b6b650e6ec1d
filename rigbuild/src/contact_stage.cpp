// The contact stages of build_rig: the reference, then contact rounds on the solved shapes. See
// docs/algorithms.md#contacts.
#include <tuple>

#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {
namespace {

// Vertices moved rigidly with their part: the guard watches the skin against them.
std::vector<char> rigid_vertices(const Placement& placement) {
  std::vector<char> out(placement.role.size(), 0);
  for (std::size_t v = 0; v < out.size(); ++v) out[v] = placement.role[v] == Role::kRigid;
  return out;
}

// The members of the placed parts of one kind: floating ones (transferred as a whole: a tongue),
// which the guard watches against the other parts, or attached ones (lashes), which ride on the
// skin after the contacts and are lifted off it.
std::vector<char> vertices_of(const Placement& placement, PlacedPart::Kind kind) {
  std::vector<char> out(placement.role.size(), 0);
  for (std::size_t v = 0; v < out.size(); ++v) {
    const int part = placement.part[v];
    out[v] = part >= 0 && placement.parts[static_cast<std::size_t>(part)].kind == kind;
  }
  return out;
}

}  // namespace

ContactStage::ContactStage(const rig::Rig& tmpl, const TemplateShapes& source,
                           const TriangleMap& map, const TargetMesh& target,
                           const Placement& placement, const ContactOptions& options)
    : guard_(target, rigid_vertices(placement), options.margin, options.part_margin,
             vertices_of(placement, PlacedPart::Kind::kFloating),
             vertices_of(placement, PlacedPart::Kind::kAttached)),
      template_(tmpl, map, source.shapes),
      placement_(placement),
      options_(options) {}

std::vector<Points> ContactStage::reference(const std::vector<Points>& copied, const Moved& moved,
                                            std::vector<ShapeQuality>& quality) {
  // Where the copy crosses a rigidly moved part or itself and the template does not (a target's
  // fuller lips and lids closed as far as the template's; lips that lie on the teeth; a mouth
  // corner that the correspondence splits between the lips). The virtual edges keep the copy:
  // they close the lids, the contacts keep them from crossing.
  std::vector<Points> reference = copied;
  parallel_for(copied.size(), [&](std::size_t k) {
    const auto template_crosses = template_.of_shape(k);
    std::tie(quality[k].part_crossings, quality[k].part_crossings_left) =
        guard_.clear_parts(reference[k], moved[k], template_crosses);
    std::tie(quality[k].copy_crossings, quality[k].copy_crossings_left) =
        guard_.untangle(reference[k], moved[k], template_crosses);
  });
  return reference;
}

void ContactStage::hold(const Transfer& transfer, const std::vector<Points>& reference,
                        const Moved& moved, std::vector<Points>& solved,
                        std::vector<ShapeQuality>& quality) {
  parallel_for(solved.size(), [&](std::size_t k) {
    const Points& ref = reference[k];
    const auto template_crosses = template_.of_shape(k);
    auto crossing = guard_.new_crossings(solved[k], ref, moved[k], template_crosses);
    ShapeQuality& q = quality[k];
    q.crossings = static_cast<int>(crossing.size());
    if (crossing.empty()) return;
    std::vector<char> held(static_cast<std::size_t>(solved[k].rows()));
    for (std::size_t v = 0; v < held.size(); ++v)
      held[v] = placement_.stays(moved[k], static_cast<int>(v));
    const Points transferred = solved[k];
    GuardContacts contacts;
    double weight = options_.weight;
    for (int round = 0; round < options_.rounds && !crossing.empty(); ++round) {
      guard_.add_contacts(crossing, ref, contacts);
      solved[k] = transfer.solve_with_contacts(transferred, held, contacts.contacts,
                                               guard_.targets(contacts, ref, transferred), weight);
      crossing = guard_.new_crossings(solved[k], ref, moved[k], template_crosses);
      weight *= 10;
    }
    q.crossings_left = static_cast<int>(crossing.size());
    q.contacts = static_cast<int>(contacts.contacts.size());
  });
}

void ContactStage::lift_attached(std::vector<Points>& solved,
                                 std::vector<ShapeQuality>& quality) const {
  parallel_for(solved.size(), [&](std::size_t k) {
    std::tie(quality[k].attached_crossings, quality[k].attached_crossings_left) =
        guard_.lift_attached(solved[k]);
  });
}

}  // namespace facecast::rigbuild
