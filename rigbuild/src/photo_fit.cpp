// The photo avatar's shape: scale-orthographic cameras and identity-mode coefficients fitted in
// turn to the photos' landmarks (jaw-line points matched to the fit's silhouette), then the
// residuals moved exactly by an RBF deformation. See docs/algorithms.md#photo-avatar.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "facecast/core/error.hpp"
#include "photo_detail.hpp"

namespace facecast::rigbuild {
namespace {

constexpr int kJawEnd = 16;  // landmarks 0..16: the jaw line, silhouette points

// One photo in the fit: its landmarks, which of them it uses, its camera and the vertex each
// used landmark is paired with.
struct View {
  const PhotoLandmarks* marks = nullptr;
  std::vector<int> used;      // landmarks this photo contributes
  std::vector<char> contour;  // per landmark: matched to the silhouette
  OrthoCamera camera;
  std::array<int, kLandmarkCount> vertex{};
  const std::array<Eigen::Vector3d, kLandmarkCount>* bias = nullptr;

  // Where landmark k sits on a head at `p`: its vertex plus the detector's convention offset.
  Eigen::Vector3d point(const anim::Positions& p, int k) const {
    const auto i = static_cast<std::size_t>(k);
    const Eigen::Vector3d x = p.row(vertex[i]).cast<double>().transpose();
    return contour[i] ? x : x + (*bias)[i];
  }
};

Eigen::Vector3d row(const anim::Positions& p, int v) {
  return p.row(v).cast<double>().transpose();
}

// Per jaw landmark, the skin vertices near the template's jaw vertex that may become its
// silhouette point.
std::vector<std::vector<int>> jaw_candidates(const PhotoTemplate& tmpl, double radius) {
  std::vector<std::vector<int>> out(kJawEnd + 1);
  const auto& p = tmpl.rig.positions;
  for (int k = 0; k <= kJawEnd; ++k) {
    const Eigen::Vector3d c = row(p, tmpl.landmarks[static_cast<std::size_t>(k)]);
    for (int v = 0; v < tmpl.rig.vertex_count(); ++v)
      if (tmpl.skin[static_cast<std::size_t>(v)] && (row(p, v) - c).norm() < radius)
        out[static_cast<std::size_t>(k)].push_back(v);
  }
  return out;
}

// Jaw landmarks take the grazing candidate (|normal . view| small) whose projection is nearest
// the photo's point; others keep their vertex.
void match_contour(const anim::Positions& positions, const anim::Positions& normals,
                   const std::vector<std::vector<int>>& candidates, View& view) {
  const Eigen::Vector3d towards = view.camera.towards();
  for (int k : view.used) {
    if (!view.contour[static_cast<std::size_t>(k)]) continue;
    const Eigen::Vector2d& q = view.marks->points[static_cast<std::size_t>(k)];
    double best = std::numeric_limits<double>::infinity();
    for (int v : candidates[static_cast<std::size_t>(k)]) {
      if (std::abs(normals.row(v).cast<double>().dot(towards.transpose())) > 0.3) continue;
      const double d = (view.camera.project(row(positions, v)) - q).squaredNorm();
      if (d < best) {
        best = d;
        view.vertex[static_cast<std::size_t>(k)] = v;
      }
    }
  }
}

void fit_camera(const anim::Positions& positions, View& view) {
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  for (int k : view.used) {
    pts.push_back(view.point(positions, k));
    px.push_back(view.marks->points[static_cast<std::size_t>(k)]);
  }
  view.camera = fit_ortho_camera(pts, px);
}

// The identity-mode coefficients for fixed cameras: each landmark gives two equations
// s R12 (x0 + sum_k c_k d_k) = q - b, in inter-ocular units of its photo; the prior adds
// noise^2 |c|^2 (c ~ N(0, 1), landmark noise `noise`).
Eigen::VectorXd solve_coefficients(const PhotoTemplate& tmpl, const std::vector<View>& views,
                                   double iod, double noise) {
  const auto K = static_cast<Eigen::Index>(tmpl.modes.size());
  Eigen::MatrixXd AtA = Eigen::MatrixXd::Identity(K, K) * noise * noise;
  Eigen::VectorXd Atb = Eigen::VectorXd::Zero(K);
  for (const auto& view : views) {
    const double unit = 1.0 / (view.camera.s * iod);
    const Eigen::Matrix<double, 2, 3> R12 = view.camera.R.topRows<2>();
    for (int k : view.used) {
      const int v = view.vertex[static_cast<std::size_t>(k)];
      const Eigen::Vector2d q = view.marks->points[static_cast<std::size_t>(k)];
      const Eigen::Vector2d p0 = view.camera.project(view.point(tmpl.rig.positions, k));
      Eigen::Vector2d r = (q - p0) * unit;
      r.y() = -r.y();  // y up
      Eigen::Matrix<double, 2, Eigen::Dynamic> A(2, K);
      for (Eigen::Index m = 0; m < K; ++m)
        A.col(m) = view.camera.s * unit * R12 *
                   tmpl.modes[static_cast<std::size_t>(m)].row(v).cast<double>().transpose();
      AtA += A.transpose() * A;
      Atb += A.transpose() * r;
    }
  }
  return AtA.ldlt().solve(Atb);
}

anim::Positions apply_modes(const PhotoTemplate& tmpl, const Eigen::VectorXd& c) {
  anim::Positions p = tmpl.rig.positions;
  for (std::size_t m = 0; m < tmpl.modes.size(); ++m)
    p += static_cast<float>(c(static_cast<Eigen::Index>(m))) * tmpl.modes[m];
  return p;
}

double rms_pixels(const anim::Positions& p, const View& view) {
  double sum = 0;
  for (int k : view.used)
    sum += (view.camera.project(view.point(p, k)) - view.marks->points[static_cast<std::size_t>(k)])
               .squaredNorm();
  return std::sqrt(sum / std::max<std::size_t>(1, view.used.size()));
}

// The 3D move of each landmark vertex that puts it exactly on the photos' points: per vertex,
// the least-squares move over the photos that use it (s R12 d = residual), with a small ridge so
// that the depth a single photo does not see stays put.
std::vector<RbfCentre> calibration_moves(const anim::Positions& p, const std::vector<View>& views,
                                         double* rms) {
  std::vector<int> order;
  std::vector<Eigen::Matrix3d> AtA;
  std::vector<Eigen::Vector3d> Atb;
  for (const auto& view : views) {
    const Eigen::Matrix<double, 2, 3> A = view.camera.s * view.camera.R.topRows<2>();
    for (int k : view.used) {
      const int v = view.vertex[static_cast<std::size_t>(k)];
      Eigen::Vector2d r =
          view.marks->points[static_cast<std::size_t>(k)] - view.camera.project(row(p, v));
      r.y() = -r.y();
      auto it = std::find(order.begin(), order.end(), v);
      std::size_t i = static_cast<std::size_t>(it - order.begin());
      if (it == order.end()) {
        order.push_back(v);
        AtA.push_back(Eigen::Matrix3d::Identity() * 1e-6 * view.camera.s * view.camera.s);
        Atb.push_back(Eigen::Vector3d::Zero());
      }
      AtA[i] += A.transpose() * A;
      Atb[i] += A.transpose() * r;
    }
  }
  std::vector<RbfCentre> out;
  double sum = 0;
  for (std::size_t i = 0; i < order.size(); ++i) {
    out.push_back({order[i], AtA[i].ldlt().solve(Atb[i])});
    sum += out.back().move.squaredNorm();
  }
  *rms = std::sqrt(sum / std::max<std::size_t>(1, out.size()));
  return out;
}

}  // namespace

PhotoFit fit_photo_shape(const PhotoTemplate& tmpl, const PhotoLandmarks& front,
                         const PhotoLandmarks* side, const PhotoOptions& options) {
  const auto& X0 = tmpl.rig.positions;
  const double iod = (row(X0, tmpl.landmarks[36]) - row(X0, tmpl.landmarks[45])).norm();
  std::vector<View> views(side ? 2 : 1);
  views[0].marks = &front;
  views[0].contour.assign(kLandmarkCount, 0);
  std::fill_n(views[0].contour.begin(), kJawEnd + 1, 1);
  if (side) {
    views[1].marks = side;
    views[1].contour.assign(kLandmarkCount, 0);
    views[1].contour[8] = 1;
    views[1].used = side_points(*side);
  }
  for (int k = 0; k < kLandmarkCount; ++k) views[0].used.push_back(k);
  for (auto& v : views) {
    v.vertex = tmpl.landmarks;
    v.bias = &tmpl.bias;
  }
  const auto candidates = jaw_candidates(tmpl, 0.3 * iod);

  PhotoFit fit;
  fit.coefficients = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(tmpl.modes.size()));
  anim::Positions p = X0;
  for (int it = 0; it < std::max(1, options.iterations); ++it) {
    for (auto& v : views) fit_camera(p, v);
    if (it > 0) {
      const anim::Positions normals = anim::vertex_normals(p, tmpl.rig.triangles);
      for (auto& v : views) {
        match_contour(p, normals, candidates, v);
        fit_camera(p, v);
      }
    }
    fit.coefficients = solve_coefficients(tmpl, views, iod, options.landmark_noise);
    p = apply_modes(tmpl, fit.coefficients);
  }
  for (auto& v : views) fit_camera(p, v);
  fit.model_positions = p;
  fit.front_rms = rms_pixels(p, views[0]);
  if (side) fit.side_rms = rms_pixels(p, views[1]);

  const auto centres = calibration_moves(p, views, &fit.moved_rms);
  for (int k = 0; k < kLandmarkCount; ++k)
    for (const auto& c : centres)
      if (c.vertex == views[0].vertex[static_cast<std::size_t>(k)])
        fit.landmark_moves[static_cast<std::size_t>(k)] = c.move;
  rbf_deform(p, centres, tmpl.rigid, options.rbf_radius * iod, 0.02 * iod);
  fit.positions = std::move(p);
  fit.front = views[0].camera;
  fit.front_vertex = views[0].vertex;
  fit.side_vertex.fill(-1);
  if (side) {
    fit.side = views[1].camera;
    fit.side_vertex = views[1].vertex;
  }
  return fit;
}

std::array<Eigen::Vector3d, kLandmarkCount> measure_landmark_bias(const PhotoTemplate& tmpl,
                                                                  const PhotoLandmarks& front,
                                                                  const PhotoLandmarks* side,
                                                                  const PhotoOptions& options) {
  PhotoTemplate plain = tmpl;
  plain.bias = zero_landmark_vectors();
  PhotoOptions o = options;
  o.landmark_noise = 1e6;  // the template's own shape: no identity modes
  const PhotoFit fit = fit_photo_shape(plain, front, side, o);
  std::array<Eigen::Vector3d, kLandmarkCount> out = zero_landmark_vectors();
  for (int k = kJawEnd + 1; k < kLandmarkCount; ++k)
    out[static_cast<std::size_t>(k)] = fit.landmark_moves[static_cast<std::size_t>(k)];
  return out;
}

}  // namespace facecast::rigbuild
