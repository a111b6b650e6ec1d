// The photo avatar's shape: the cameras (scale-orthographic or perspective) and identity-mode
// coefficients fitted together to the photos' landmarks (jaw-line points matched to the fit's
// silhouette) and to the edges along the face's outline, then the residuals moved by an RBF
// deformation. See docs/algorithms.md#photo-avatar.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <deque>
#include <future>
#include <limits>
#include <optional>
#include <set>
#include <thread>

#include "edge_image.hpp"
#include "facecast/core/error.hpp"
#include "geometry.hpp"
#include "parallel.hpp"
#include "photo_detail.hpp"

namespace facecast::rigbuild {
namespace {

constexpr int kJawEnd = 16;  // landmarks 0..16: the jaw line, silhouette points

// dlib's landmarks by feature: the jaw line, brows, nose, eyes, mouth. Each group's noise is
// estimated on its own (estimate_group_noise).
constexpr int kGroups = 5;
// A group's variance estimate is pulled towards the photo's as if by this many more degrees of
// freedom at the photo's variance (a group of 9 points has about 12 of its own).
constexpr double kGroupPrior = 10;
int landmark_group(int k) {
  return k <= kJawEnd ? 0 : k <= 26 ? 1 : k <= 35 ? 2 : k <= 47 ? 3 : 4;
}

// A vertex on the fit's outline paired with the photo's edge: its projection should move along
// `normal` (the outline's, outwards, photo pixels) onto the line through `target`.
struct OutlinePoint {
  int vertex = 0;
  Eigen::Vector2d normal = Eigen::Vector2d::Zero(), target = Eigen::Vector2d::Zero();
  double weight = 1;
};

// The fit's coefficient m: identity mode m, or past the modes an expression shape.
const rig::Positions& mode_shape(const PhotoTemplate& tmpl, int m) {
  const auto i = static_cast<std::size_t>(m);
  return i < tmpl.modes.size() ? tmpl.modes[i] : tmpl.expressions[i - tmpl.modes.size()];
}

// One photo in the fit: its landmarks, which of them it uses, its camera and the vertex each
// used landmark is paired with.
struct View {
  const PhotoLandmarks* marks = nullptr;
  std::vector<int> used;      // landmarks this photo contributes
  std::vector<char> contour;  // per landmark: matched to the silhouette
  PhotoCamera camera;
  std::array<int, kLandmarkCount> vertex{};
  const PhotoTemplate* tmpl = nullptr;
  const std::array<Eigen::Vector3d, kLandmarkCount>* bias = nullptr;
  const std::vector<std::array<Eigen::Vector3d, kLandmarkCount>>* mode_bias = nullptr;
  double noise = 1;  // this photo's landmark noise relative to the front photo's
  // Each landmark group's noise relative to the photo's (estimate_group_noise).
  std::array<double, kGroups> group_noise{1, 1, 1, 1, 1};
  double sd(int k) const {
    return noise * group_noise[static_cast<std::size_t>(landmark_group(k))];
  }
  // A turned head: this photo's rotation is the front photo's times a turn about the head's
  // vertical axis (R_front Ry(turn)) instead of a free rotation.
  bool turned = false;
  double turn = 0;
  // The camera's perspective (PhotoCamera::kappa) is fitted too (else it stays as it is).
  bool perspective = false;
  std::optional<EdgeImage> edges;     // the photo's, when its outline is matched
  std::vector<OutlinePoint> outline;  // the outline's matches (match_outline)

  // Where the detector puts landmark k on the head with coefficients c (positions p): its vertex
  // plus the detector's convention offset for that identity.
  Eigen::Vector3d point(const rig::Positions& p, const Eigen::VectorXd& c, int k) const {
    const auto i = static_cast<std::size_t>(k);
    Eigen::Vector3d x = p.row(vertex[i]).cast<double>().transpose();
    if (contour[i]) return x;
    x += (*bias)[i];
    for (std::size_t m = 0; m < mode_bias->size(); ++m)
      x += c(static_cast<Eigen::Index>(m)) * (*mode_bias)[m][i];
    return x;
  }
  // d point / d c_m (the expressions' weights after the modes).
  Eigen::Vector3d mode(int m, int k) const {
    const auto i = static_cast<std::size_t>(k);
    Eigen::Vector3d d = mode_shape(*tmpl, m).row(vertex[i]).cast<double>().transpose();
    if (!contour[i] && static_cast<std::size_t>(m) < mode_bias->size())
      d += (*mode_bias)[static_cast<std::size_t>(m)][i];
    return d;
  }
};

Eigen::Matrix3d skew(const Eigen::Vector3d& x) {
  Eigen::Matrix3d m;
  m << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
  return m;
}

Eigen::Matrix3d turn_matrix(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

Eigen::Vector3d row(const rig::Positions& p, int v) {
  return p.row(v).cast<double>().transpose();
}

// The head with coefficients c: the identity modes' and, past them, the expressions' weights.
rig::Positions apply_modes(const PhotoTemplate& tmpl, const Eigen::VectorXd& c) {
  rig::Positions p = tmpl.rig.positions;
  for (Eigen::Index m = 0; m < c.size(); ++m)
    if (c(m) != 0) p += static_cast<float>(c(m)) * mode_shape(tmpl, static_cast<int>(m));
  return p;
}

// Per vertex: on the silhouette the camera sees (from its centre when it has perspective).
std::vector<char> camera_silhouette(const rig::Positions& p, const Triangles& tris,
                                    const PhotoCamera& camera) {
  if (!camera.perspective()) return silhouette(p, tris, camera.towards());
  const Eigen::Vector3d eye = camera.eye();
  std::vector<unsigned char> facing(static_cast<std::size_t>(p.rows()), 0);
  for (Eigen::Index f = 0; f < tris.rows(); ++f) {
    const Eigen::Vector3d a = row(p, tris(f, 0)), b = row(p, tris(f, 1)), c = row(p, tris(f, 2));
    const unsigned char bit = (b - a).cross(c - a).dot(eye - a) > 0 ? 1 : 2;
    for (int k = 0; k < 3; ++k) facing[static_cast<std::size_t>(tris(f, k))] |= bit;
  }
  std::vector<char> out(facing.size());
  for (std::size_t v = 0; v < facing.size(); ++v) out[v] = facing[v] == 3;
  return out;
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

// Jaw landmarks (dlib traces the face's outline) take, among the template's own jaw vertex and
// the silhouette vertices near it, the one projecting nearest the photo's point.
void match_contour(const PhotoTemplate& tmpl, const rig::Positions& positions,
                   const std::vector<std::vector<int>>& candidates, View& view) {
  const std::vector<char> outline = camera_silhouette(positions, tmpl.rig.triangles, view.camera);
  for (int k : view.used) {
    const auto i = static_cast<std::size_t>(k);
    if (!view.contour[i]) continue;
    const Eigen::Vector2d& q = view.marks->points[i];
    const auto dist = [&](int v) {
      return (view.camera.project(row(positions, v)) - q).squaredNorm();
    };
    view.vertex[i] = tmpl.landmarks[i];
    double best = dist(view.vertex[i]);
    for (int v : candidates[i]) {
      if (!outline[static_cast<std::size_t>(v)]) continue;
      const double d = dist(v);
      if (d < best) {
        best = d;
        view.vertex[i] = v;
      }
    }
  }
}

// Per vertex: may be an outline point, a skin vertex of the face in front of the ears, from the
// chin's underside to the forehead (the neck, the back of the head and the scalp are often
// clothes, shadow or hair in a photo, not skin against the background).
std::vector<char> outline_region(const PhotoTemplate& tmpl, double iod) {
  const auto& p = tmpl.rig.positions;
  const auto at = [&](int k) { return row(p, tmpl.landmarks[static_cast<std::size_t>(k)]); };
  double brow = -std::numeric_limits<double>::max();
  for (int k = 17; k <= 26; ++k) brow = std::max(brow, at(k).y());
  const double bottom = at(8).y() - 0.05 * iod, top = brow + 0.5 * iod;
  const double back = std::min(at(0).z(), at(kJawEnd).z());
  std::vector<char> out(static_cast<std::size_t>(p.rows()), 0);
  for (int v = 0; v < p.rows(); ++v) {
    const Eigen::Vector3d x = row(p, v);
    out[static_cast<std::size_t>(v)] =
        tmpl.skin[static_cast<std::size_t>(v)] && x.y() > bottom && x.y() < top && x.z() > back;
  }
  return out;
}

// Pairs the fit's outer outline seen by the view's camera with the photo's edges: the region's
// silhouette vertices with no mesh just outside them (else an inner fold: the nose's side, the
// jaw over the neck), at most one per `spacing` pixels, each with the strongest edge along its
// normal within `window` pixels (|gradient . normal|, sub-pixel by a parabola). An edge's weight
// falls to zero at the window's end (Tukey's biweight), and edges weaker than a quarter of the
// median are dropped: another feature than the outline was found, or none.
void match_outline(const PhotoTemplate& tmpl, const rig::Positions& p,
                   const std::vector<char>& region, double window, double spacing, View& view) {
  const PhotoCamera& cam = view.camera;
  const EdgeImage& edges = *view.edges;
  const std::vector<char> outline = camera_silhouette(p, tmpl.rig.triangles, cam);
  const rig::Positions normals = rig::vertex_normals(p, tmpl.rig.triangles);
  const DepthBuffer cover(p, tmpl.rig.triangles, cam, edges.width(), edges.height());
  std::set<std::pair<long, long>> cells;
  std::vector<std::pair<OutlinePoint, double>> found;  // with the edge's strength
  const double step = window / 16;
  for (int v = 0; v < p.rows(); ++v) {
    if (!region[static_cast<std::size_t>(v)] || !outline[static_cast<std::size_t>(v)]) continue;
    const Eigen::Vector3d normal = row(normals, v), at = row(p, v);
    const double facing = normal.dot(cam.towards(at));
    if (1 - facing * facing < 0.25) continue;  // facing the camera: not on the outline
    // The normal seen in the photo (pixels, y down).
    Eigen::Vector2d n = cam.jacobian(at) * normal;
    n.y() = -n.y();
    if (n.norm() == 0) continue;
    n.normalize();
    const Eigen::Vector2d x = cam.project(at);
    if (cover.covered(x + 0.25 * spacing * n)) continue;
    if (!cells
             .insert({std::lround(std::floor(x.x() / spacing)),
                      std::lround(std::floor(x.y() / spacing))})
             .second)
      continue;
    const auto strength = [&](double t) { return std::abs(edges.gradient(x + t * n).dot(n)); };
    double best = 0, t = 0;
    for (int i = -16; i <= 16; ++i)
      if (const double g = strength(i * step); g > best) {
        best = g;
        t = i * step;
      }
    if (best <= 0) continue;
    if (std::abs(t) < window) {
      const double a = strength(t - step), b = strength(t + step);
      const double curve = a - 2 * best + b;
      if (curve < 0) t += std::clamp(0.5 * (a - b) / curve, -0.5, 0.5) * step;
    }
    const double u = t / window;
    if (std::abs(u) >= 1) continue;
    found.push_back({{v, n, x + t * n, (1 - u * u) * (1 - u * u)}, best});
  }
  view.outline.clear();
  if (found.empty()) return;
  std::vector<double> strengths;
  for (const auto& f : found) strengths.push_back(f.second);
  std::nth_element(strengths.begin(),
                   strengths.begin() + static_cast<std::ptrdiff_t>(strengths.size() / 2),
                   strengths.end());
  const double median = strengths[strengths.size() / 2];
  for (const auto& f : found)
    if (f.second >= 0.25 * median) view.outline.push_back(f.first);
}

void fit_camera(const rig::Positions& positions, const Eigen::VectorXd& c, View& view) {
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  for (int k : view.used) {
    pts.push_back(view.point(positions, c, k));
    px.push_back(view.marks->points[static_cast<std::size_t>(k)]);
  }
  view.camera = fit_ortho_camera(pts, px);
}

// One Gauss-Newton step on the cameras and the identity-mode coefficients together (the camera's
// scale and rotation trade off against the modes, so alternating between them stalls):
//   min sum_photos sum_landmarks |pi_v(x0_k + D_k c + b_k) - q_k|^2 / (s_v IOD)^2
//     + sum_photos sum_outline w_j (n_j . (q_j - pi_v(x0_j + D_j c)))^2 / (s_v IOD n_o)^2
//     + sigma^2 |c|^2 [+ sigma^2 (q - 1 / f)^2 / (f_sd / f)^2],
// pi_v = scale-orthographic camera (rotation R exp([w]x), scale s, translation t); an outline
// point only moves along its normal n_j (it slides along the outline), n_o = `outline_noise`.
// With a perspective camera the photos share an inverse focal length q, whose prior is the front
// photo's EXIF focal length f (PhotoLandmarks::focal) where it has one, f_sd = `focal_sd`.
// `scatter` (optional), per photo: its weighted landmark residuals' sum of squares and their
// redundancy (their count less what the parameters absorb, tr(H^-1 J_v^T J_v)), before the step:
// the variance components that set the side photo's noise (fit_shape). `covariance`
// (optional): the coefficients' posterior covariance, noise^2 H^-1 over the modes (the data terms
// and the prior, both in units of `noise`), at the step's start.
constexpr Eigen::Index kCameraParameters = 6;  // per photo: rotation (3), scale, translation (2)

void gauss_newton_step(const PhotoTemplate& tmpl, std::vector<View>& views, Eigen::VectorXd& c,
                       double iod, double noise, double outline_noise, double focal_sd,
                       double expression_sd, std::vector<Eigen::Vector2d>* scatter = nullptr,
                       Eigen::MatrixXd* covariance = nullptr,
                       std::array<Eigen::Vector2d, kGroups>* groups = nullptr) {
  // The identity modes' coefficients, then the expressions' weights (c's size says how many).
  const auto K = c.size(), modes = static_cast<Eigen::Index>(tmpl.modes.size());
  // The last parameter: the photos' shared inverse focal length q (kappa_v = s_v q; one camera
  // took both photos).
  const Eigen::Index n = K + kCameraParameters * static_cast<Eigen::Index>(views.size()) + 1;
  const double inv_focal = views[0].perspective ? views[0].camera.kappa / views[0].camera.s : 0.0;
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(n, n) * 1e-9;
  // The prior: N(0, 1) per mode, N(0, expression_sd^2) per expression weight.
  Eigen::VectorXd prior = Eigen::VectorXd::Constant(K, noise * noise);
  prior.tail(K - modes).array() /= expression_sd * expression_sd;
  H.topLeftCorner(K, K).diagonal() += prior;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  g.head(K) = -prior.cwiseProduct(c);
  if (tmpl.appearance.information.rows() == modes) {  // the photo's pixels (appearance_evidence)
    H.topLeftCorner(modes, modes) += noise * noise * tmpl.appearance.information;
    g.head(modes) +=
        noise * noise * (tmpl.appearance.pull - tmpl.appearance.information * c.head(modes));
  }
  const rig::Positions p = apply_modes(tmpl, c);
  std::vector<Eigen::MatrixXd> Hv;
  std::vector<double> rss(views.size(), 0.0), count(views.size(), 0.0);
  std::vector<Eigen::MatrixXd> Hg(groups ? kGroups : 0, Eigen::MatrixXd::Zero(n, n));
  std::array<double, kGroups> group_rss{}, group_count{};
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    if (scatter) Hv.push_back(Eigen::MatrixXd::Zero(n, n));
    const View& view = views[vi];
    const PhotoCamera& cam = view.camera;
    const double unit = 1.0 / (cam.s * iod);
    const Eigen::Index o = K + kCameraParameters * static_cast<Eigen::Index>(vi);
    const Eigen::Matrix<double, 2, 3> R12 = cam.R.topRows<2>();
    // d pi_v(x) / d(c, cameras), y up; D: d x / d c. With r = R x, d = 1 - kappa r.z and Q the
    // pixel (y up, from the principal point): dQ/dr = (s [I 0] + kappa Q e_z^T) / d, so that
    // dQ/dx = dQ/dr R (PhotoCamera::jacobian).
    const auto jacobian = [&](const Eigen::Vector3d& x, const Eigen::Matrix3Xd& D) {
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2, n);
      const Eigen::Vector3d r = cam.R * x;
      const double d = 1 - cam.kappa * r.z();
      const Eigen::Vector2d pixel = cam.project(x);
      const Eigen::Vector2d offset(pixel.x() - cam.centre.x(), cam.centre.y() - pixel.y());
      Eigen::Matrix<double, 2, 3> dr = Eigen::Matrix<double, 2, 3>::Zero();
      dr.leftCols<2>() = cam.s * Eigen::Matrix2d::Identity();
      dr.col(2) = cam.kappa * offset;
      dr /= d;
      const Eigen::Matrix<double, 2, 3> dx = dr * cam.R;
      J.leftCols(K) = dx * D;
      if (view.turned) {
        // R = R_front exp([w]x) Ry(turn): the front photo's w, and the turn.
        const Eigen::Vector3d y = Eigen::AngleAxisd(view.turn, Eigen::Vector3d::UnitY()) * x;
        J.block(0, K, 2, 3) = -dr * views[0].camera.R * skew(y);
        J.col(o) = dx * Eigen::Vector3d::UnitY().cross(x);
      } else {
        J.block(0, o, 2, 3) = -dx * skew(x);  // d(R exp([w]x) x)/dw at 0: -R [x]x
      }
      J.col(o + 3) = R12 * x / d;
      J.block(0, o + 4, 2, 2) = Eigen::Matrix2d::Identity() / d;
      if (view.perspective) {  // dQ/dkappa = Q r.z / d, kappa = s q
        const Eigen::Vector2d dkappa = offset * r.z() / d;
        J.col(o + 3) += inv_focal * dkappa;
        J.col(n - 1) = cam.s * dkappa;
      }
      return J;
    };
    Eigen::Matrix3Xd D(3, K);
    for (int k : view.used) {
      const auto i = static_cast<std::size_t>(k);
      const Eigen::Vector3d x = view.point(p, c, k);
      Eigen::Vector2d r = view.marks->points[i] - cam.project(x);
      r.y() = -r.y();  // y up
      for (Eigen::Index m = 0; m < K; ++m) D.col(m) = view.mode(static_cast<int>(m), k);
      const Eigen::MatrixXd J = jacobian(x, D) * (unit / view.sd(k));
      r *= unit / view.sd(k);
      const Eigen::MatrixXd JtJ = J.transpose() * J;
      H += JtJ;
      g += J.transpose() * r;
      if (scatter) {
        Hv[vi] += JtJ;
        rss[vi] += r.squaredNorm();
        count[vi] += 2;
        if (groups && vi == 0) {
          const auto gi = static_cast<std::size_t>(landmark_group(k));
          Hg[gi] += JtJ;
          group_rss[gi] += r.squaredNorm();
          group_count[gi] += 2;
        }
      }
    }
    for (const OutlinePoint& q : view.outline) {
      const Eigen::Vector3d x = row(p, q.vertex);
      for (Eigen::Index m = 0; m < K; ++m)
        D.col(m) = row(mode_shape(tmpl, static_cast<int>(m)), q.vertex);
      const Eigen::Vector2d up(q.normal.x(), -q.normal.y());
      const double w = std::sqrt(q.weight) * unit / outline_noise;
      const Eigen::RowVectorXd J = w * up.transpose() * jacobian(x, D);
      const double r = w * q.normal.dot(q.target - cam.project(x));
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
  }
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    const Eigen::Index o = K + kCameraParameters * static_cast<Eigen::Index>(vi);
    if (views[vi].turned) {  // its other two rotation parameters are not used
      H(o + 1, o + 1) += 1;
      H(o + 2, o + 2) += 1;
    }
  }
  if (!views[0].perspective) H(n - 1, n - 1) += 1;  // orthographic: q stays 0
  if (views[0].perspective && views[0].marks->focal > 0) {
    // The lens the front photo's EXIF gives: a prior on q, N(1 / focal, (focal_sd / focal)^2),
    // in the landmarks' units as the modes' prior is.
    const double q0 = 1 / views[0].marks->focal, weight = noise * noise / (focal_sd * focal_sd);
    H(n - 1, n - 1) += weight / (q0 * q0);
    g(n - 1) += weight * (q0 - inv_focal) / (q0 * q0);
  }
  const auto ldlt = H.ldlt();
  Eigen::VectorXd dx = ldlt.solve(g);
  if (views[0].perspective) {
    // q stays in [0, 0.8 / (s max r_z)] (no point of the head nearer than a fifth of the camera's
    // distance) and a step moves the nearest point's perspective factor kappa r_z by at most 0.05
    // (far from the solution a full step can throw the cameras off). A step that would leave
    // those bounds takes q to the bound and solves the other parameters again with it there (a
    // coupled step computed for a q that is not taken throws them off instead).
    double nearest = 1e-9, s_max = 0;
    for (const View& view : views) {
      for (int v = 0; v < p.rows(); ++v)
        nearest = std::max(nearest, (view.camera.R * row(p, v)).z());
      s_max = std::max(s_max, view.camera.s);
    }
    const double limit = 0.05 / (nearest * s_max);
    const double next =
        std::clamp(inv_focal + std::clamp(dx(n - 1), -limit, limit), 0.0, 0.8 / (nearest * s_max));
    const double step = next - inv_focal;
    if (step != dx(n - 1)) {
      Eigen::MatrixXd Hq = H;
      Eigen::VectorXd gq = g - H.col(n - 1) * step;
      Hq.row(n - 1).setZero();
      Hq.col(n - 1).setZero();
      Hq(n - 1, n - 1) = 1;
      gq(n - 1) = step;
      dx = Hq.ldlt().solve(gq);
    }
  }
  if (scatter) {
    scatter->clear();
    for (std::size_t vi = 0; vi < views.size(); ++vi)
      scatter->emplace_back(rss[vi], count[vi] - ldlt.solve(Hv[vi]).trace());
    if (groups)
      for (std::size_t gi = 0; gi < kGroups; ++gi)
        (*groups)[gi] = {group_rss[gi], group_count[gi] - ldlt.solve(Hg[gi]).trace()};
  }
  if (covariance)
    *covariance =
        noise * noise * ldlt.solve(Eigen::MatrixXd::Identity(n, n)).topLeftCorner(modes, modes);
  c += dx.head(K);
  // An expression's weight stays in [0, 1] (a shape pushed past its range is not that expression).
  c.tail(K - modes) = c.tail(K - modes).cwiseMax(0.0).cwiseMin(1.0);
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    PhotoCamera& cam = views[vi].camera;
    const Eigen::Index o = K + kCameraParameters * static_cast<Eigen::Index>(vi);
    const Eigen::Vector3d w = dx.segment<3>(o);
    if (views[vi].turned) {  // after the front photo's camera (vi = 0) moved
      views[vi].turn += dx(o);
      cam.R = views[0].camera.R * turn_matrix(views[vi].turn);
    } else if (w.norm() > 0)
      cam.R = cam.R * Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
    cam.s += dx(o + 3);
    cam.t += Eigen::Vector2d(dx(o + 4), -dx(o + 5));
  }
  if (views[0].perspective)
    for (View& view : views) view.camera.kappa = view.camera.s * (inv_focal + dx(n - 1));
}

double rms_pixels(const rig::Positions& p, const Eigen::VectorXd& c, const View& view) {
  double sum = 0;
  for (int k : view.used)
    sum +=
        (view.camera.project(view.point(p, c, k)) - view.marks->points[static_cast<std::size_t>(k)])
            .squaredNorm();
  return std::sqrt(sum / std::max<std::size_t>(1, view.used.size()));
}

// The 3D move of each landmark vertex that puts it exactly on the photos' points: per vertex,
// the least-squares move over the photos that use it (s R12 d = residual), with a small ridge so
// that the depth a single photo does not see stays put. `side_moves` false: the front photo's
// only (the side photo's depth then comes from the modes alone: its residuals are mostly the
// detector's noise, which a depth move amplifies by 1 / sin(turn)).
std::vector<RbfCentre> calibration_moves(const rig::Positions& p, const Eigen::VectorXd& c,
                                         const std::vector<View>& views, bool side_moves,
                                         double* rms) {
  std::vector<int> order;
  std::vector<Eigen::Matrix3d> AtA;
  std::vector<Eigen::Vector3d> Atb;
  for (const auto& view : views) {
    if (&view != &views.front() && !side_moves) continue;
    for (int k : view.used) {
      const int v = view.vertex[static_cast<std::size_t>(k)];
      const Eigen::Vector3d x = view.point(p, c, k);
      const Eigen::Matrix<double, 2, 3> A = view.camera.jacobian(x) / view.sd(k);
      Eigen::Vector2d r = view.marks->points[static_cast<std::size_t>(k)] - view.camera.project(x);
      r.y() = -r.y();
      r /= view.sd(k);
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

// The fit; `contour`: jaw-line points matched to the silhouette (else fixed vertices whose
// detector offsets were measured); `expressions`: the template's expressions are fitted too.
PhotoFit fit_shape(const PhotoTemplate& tmpl, const PhotoLandmarks& front,
                   const PhotoLandmarks* side, const PhotoOptions& options, bool contour,
                   const render::Image* front_photo, const render::Image* side_photo,
                   bool perspective, const PhotoFit* start, bool expressions) {
  const auto& X0 = tmpl.rig.positions;
  const double iod = (row(X0, tmpl.landmarks[36]) - row(X0, tmpl.landmarks[45])).norm();
  std::vector<View> views(side ? 2 : 1);
  views[0].marks = &front;
  views[0].contour.assign(kLandmarkCount, 0);
  std::fill_n(views[0].contour.begin(), kJawEnd + 1, contour ? 1 : 0);
  if (side) {
    views[1].marks = side;
    views[1].contour.assign(kLandmarkCount, 0);
    views[1].contour[8] = contour ? 1 : 0;
    views[1].used = side_points(*side);
    views[1].noise = options.side_noise;
  }
  for (int k = 0; k < kLandmarkCount; ++k) views[0].used.push_back(k);
  for (auto& v : views) {
    v.vertex = tmpl.landmarks;
    v.tmpl = &tmpl;
    v.bias = &v == &views[0] ? &tmpl.bias : &tmpl.side_bias;
    v.mode_bias = &v == &views[0] ? &tmpl.mode_bias : &tmpl.side_mode_bias;
  }
  const auto candidates = jaw_candidates(tmpl, 0.3 * iod);

  PhotoFit fit;
  const auto modes = static_cast<Eigen::Index>(tmpl.modes.size());
  Eigen::VectorXd c = Eigen::VectorXd::Zero(
      modes + (expressions ? static_cast<Eigen::Index>(tmpl.expressions.size()) : 0));
  rig::Positions p = X0;
  for (auto& v : views) fit_camera(p, c, v);
  if (side && options.side_turn) {
    // The side photo's camera as the front's with the head turned: the turn is the yaw of the
    // relative rotation.
    const Eigen::Matrix3d rel = views[0].camera.R.transpose() * views[1].camera.R;
    views[1].turned = true;
    views[1].turn = std::atan2(rel(0, 2), rel(0, 0));
    views[1].camera.R = views[0].camera.R * turn_matrix(views[1].turn);
  }
  if (start) {
    // From an earlier fit's cameras (analysis by synthesis): the detector's offsets measured on
    // renders of a side photo move its camera fitted alone by up to 15 degrees of turn, further
    // than the outline reaches.
    views[0].camera = start->front;
    if (side && start->side) {
      views[1].camera = *start->side;
      if (views[1].turned) {
        const Eigen::Matrix3d rel = start->front.R.transpose() * start->side->R;
        views[1].turn = std::atan2(rel(0, 2), rel(0, 0));
        views[1].camera.R = views[0].camera.R * turn_matrix(views[1].turn);
      }
    }
    if (!perspective)
      for (auto& v : views) v.camera.kappa = 0;
  }
  if (perspective)
    for (auto& v : views) {
      // From orthographic (kappa 0, or the earlier fit's) on; the principal point is the photo's
      // centre.
      v.perspective = true;
      v.camera.centre = {0.5 * (v.marks->width - 1), 0.5 * (v.marks->height - 1)};
    }
  // The outlines' edges, blurred and searched in proportion to the face's size in each photo.
  const render::Image* photos[2] = {options.front_outline ? front_photo : nullptr,
                                    options.side_outline ? side_photo : nullptr};
  for (std::size_t i = 0; i < views.size(); ++i)
    if (photos[i]) views[i].edges.emplace(*photos[i], 0.01 * views[i].camera.s * iod);
  const auto region = outline_region(tmpl, iod);
  // The outline's search window (inter-ocular distances) in `round`: outline_start times
  // outline_window in the first round that matches outlines, half a window narrower each round
  // after. The side photo's first turn, from the landmarks alone, is often 5-10 degrees short
  // (dlib's points on a turned face lie as if it were turned less), and its outline then lies
  // outside the narrow window.
  const auto window = [&](int round) {
    return options.outline_window * std::max(1.0, options.outline_start - 0.5 * (round - 1));
  };
  double noise = options.landmark_noise;  // the front landmarks', inter-ocular distances
  for (int it = 0; it < std::max(1, options.iterations); ++it) {
    // From an earlier fit's cameras the outlines are matched from the first round: a first round
    // of landmarks alone moved the side photo's turn from the earlier fit's 31 degrees to 17 (for
    // 35), and the narrowing window found the outline again in some fits and not in others.
    const int round = it + (start ? 1 : 0);
    if (round > 0)
      for (auto& v : views) {
        match_contour(tmpl, p, candidates, v);
        if (v.edges)
          match_outline(tmpl, p, region, window(round) * v.camera.s * iod, 0.05 * v.camera.s * iod,
                        v);
      }
    std::vector<Eigen::Vector2d> scatter;
    std::array<Eigen::Vector2d, kGroups> groups;
    for (int step = 0; step < 3; ++step)
      gauss_newton_step(tmpl, views, c, iod, noise, options.outline_noise, options.exif_focal_sd,
                        options.expression_sd, step == 2 ? &scatter : nullptr,
                        step == 2 ? &fit.coefficient_covariance : nullptr,
                        step == 2 ? &groups : nullptr);
    // A photo's weighted landmark residuals per degree of freedom (variance components).
    const auto variance = [](const Eigen::Vector2d& v) { return v(0) / std::max(1.0, v(1)); };
    if (options.estimate_group_noise && it > 0) {
      // Variance components within the front photo: each landmark group's weighted residuals per
      // degree of freedom (pulled towards the photo's by kGroupPrior) against the photo's set its
      // noise relative to the others (the detector's convention is kept less well on the brows
      // and the jaw line than at the eye corners), within [1/3, 3], normalised to a mean square
      // of 1 over the points (the photo's noise stays the pooled one, the prior keeps its weight).
      auto& f = views[0].group_noise;
      const double all = std::max(1e-12, variance(scatter[0]));
      for (std::size_t gi = 0; gi < kGroups; ++gi) {
        const double dof = std::max(0.0, groups[gi](1));
        const double v = (groups[gi](0) + kGroupPrior * all) / (dof + kGroupPrior);
        f[gi] = std::clamp(f[gi] * std::sqrt(v / all), 1.0 / 3, 3.0);
      }
      double mean_square = 0;
      for (int k = 0; k < kLandmarkCount; ++k)
        mean_square += std::pow(f[static_cast<std::size_t>(landmark_group(k))], 2) / kLandmarkCount;
      for (double& x : f) x /= std::sqrt(mean_square);
    }
    if (options.estimate_noise) {
      // The front landmarks' residuals per degree of freedom estimate their noise (the detector's
      // scatter and its convention's offsets from the template's vertices alike): the prior holds
      // the modes in proportion (not below landmark_noise).
      noise = std::max(options.landmark_noise, std::sqrt(variance(scatter[0])));
    }
    if (side && options.estimate_side_noise && it > 0) {
      // Variance components: each photo's weighted residuals per degree of freedom estimate its
      // noise relative to its weight; the side's weight follows the ratio to the front's (not
      // below side_noise). After the first round: its residuals are the template's misfit.
      views[1].noise = std::max(
          options.side_noise,
          views[1].noise * std::sqrt(variance(scatter[1]) / std::max(1e-12, variance(scatter[0]))));
    }
    p = apply_modes(tmpl, c);
  }
  fit.coefficients = c.head(modes);
  fit.coefficient_sd = fit.coefficient_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  fit.expression = c.tail(c.size() - modes);
  fit.model_positions = apply_modes(tmpl, fit.coefficients);  // the neutral
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    // The landmarks' misfit in inter-ocular distances (the camera model's evidence), the groups
    // unweighted: each camera model's fit weighs them its own way, and a misfit weighed by a fit's
    // own group noise favours the fit that explains least (selfies' orthographic fits chose to
    // trust the points a flat camera could explain).
    const View& v = views[vi];
    double sum = 0;
    for (int k : v.used)
      sum += (v.camera.project(v.point(p, c, k)) - v.marks->points[static_cast<std::size_t>(k)])
                 .squaredNorm();
    (vi == 0 ? fit.front_rss : fit.side_rss) = sum / std::pow(v.camera.s * iod, 2);
    fit.residuals += 2 * static_cast<int>(v.used.size());
  }
  fit.front_rms = rms_pixels(p, c, views[0]);
  if (side) {
    fit.side_rms = rms_pixels(p, c, views[1]);
    fit.side_noise = views[1].noise;
  }
  fit.noise = noise;
  fit.group_noise = views[0].group_noise;

  // The calibration's moves, measured on the head as photographed, move the neutral.
  const auto centres = calibration_moves(p, c, views, options.side_calibration, &fit.moved_rms);
  p = fit.model_positions;
  for (int k = 0; k < kLandmarkCount; ++k)
    for (const auto& centre : centres)
      if (centre.vertex == views[0].vertex[static_cast<std::size_t>(k)])
        fit.landmark_moves[static_cast<std::size_t>(k)] = centre.move;
  rbf_deform(p, centres, tmpl.rigid, options.rbf_radius * iod, 0.02 * iod, options.rbf_smoothing);
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

// A fit's landmark misfit in the noises `var` (front) and `side_var` plus its prior, chi^2 +
// |c|^2 + |e / expression_sd|^2 (and the photo's pixels' term, tmpl.appearance): the evidence's
// measure.
double chi2(const PhotoTemplate& tmpl, const PhotoFit& f, double var, double side_var,
            const PhotoOptions& options) {
  double appearance = 0;
  if (tmpl.appearance.information.rows() == f.coefficients.size())
    appearance = f.coefficients.dot(tmpl.appearance.information * f.coefficients) -
                 2 * tmpl.appearance.pull.dot(f.coefficients);
  return f.front_rss / var + f.side_rss / side_var + f.coefficients.squaredNorm() + appearance +
         (f.expression / options.expression_sd).squaredNorm();
}

// fit_photo_shape with or without the template's expressions: the camera model chosen.
PhotoFit fit_camera_model(const PhotoTemplate& tmpl, const PhotoLandmarks& front,
                          const PhotoLandmarks* side, const PhotoOptions& options,
                          const render::Image* front_photo, const render::Image* side_photo,
                          const PhotoFit* start, bool expressions) {
  const bool contour = tmpl.mode_bias.empty();
  const bool sized = front.width > 0 && (!side || side->width > 0);
  const auto fit = [&](const PhotoLandmarks& marks, bool perspective, const PhotoOptions& o) {
    return fit_shape(tmpl, marks, side, o, contour, front_photo, side_photo, perspective, start,
                     expressions);
  };
  if (options.camera == "orthographic" || !sized) return fit(front, false, options);
  if (options.camera == "perspective") {
    PhotoFit f = fit(front, true, options);
    f.camera_model = "perspective";
    return f;
  }
  if (front.focal > 0) {
    // The lens the front photo's EXIF gives, the focal length's prior, at any distance: a lens
    // of 12-20 degrees puts the camera 1.2-2 m away, and although its perspective moves the
    // landmarks by about their noise, it shrinks the ears and the skull's outline by 5-8 % against
    // the face, which the photos' pixels see (an orthographic fit's renders needed the photo
    // scaled by 4-8 % to match under a lamp; docs/benchmarks.md#photo-avatar). Nearer than
    // exif_distance (a selfie) the landmarks' noise floor is near_landmark_noise: the lens at
    // arm's length moves dlib's points more than the analysis by synthesis's renders reproduce
    // (held-out selfies at landmark_noise: coefficients' errors 1.7 of their posterior sd). Both
    // photos were taken through that lens at that distance: the side photo's noise is the same
    // floor (side_noise), not the ratio of its residuals to the front's: both sit far below the
    // floor (the front's about 0.01 IOD), and their ratio weighed the side down for what the
    // floor already covers (52 selfie heads: new warped head 5001 1.00 -> 0.96 of the template's
    // error, the mixtures' means within 0.04; docs/benchmarks.md#photo-avatar).
    PhotoOptions near_options = options;
    near_options.landmark_noise = std::max(options.landmark_noise, options.near_landmark_noise);
    near_options.estimate_side_noise = false;
    PhotoFit lens = fit(front, true, near_options);
    if (lens.front.perspective() && 1 / lens.front.kappa >= options.exif_distance &&
        near_options.landmark_noise > options.landmark_noise)
      lens = fit(front, true, options);
    if (lens.front.perspective()) {
      lens.camera_model = "perspective";
      lens.exif_focal = true;
      return lens;
    }
    PhotoLandmarks unknown = front;
    unknown.focal = 0;
    return fit_camera_model(tmpl, unknown, side, options, front_photo, side_photo, start,
                            expressions);
  }
  // Chosen by the evidence: each model's landmark misfit in the orthographic fit's noise (the
  // front's, and the side's relative to it) plus the prior (chi2), and for the perspective one a
  // penalty of ln(residuals) for its extra parameter (the focal length the photos share: the
  // Bayesian information criterion).
  PhotoFit ortho = fit(front, false, options);
  PhotoFit persp = fit(front, true, options);
  const double var = ortho.noise * ortho.noise;
  const double side_var = var * std::max(1.0, ortho.side_noise * ortho.side_noise);
  const double penalty = std::log(static_cast<double>(ortho.residuals));
  const double evidence = chi2(tmpl, ortho, var, side_var, options) -
                          chi2(tmpl, persp, var, side_var, options) - penalty;
  PhotoFit& chosen = evidence > 0 ? persp : ortho;
  chosen.camera_model = evidence > 0 ? "perspective" : "orthographic";
  chosen.camera_evidence = evidence;
  return chosen;
}

}  // namespace

PhotoFit fit_photo_shape(const PhotoTemplate& tmpl, const PhotoLandmarks& front,
                         const PhotoLandmarks* side, const PhotoOptions& options,
                         const render::Image* front_photo, const render::Image* side_photo,
                         const PhotoFit* start) {
  PhotoFit neutral =
      fit_camera_model(tmpl, front, side, options, front_photo, side_photo, start, false);
  if (tmpl.expressions.empty()) return neutral;
  // The expressions (a smile, the mouth open) kept by the evidence, as the camera model is: the
  // misfit in the neutral fit's noise plus the prior, with a penalty of ln(residuals) per weight.
  PhotoFit posed =
      fit_camera_model(tmpl, front, side, options, front_photo, side_photo, start, true);
  const double var = neutral.noise * neutral.noise;
  const double side_var = var * std::max(1.0, neutral.side_noise * neutral.side_noise);
  const double penalty = static_cast<double>(tmpl.expressions.size()) *
                         std::log(static_cast<double>(neutral.residuals));
  const double evidence = chi2(tmpl, neutral, var, side_var, options) -
                          chi2(tmpl, posed, var, side_var, options) - penalty;
  PhotoFit& chosen = evidence > 0 ? posed : neutral;
  chosen.expression_evidence = evidence;
  return chosen;
}

namespace {

// The identity prior N(0, I / alpha), 1 <= alpha <= max_alpha, under which the coefficients'
// evidence is most probable (type-II maximum likelihood, one precision for all modes: MacKay's
// alpha). The evidence is information D about coefficients c_e (D c_e = pull); in D's eigenbasis
// (lambda_i, z = the projected c_e) it is N(z_i; 0, v + 1 / lambda_i) per direction, v = 1 /
// alpha: its log -1/2 sum (ln(v + 1 / lambda_i) + z_i^2 / (v + 1 / lambda_i)) is searched on a
// grid of v in [1 / max_alpha, 1] and refined by golden section.
double evidence_precision(const Eigen::MatrixXd& information, const Eigen::VectorXd& pull,
                          double max_alpha) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(information);
  const Eigen::VectorXd projected = eigen.eigenvectors().transpose() * pull;
  std::vector<std::pair<double, double>> terms;  // 1 / lambda_i, z_i^2
  for (Eigen::Index i = 0; i < projected.size(); ++i)
    if (const double lambda = eigen.eigenvalues()(i); lambda > 1e-9)
      terms.emplace_back(1 / lambda, std::pow(projected(i) / lambda, 2));
  const auto log_evidence = [&](double v) {
    double sum = 0;
    for (const auto& [spread, z2] : terms) sum -= std::log(v + spread) + z2 / (v + spread);
    return sum;
  };
  constexpr int kSteps = 200;
  const double low = 1 / max_alpha, step = (1 - low) / kSteps;
  int best = 0;
  for (int k = 1; k <= kSteps; ++k)
    if (log_evidence(low + k * step) > log_evidence(low + best * step)) best = k;
  double lo = low + std::max(0, best - 1) * step, hi = low + std::min(kSteps, best + 1) * step;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  for (int round = 0; round < 40; ++round) {
    const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
    if (log_evidence(a) >= log_evidence(b))
      hi = b;
    else
      lo = a;
  }
  double v = (lo + hi) / 2;
  for (const double end : {low, 1.0})
    if (log_evidence(end) >= log_evidence(v)) v = end;
  return 1 / v;
}

}  // namespace

void calibrate_posterior(const PhotoTemplate& tmpl, PhotoFit& fit, double scale,
                         double max_precision) {
  const Eigen::Index modes = fit.coefficients.size();
  if ((scale == 1 && max_precision <= 1) || fit.coefficient_covariance.rows() != modes) return;
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(modes, modes);
  // The fit's posterior precision is D + I (D the evidence's information, I the prior's), its
  // mean solves (D + I) c = D c_e. Counted 1 / scale^2 times, D becomes D / scale^2.
  const Eigen::MatrixXd precision = fit.coefficient_covariance.inverse();
  const Eigen::MatrixXd information = (precision - identity) / (scale * scale);
  const Eigen::VectorXd pull = precision * fit.coefficients / (scale * scale);
  const double alpha =
      max_precision > 1 ? evidence_precision(information, pull, max_precision) : 1.0;
  const Eigen::MatrixXd covariance = (information + alpha * identity).inverse();
  const Eigen::VectorXd c = covariance * pull;
  for (std::size_t m = 0; m < tmpl.modes.size(); ++m) {
    const auto move = static_cast<float>(c(static_cast<Eigen::Index>(m)) -
                                         fit.coefficients(static_cast<Eigen::Index>(m))) *
                      tmpl.modes[m];
    fit.positions += move;
    fit.model_positions += move;
  }
  fit.coefficients = c;
  fit.coefficient_covariance = covariance;
  fit.coefficient_sd = fit.coefficient_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  fit.prior_precision = alpha;
}

rig::Positions posed_positions(const PhotoTemplate& tmpl, const PhotoFit& fit) {
  rig::Positions p = fit.positions;
  for (Eigen::Index e = 0; e < fit.expression.size(); ++e)
    if (fit.expression(e) != 0)
      p += static_cast<float>(fit.expression(e)) * tmpl.expressions[static_cast<std::size_t>(e)];
  return p;
}

std::array<Eigen::Vector3d, kLandmarkCount> measure_landmark_bias(const PhotoTemplate& tmpl,
                                                                  const PhotoLandmarks& front,
                                                                  const PhotoLandmarks* side,
                                                                  const PhotoOptions& options) {
  PhotoTemplate plain = tmpl;
  plain.bias = zero_landmark_vectors();
  plain.mode_bias.clear();
  plain.side_bias = zero_landmark_vectors();
  plain.side_mode_bias.clear();
  PhotoOptions o = options;
  o.landmark_noise = 1e6;  // the template's own shape: no identity modes
  // A perspective photo's offsets against a perspective camera (an orthographic one would count
  // the lens's distortion as the detector's).
  const bool perspective = (options.camera == "perspective" || front.focal > 0) &&
                           front.width > 0 && (!side || side->width > 0);
  const PhotoFit fit =
      fit_shape(plain, front, side, o, false, nullptr, nullptr, perspective, nullptr, false);
  std::array<Eigen::Vector3d, kLandmarkCount> out = zero_landmark_vectors();
  for (int k = 0; k < kLandmarkCount; ++k)
    out[static_cast<std::size_t>(k)] = fit.landmark_moves[static_cast<std::size_t>(k)];
  return out;
}

void measure_detector_response(PhotoTemplate& tmpl, const PhotoShootFn& shoot,
                               const PhotoOptions& options, double amplitude,
                               const PhotoDetectFn& detect) {
  const PhotoDetectFn find = detect ? detect : [&](const render::Image& shot, bool side) {
    return detect_photo_landmarks(shot, side ? "template side" : "template front", options);
  };
  using Offsets = std::array<Eigen::Vector3d, kLandmarkCount>;
  // The template, then each mode at +-amplitude.
  std::vector<rig::Positions> heads{tmpl.rig.positions};
  for (const auto& mode : tmpl.modes) {
    heads.push_back(tmpl.rig.positions + static_cast<float>(amplitude) * mode);
    heads.push_back(tmpl.rig.positions - static_cast<float>(amplitude) * mode);
  }
  // Photographed on this thread (a renderer's context is its thread's), each read on another
  // thread as soon as it is taken, while the next is photographed: dlib's detector and predictor
  // take about ten times as long as a render. At most one photo per core is held at a time.
  const std::size_t most = std::max(1u, std::thread::hardware_concurrency());
  // Per photo alone (all 68 points), the offsets on each head: front, side.
  std::vector<std::array<Offsets, 2>> measured(heads.size());
  // Each head's template, copied twice per head: less what a landmark fit without expressions
  // never reads (the rig's shapes and textures, the expressions), most of the whole template.
  PhotoTemplate lean = tmpl;
  lean.rig.shapes.clear();
  lean.rig.textures.clear();
  lean.expressions.clear();
  lean.expression_names.clear();
  std::deque<std::future<void>> reading;  // after `measured`: on a throw, waited for before it goes
  for (std::size_t i = 0; i < heads.size(); ++i) {
    auto shots = shoot(heads[i]);
    if (reading.size() >= most) {
      reading.front().get();
      reading.pop_front();
    }
    reading.push_back(async_within_budget([&, i, shots = std::move(shots)] {
      PhotoTemplate t = lean;
      t.rig.positions = heads[i];
      const auto& [front, side] = shots;
      measured[i] = {measure_landmark_bias(t, find(front, false), nullptr, options),
                     zero_landmark_vectors()};
      if (side.width > 0)
        measured[i][1] = measure_landmark_bias(t, find(side, true), nullptr, options);
    }));
  }
  for (auto& r : reading) r.get();
  // The offsets' model, bias + sum_m mode_bias_m c_m, fitted by least squares to the heads at
  // c = 0 and c = +-amplitude e_m: their c sum to 0, so the bias is the offsets' mean over all of
  // them and mode_bias_m the central difference. The mean over all the photographs (21 with ten
  // modes), not the template's alone, leaves less of one render's chance in the convention
  // (analysis by synthesis on development heads, front + side mixtures: studio 0.36 -> 0.34,
  // window 0.52 -> 0.50; docs/benchmarks.md#photo-avatar).
  tmpl.bias = zero_landmark_vectors();
  tmpl.side_bias = zero_landmark_vectors();
  for (const auto& m : measured)
    for (std::size_t k = 0; k < kLandmarkCount; ++k) {
      tmpl.bias[k] += m[0][k] / static_cast<double>(measured.size());
      tmpl.side_bias[k] += m[1][k] / static_cast<double>(measured.size());
    }
  tmpl.mode_bias.assign(tmpl.modes.size(), zero_landmark_vectors());
  tmpl.side_mode_bias = tmpl.mode_bias;
  for (std::size_t m = 0; m < tmpl.modes.size(); ++m) {
    const auto& plus = measured[1 + 2 * m];
    const auto& minus = measured[2 + 2 * m];
    for (std::size_t k = 0; k < kLandmarkCount; ++k) {
      tmpl.mode_bias[m][k] = (plus[0][k] - minus[0][k]) / (2 * amplitude);
      tmpl.side_mode_bias[m][k] = (plus[1][k] - minus[1][k]) / (2 * amplitude);
    }
  }
}

}  // namespace facecast::rigbuild
