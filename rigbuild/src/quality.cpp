#include "facecast/rigbuild/quality.hpp"

#include <algorithm>

#include "facecast/core/error.hpp"

namespace facecast::rigbuild {
namespace {
ShapeError stats(const std::string& name, std::vector<double>& err, double diag) {
  ShapeError e;
  e.shape = name;
  if (err.empty()) return e;
  double sum = 0;
  for (double x : err) sum += x;
  e.mean = sum / static_cast<double>(err.size());
  const std::size_t k =
      std::min(err.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(err.size())));
  std::nth_element(err.begin(), err.begin() + static_cast<long>(k), err.end());
  e.p99 = err[k];
  e.max = *std::max_element(err.begin(), err.end());
  e.p99_percent = 100.0 * e.p99 / diag;
  return e;
}
}  // namespace

std::vector<ShapeError> truth_errors(const anim::Rig& built, const anim::Positions& truth_neutral,
                                     const anim::Rig& truth_deltas, int first, int last) {
  const int nv = built.vertex_count();
  if (truth_neutral.rows() != nv) throw Error("truth: vertex count differs from the built rig");
  last = std::min(last, nv);
  const double diag =
      (built.positions.colwise().maxCoeff() - built.positions.colwise().minCoeff()).norm();
  std::vector<ShapeError> out;
  std::vector<double> err;
  for (const auto& s : built.shapes) {
    const int ti = truth_deltas.find_shape(s.name);
    if (ti < 0) continue;
    const anim::Positions got = built.positions + s.dense(nv);
    const anim::Positions want =
        truth_neutral + truth_deltas.shapes[static_cast<std::size_t>(ti)].dense(nv);
    err.clear();
    for (int v = first; v < last; ++v) err.push_back((got.row(v) - want.row(v)).norm());
    out.push_back(stats(s.name, err, diag));
  }
  return out;
}

std::vector<ShapeError> truth_errors(const anim::Rig& built,
                                     const std::vector<anim::Positions>& truth) {
  const int nv = built.vertex_count();
  const double diag =
      (built.positions.colwise().maxCoeff() - built.positions.colwise().minCoeff()).norm();
  std::vector<ShapeError> out;
  std::vector<double> err;
  for (std::size_t k = 0; k < built.shapes.size() && k < truth.size(); ++k) {
    if (truth[k].rows() != nv)
      throw Error("truth shape '" + built.shapes[k].name + "': vertex count differs");
    const anim::Positions got = built.positions + built.shapes[k].dense(nv);
    err.clear();
    for (int v = 0; v < nv; ++v) err.push_back((got.row(v) - truth[k].row(v)).norm());
    out.push_back(stats(built.shapes[k].name, err, diag));
  }
  return out;
}

}  // namespace facecast::rigbuild
