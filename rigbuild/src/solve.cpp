// The transfer's stages: the factor, every shape solved, the deltas and their measures. See
// docs/algorithms.md#deformation-transfer and #virtual-edges.
#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {

Transfer factor(const Points& rest, const Triangles& faces, const TriangleMap& map,
                const std::vector<VirtualEdge>& edges, const Placement& placement,
                const BuildOptions& options) {
  TransferSetup setup;
  setup.target_rest = rest;
  setup.target_faces = faces;
  setup.map = map;
  if (options.virtual_edges != VirtualEdgeMode::kOff) setup.virtual_edges = edges;
  setup.lambda = options.lambda;
  setup.dirichlet = placement.prescribed();
  setup.solver = options.solver;
  return Transfer(std::move(setup));
}

namespace {

// Closing gaps (docs/algorithms.md#closing-gaps): a virtual edge whose wanted vector is under half
// its neutral length is a gap the shape closes (a blink, closed lips). The gradients resist the
// closing, and the soft edge term leaves such a gap about a third wider than it asks (MakeHuman's
// blink: 0.22 of the lid gap where its edges ask for 0.164). So the closing edges are enforced by
// the augmented Lagrangian's multiplier update: each edge's target moves by its residual,
// t += kRelax (wanted - got), and the shapes that have such edges move by the solution of that
// change alone (back-substitutions on the same factor; the solution is linear in the targets),
// until every closing gap is within kClosed of its neutral length of what it wants, or `rounds`
// times.
constexpr double kRelax = 2.5;
constexpr double kClosed = 0.01;

void close_gaps(const Transfer& transfer, const Points& rest, const std::vector<Points>& wanted,
                int rounds, std::vector<Points>& out) {
  const std::vector<VirtualEdge>& edges = transfer.virtual_edges();
  std::vector<std::size_t> shapes;  // of this block, those with a closing edge
  std::vector<std::vector<std::size_t>> closing(wanted.size());
  for (std::size_t k = 0; k < wanted.size(); ++k) {
    for (std::size_t i = 0; i < edges.size(); ++i)
      if (wanted[k].row(static_cast<Eigen::Index>(i)).norm() <
          0.5 * (rest.row(edges[i].a) - rest.row(edges[i].b)).norm())
        closing[k].push_back(i);
    if (!closing[k].empty()) shapes.push_back(k);
  }
  for (int round = 0; round < rounds && !shapes.empty(); ++round) {
    std::vector<Points> change(shapes.size(), Points::Zero(wanted[0].rows(), 3));
    double worst = 0;
    for (std::size_t j = 0; j < shapes.size(); ++j) {
      const std::size_t k = shapes[j];
      for (std::size_t i : closing[k]) {
        const auto e = static_cast<Eigen::Index>(i);
        const Eigen::RowVector3d miss =
            wanted[k].row(e) - (out[k].row(edges[i].a) - out[k].row(edges[i].b));
        worst = std::max(worst, miss.norm() / (rest.row(edges[i].a) - rest.row(edges[i].b)).norm());
        change[j].row(e) = kRelax * miss;
      }
    }
    if (worst < kClosed) return;
    const auto moved = transfer.solve_edge_change(change);
    for (std::size_t j = 0; j < shapes.size(); ++j) out[shapes[j]] += moved[j];
  }
}

}  // namespace

std::vector<Points> solve_shapes(const Transfer& transfer, const Points& rest,
                                 const std::vector<Gradients>& gradients,
                                 const std::vector<Points>& copied,
                                 const std::vector<Points>& edge_targets,
                                 const Placement& placement, const Moved& moved, int closing_rounds,
                                 const ProgressFn& progress) {
  const std::size_t n = gradients.size();
  const std::vector<int> dirichlet = placement.prescribed();
  // In blocks, so the right-hand sides stay small; progress per block.
  std::vector<Points> solved(n);
  const std::size_t block = 20;
  for (std::size_t b = 0; b < n; b += block) {
    const std::size_t e = std::min(n, b + block);
    std::vector<const Gradients*> source;
    std::vector<Points> prescribed, edges;
    for (std::size_t k = b; k < e; ++k) {
      source.push_back(&gradients[k]);
      Points& P = prescribed.emplace_back(static_cast<Eigen::Index>(dirichlet.size()), 3);
      for (std::size_t i = 0; i < dirichlet.size(); ++i)
        P.row(static_cast<Eigen::Index>(i)) = copied[k].row(dirichlet[i]);
      if (!edge_targets.empty()) edges.push_back(edge_targets[k]);
    }
    auto out = transfer.solve(source, prescribed, edges);
    if (!edges.empty()) close_gaps(transfer, rest, edges, closing_rounds, out);
    for (std::size_t k = b; k < e; ++k) solved[k] = std::move(out[k - b]);
    report(progress, "solve", static_cast<double>(e) / static_cast<double>(n));
  }
  // Vertices the template shape leaves still stay exactly still (the contacts hold them too).
  parallel_for(n, [&](std::size_t k) {
    for (Eigen::Index v = 0; v < solved[k].rows(); ++v)
      if (placement.stays(moved[k], static_cast<int>(v))) solved[k].row(v) = rest.row(v);
  });
  return solved;
}

rig::Rig with_shapes(const rig::Rig& tmpl, const rig::Rig& target, const Points& rest,
                     const std::vector<Points>& solved) {
  rig::Rig rig = target;
  rig.shapes.clear();
  const float keep = static_cast<float>(1e-7 * diagonal(rest));
  for (std::size_t k = 0; k < solved.size(); ++k) {
    const rig::Positions d = rig::to_positions(solved[k] - rest);
    rig.shapes.push_back(rig::Blendshape::from_dense(tmpl.shapes[k].name, d, keep));
  }
  return rig;
}

void measure_gaps(const rig::Rig& built, const Points& rest, const std::vector<Points>& solved,
                  const std::vector<VirtualEdge>& edges, const std::vector<Points>& edge_targets,
                  std::vector<ShapeQuality>& quality) {
  // Each gap normalised so the neutral gap is 10 (docs/algorithms.md#virtual-edges).
  const double diag = diagonal(rest);
  const std::size_t ne = edges.size();
  for (std::size_t k = 0; k < solved.size(); ++k) {
    ShapeQuality& q = quality[k];
    q.shape = built.shapes[k].name;
    q.max_displacement = built.shapes[k].max_displacement();
    q.min_gap = ne ? std::numeric_limits<double>::max() : 0.0;
    const rig::Positions d = rig::to_positions(solved[k] - rest);
    for (std::size_t i = 0; i < ne; ++i) {
      const auto& ve = edges[i];
      const double neutral = (rest.row(ve.a) - rest.row(ve.b)).norm();
      if (neutral < 1e-9 * diag) continue;  // coincident vertices: no gap to measure
      const Eigen::RowVector3f got =
          built.positions.row(ve.a) + d.row(ve.a) - built.positions.row(ve.b) - d.row(ve.b);
      const double gap = 10.0 * got.cast<double>().norm() / neutral;
      const double wanted =
          10.0 * edge_targets[k].row(static_cast<Eigen::Index>(i)).norm() / neutral;
      q.gap_change += std::abs(gap - wanted) / static_cast<double>(ne);
      // A gap that flips direction has crossed: count it as closed.
      const double sign = got.cast<double>().dot(rest.row(ve.a) - rest.row(ve.b)) < 0 ? 0.0 : 1.0;
      q.min_gap = std::min(q.min_gap, sign * gap);
    }
  }
}

}  // namespace facecast::rigbuild
