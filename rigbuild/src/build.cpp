// build_rig: the stages of stages.hpp in order. See docs/algorithms.md#deformation-transfer.
#include "facecast/rigbuild/build.hpp"

#include <chrono>
#include <future>
#include <optional>
#include <vector>

#include "facecast/core/error.hpp"
#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {
namespace {

using Clock = std::chrono::steady_clock;

// Seconds that `work` takes.
template <typename Work>
double seconds_of(Work&& work) {
  const auto t0 = Clock::now();
  work();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Reports the stage to `progress`, runs it and adds its time to `seconds`.
template <typename Stage>
auto timed(const ProgressFn& progress, const char* name, double& seconds, Stage&& stage) {
  report(progress, name, 0.0);
  const auto t0 = Clock::now();
  auto out = stage();
  seconds += std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

void check_inputs(const rig::Rig& tmpl, const rig::Rig& target, const BuildOptions& options) {
  tmpl.validate("template");
  target.validate("target");
  if (tmpl.shapes.empty()) throw Error("template: rig has no blendshapes");
  if (options.lambda < 0) throw Error("--lambda must not be negative");
  const int nv = target.vertex_count();
  for (int v : options.fixed) {
    if (v < 0 || v >= nv) {
      throw Error("--fixed: vertex " + std::to_string(v) + " out of range (" + std::to_string(nv) +
                  " vertices)");
    }
  }
  if (!options.markers.empty()) check_markers(options.markers, tmpl.vertex_count(), nv);
  if (options.virtual_edges == VirtualEdgeMode::kFile) {
    for (const auto& e : options.given_edges)
      if (e.a < 0 || e.b < 0 || e.a >= nv || e.b >= nv || e.a == e.b)
        throw Error("virtual edges: edge " + std::to_string(e.a) + "-" + std::to_string(e.b) +
                    " out of range (" + std::to_string(nv) + " vertices)");
  }
  if (const auto& c = options.correspondence;
      c && (c->template_vertices != tmpl.vertex_count() ||
            c->template_triangles != tmpl.triangle_count() || c->target_vertices != nv ||
            c->target_triangles != target.triangle_count() ||
            c->vertex_map.size() != static_cast<std::size_t>(nv) ||
            c->map.sources.size() != static_cast<std::size_t>(target.triangle_count())))
    throw Error("correspondence: made for other meshes");
}

}  // namespace

Correspondence correspond(const rig::Rig& tmpl, const rig::Rig& target,
                          const MeshParts& target_parts, const BuildOptions& options,
                          std::optional<AutoMarkers>& found,
                          std::optional<TemplateParts>& template_parts,
                          const ProgressFn& progress) {
  const std::vector<MarkerPair>* markers = &options.markers;
  if (options.markers.empty()) {
    if (auto same = same_topology_correspondence(tmpl.vertex_count(), tmpl.triangles,
                                                 target.vertex_count(), target.triangles))
      return std::move(*same);
    if (!options.auto_landmarks)
      throw Error("target: topology differs from the template (" +
                  std::to_string(target.vertex_count()) + " vs " +
                  std::to_string(tmpl.vertex_count()) + " vertices); give --markers");
    // Another topology without markers: automatic landmarks (docs/algorithms.md#landmarks).
    report(progress, "landmarks", 0.0);
    const auto t0 = Clock::now();
    found = auto_markers(tmpl, target, target_parts.components, options.landmarks);
    found->seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    markers = &found->markers;
  }
  const TemplateParts& parts = template_parts.emplace(tmpl);
  if (options.correspondence) return *options.correspondence;
  // The middles of the lids, where the landmarks leave the registration free
  // (docs/algorithms.md#landmarks, step 7).
  std::vector<MarkerPair> refined;
  MarkerRefinement lid_middles;
  if (options.landmarks.lid_margins)
    lid_middles = [&](const Points& registered) {
      return refined =
                 with_lid_middles(tmpl, target, target_parts.components, registered, *markers);
    };
  Correspondence c = compute_correspondence(
      rig::to_points(tmpl.positions), tmpl.triangles, parts.mesh.components, parts.of_triangle,
      rig::to_points(target.positions), target.triangles, target_parts.components, *markers,
      options.registration, progress, lid_middles);
  if (found && !refined.empty()) found->markers = std::move(refined);
  return c;
}

// The correspondence (into r, with the landmarks when they were found; into `template_parts`
// the template's where the topologies differ), while `source`, the template's shapes and
// gradients, which need none, are made on another thread (the landmarks and the registration's
// factorizations leave a core idle much of the time).
TemplateShapes correspond_and_differentiate(const rig::Rig& tmpl,
                                            std::future<TemplateShapes> source,
                                            const rig::Rig& target, const MeshParts& target_parts,
                                            const BuildOptions& options, const ProgressFn& progress,
                                            std::optional<TemplateParts>& template_parts,
                                            BuildResult& r) {
  auto& time = r.timings;
  r.correspondence = timed(progress, "correspondence", time.correspondence, [&] {
    return correspond(tmpl, target, target_parts, options, r.landmarks, template_parts, progress);
  });
  time.landmarks = r.landmarks ? r.landmarks->seconds : 0.0;
  time.registration = r.correspondence.registration_seconds;
  report(progress, "gradients", 0.0);
  TemplateShapes shapes = source.get();
  time.gradients = shapes.seconds;
  return shapes;
}

namespace {

// What every shape's solve starts from: the target's rest positions, the template's motion copied
// onto it, and the virtual edges' target vectors.
struct SolveInputs {
  const Points& rest;
  const std::vector<Points>& copied;
  const std::vector<Points>& edge_targets;
};

// The solve, then the contacts and the attached parts. The contacts' reference needs no solved
// shape: it is made on another thread while the solve, mostly CHOLMOD's back-substitutions on one
// core, runs on this one (under a budget with no thread to lend, after the solve on this one).
std::vector<Points> solve_and_hold(const rig::Rig& tmpl, const TemplateShapes& source,
                                   const TargetMesh& mesh, const Placement& placement,
                                   const Moved& moved, const Transfer& transfer,
                                   const SolveInputs& in, const BuildOptions& options,
                                   const ProgressFn& progress, BuildResult& r) {
  auto& time = r.timings;
  std::optional<ContactStage> contacts;
  std::vector<Points> reference;
  std::future<void> contacts_ready;
  if (options.contacts.enabled)
    contacts_ready = async_within_budget([&] {
      time.contacts = seconds_of([&] {
        contacts.emplace(tmpl, source, r.correspondence.map, mesh, placement, options.contacts);
        reference = contacts->reference(in.copied, moved, r.quality);
      });
    });
  std::vector<Points> solved = timed(progress, "solve", time.solve, [&] {
    return solve_shapes(transfer, in.rest, source.gradients, in.copied, in.edge_targets, placement,
                        moved, options.closing_rounds, progress);
  });
  if (contacts_ready.valid()) {
    report(progress, "contacts", 0.0);
    contacts_ready.get();
    r.watched_pairs = contacts->watched();
    time.contacts +=
        seconds_of([&] { contacts->hold(transfer, reference, moved, solved, r.quality); });
  }
  carry_attached(placement, mesh.parts, in.rest, solved);  // after the contacts placed the skin
  if (contacts) time.contacts += seconds_of([&] { contacts->lift_attached(solved, r.quality); });
  return solved;
}

}  // namespace

BuildResult build_rig(const rig::Rig& tmpl, const rig::Rig& target, const BuildOptions& options,
                      const ProgressFn& progress) {
  const OpenMpWithinBudget omp_threads;  // Eigen's and CHOLMOD's regions, within the budget
  check_inputs(tmpl, target, options);   // before the template's shapes are made from it
  return build_rig(tmpl, async_within_budget([&tmpl] { return template_shapes(tmpl); }), target,
                   options, progress);
}

BuildResult build_rig(const rig::Rig& tmpl, std::future<TemplateShapes> source_ready,
                      const rig::Rig& target, const BuildOptions& options,
                      const ProgressFn& progress) {
  const OpenMpWithinBudget omp_threads;
  const auto t_start = Clock::now();
  check_inputs(tmpl, target, options);
  BuildResult r;
  auto& time = r.timings;
  const Points rest = rig::to_points(target.positions);
  const TargetMesh mesh(rest, target.triangles);  // its parts and edge graph, computed once
  std::optional<TemplateParts> tmpl_parts;        // the template's, where the topologies differ
  const TemplateShapes source = correspond_and_differentiate(
      tmpl, std::move(source_ready), target, mesh.parts, options, progress, tmpl_parts, r);
  const Moved moved = classify_motion(r.correspondence, source, options.still_tolerance);
  const Placement placement =
      place_components(tmpl, mesh, tmpl_parts, r.correspondence, source, moved, options);
  r.components = placement.components;
  r.fixed_vertices = placement.fixed_count();
  r.virtual_edges = timed(progress, "virtual edges", time.detect,
                          [&] { return virtual_edges(mesh, options, r.ve_stats); });
  report(progress, "factor", 0.0);
  const Transfer transfer =
      factor(rest, mesh.faces, r.correspondence.map, r.virtual_edges, placement, options);
  time.factor = transfer.factor_seconds();
  r.factor_nonzeros = transfer.factor_nonzeros();
  const std::vector<Points> copied = copy_motion(rest, r.correspondence, source, placement, moved);
  const std::vector<Points> edge_targets = edge_vectors(rest, r.correspondence, source, copied,
                                                        r.virtual_edges, options.gap_scale_limit);
  r.quality.resize(source.size());
  const std::vector<Points> solved =
      solve_and_hold(tmpl, source, mesh, placement, moved, transfer, {rest, copied, edge_targets},
                     options, progress, r);
  r.rig = with_shapes(tmpl, target, rest, solved);
  measure_gaps(r.rig, rest, solved, r.virtual_edges, edge_targets, r.quality);
  time.total = std::chrono::duration<double>(Clock::now() - t_start).count();
  report(progress, "done", 1.0);
  return r;
}

}  // namespace facecast::rigbuild
