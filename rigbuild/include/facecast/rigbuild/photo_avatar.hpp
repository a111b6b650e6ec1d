#pragma once
// An avatar from photos (docs/algorithms.md#photo-avatar): dlib's 68 landmarks in a front photo
// (and optionally a side photo, turned up to about 45 degrees), a scale-orthographic or
// perspective camera per photo (PhotoCamera; the model chosen by the evidence) estimated jointly
// with the shape (similarity + the template's identity modes by regularised least squares,
// jaw-line points matched to the fit's silhouette, the face's outline to the photos' edges), the
// landmark residuals then moved by an RBF deformation of the whole head (eyes and mouth interior
// carried rigidly), a UV texture baked from the photos blended by the normal (seed 003, section
// 5), and the template's expressions transferred onto the fitted head (build.hpp).
//
// Photos: y down, pixel centres at whole numbers (dlib's convention). Heads face +Z, +Y up.
#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "facecast/core/progress.hpp"
#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/landmarks.hpp"

namespace facecast::rigbuild {

/// One zero vector per landmark.
inline std::array<Eigen::Vector3d, kLandmarkCount> zero_landmark_vectors() {
  std::array<Eigen::Vector3d, kLandmarkCount> a;
  a.fill(Eigen::Vector3d::Zero());
  return a;
}

/// Defaults mirrored in configs/rigbuild/photo.json (load_photo_options).
struct PhotoOptions {
  std::string predictor = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";
  std::string template_path;  // --template default: a template folder or rig file ("" = the
                              // shipped template, ict_facekit.glb)
  int min_face = 80;          // a face box narrower than this (pixels) is "too small"
  int max_side = 640;         // photos are scaled down to this longest side for detection
  /// avatar_from_photos works on photos scaled down to at most this longest side (the landmarks,
  /// the fit, its renders and the texture; the report's landmarks are in the photos' pixels).
  int max_photo_side = 2048;
  /// No face at the detector's threshold (at the working size or twice it): the best-scoring face
  /// above this offset to it (dlib's adjust_threshold; a face turned well aside scores below) is
  /// taken, with a note in the report; 0: none.
  double weak_face_score = -0.5;
  /// No upright face at the threshold: the detector looks at the photo turned by roll_step,
  /// 2 roll_step, ... degrees either way up to max_roll (a tilted head; 0: not).
  double max_roll = 45;
  double roll_step = 15;
  /// The landmarks are predicted again in a view turned upright when their eyes' line is tilted
  /// by more than this many degrees (0: never).
  double level_eyes = 8;
  double box_jitter = 0.06;      // landmarks averaged over face boxes moved by up to this
  int box_steps = 2;             // fraction of their size, in this many steps each way
  int iterations = 8;            // camera / coefficient alternations
  double landmark_noise = 0.02;  // landmark noise, inter-ocular distances: the modes' prior weight
  bool estimate_noise = true;    // ... estimated from the residuals (landmark_noise: its floor)
  bool estimate_group_noise = true;  // ... and per landmark group (jaw, brows, nose, eyes, mouth)
  /// Without a measured detector response in the template: a head in the photo's colours
  /// (calibration_texture) is photographed through the photo's fitted camera, at the template and
  /// moved along each mode; the detector's offsets on it become the bias and its change per mode,
  /// and the shape is fitted again (this many rounds; 0: none).
  int self_calibrate = 1;
  /// What the head wears in those photographs: "painted" (the template itself, a stylised face in
  /// the photo's colours painted where its landmark vertices put the features:
  /// paint_face_texture) or "photo" (the first fit's head wearing the texture baked from the
  /// photo, whose features then sit where the first fit put its landmark vertices).
  std::string calibration_texture = "painted";
  /// ... painted only when the photo's fitted perspective camera is at least this far from the
  /// model's origin (model units, cm; nearer, e.g. a selfie at arm's length: photo), or its EXIF
  /// gives its lens (exif_distance).
  double painted_distance = 100;
  /// The painted template also carries the photo's light: the ratio of the photo to a render of
  /// the flat painted template, fitted over the face as a function of the surface normal
  /// (spherical harmonics to order 2), multiplies its colours.
  bool calibration_light = true;
  /// Those photographs show the photo's background colour behind the head (the median of its top
  /// row and the upper halves of its sides), not the renderer's: dlib traces the jaw line
  /// against it.
  bool calibration_background = true;
  /// The fit after them is followed by a measure of the identity pixel by pixel: the painted head
  /// at its identity and moved along each mode, photographed through its camera before what the
  /// photo shows behind the head, against the front photo (and the side photo's, through its
  /// camera, with appearance_side), both blurred by a Gaussian of appearance_blur face-box widths
  /// (appearance_evidence); each photo's evidence, weighed by appearance_weight, joins a third
  /// fit unless the photo had to move by more than 5 % of the face to match (0: not measured).
  double appearance_weight = 0.01;
  double appearance_blur = 0.08;
  bool appearance_side = true;
  /// With a side photo, the two photos are also compared with each other through the fitted head
  /// (stereo_evidence: where both see the same skin, in linear light, its colour across the
  /// light's, blurred by a Gaussian of stereo_blur face-box widths), the evidence weighed by
  /// stereo_weight joining that third fit unless the side photo had to move by more than 5 % of
  /// the face to match (0: not measured).
  double stereo_weight = 0.01;
  double stereo_blur = 0.02;
  double side_noise = 1.0;          // the side photo's landmark noise relative to the front's
  bool estimate_side_noise = true;  // ... estimated from the residuals (side_noise: its floor)
  bool side_turn = true;            // the side camera = the front's with the head turned (a yaw)
  /// The photos' camera: "orthographic" (scale-orthographic), "perspective" (one unknown focal
  /// length for the photos, the principal point at each one's centre) or "auto" (the one the
  /// evidence picks: fit_photo_shape).
  std::string camera = "auto";
  /// A photo whose EXIF gives its lens (PhotoLandmarks::focal) gets a perspective camera ("auto")
  /// whose focal length has that as its prior, with this standard deviation relative to it, at
  /// any distance.
  double exif_focal_sd = 0.02;
  /// When that camera is nearer than this to the model's origin (model units, cm: a selfie) ...
  double exif_distance = 100;
  /// ... the landmarks' noise floor is this (not below landmark_noise): at arm's length the lens
  /// moves dlib's points more than the analysis by synthesis's renders reproduce (held at
  /// landmark_noise, selfies' coefficients came back 1.7 posterior sd off). The side photo, taken
  /// through the same lens, then keeps side_noise (estimate_side_noise is for far lenses).
  double near_landmark_noise = 0.03;
  /// The template's expression shapes the photos may show (ARKit names; an ICT FaceKit's
  /// name_L / name_R are found by nameLeft / nameRight): fitted with the identity when the
  /// evidence asks for them (fit_photo_shape), left out of the avatar's neutral ([]: none).
  std::vector<std::string> expressions{"jawOpen", "mouthSmileLeft", "mouthSmileRight"};
  double expression_sd = 0.5;     // their weights' prior standard deviation (weights in [0, 1])
  bool side_calibration = false;  // the RBF calibration moves the side photo's residuals too
  bool front_outline = false;     // the fit matches the face's outline to the front photo's edges
  bool side_outline = true;       // ... and to the side photo's
  double outline_noise = 2.0;     // an outline point's noise relative to a front landmark's
  double outline_window = 0.06;   // edges searched this far from the outline, inter-ocular dist.
  double outline_start = 2.5;     // ... times this in the first round, narrowing to it by round 4
  double rbf_smoothing = 1.0;     // RBF regularisation: 0 moves the landmarks exactly
  double rbf_radius = 1.2;        // RBF support radius, in inter-ocular distances of the template
  /// The RBF calibration also moves the analysis-by-synthesis fit's residuals (off: that fit's
  /// head is the identity modes' alone; the first fit, whose head the analysis photographs, keeps
  /// it).
  bool rbf_after_synthesis = false;
  /// With a side photo, the analysis by synthesis fit's posterior made as wide as its errors were
  /// on development heads of known shape (calibrate_posterior): the evidence on the coefficients
  /// counted 1 / posterior_scale^2 times (1: as the fit has it).
  double posterior_scale = 1.56;
  /// After the last fit, the identity prior's precision (one for all modes) chosen by the
  /// evidence between the modes' own (1) and this (calibrate_posterior): a head the photos put
  /// nearer the template than its modes' spread is drawn nearer still (1: the modes' prior).
  double max_prior_precision = 2.0;
  int texture_size = 1024;      // texture height; the width is twice (face and back of head)
  double side_gamma = 1.0;      // blend exponent on the normal's components (1: the seed's)
  bool mask_background = true;  // outside the face, no background or clothes in the texture
  bool shapes = true;           // transfer the template's expressions onto the fitted head
  BuildOptions build;           // that transfer (configs/rigbuild/build.json)
};

/// PhotoOptions from configs/rigbuild/photo.json; throws Error naming the field.
PhotoOptions load_photo_options();

/// Evidence on the identity coefficients c from beyond the landmarks (the photo matched pixel by
/// pixel to renders: appearance_evidence): a Gaussian likelihood, c^T information c - 2 pull^T c
/// added to the fit's chi^2 (empty: none).
struct IdentityEvidence {
  Eigen::MatrixXd information;
  Eigen::VectorXd pull;
  int samples = 0;                                 // photo points it was measured on
  double noise = 0;                                // their residuals' robust spread (0..1)
  Eigen::Vector4d warp = Eigen::Vector4d::Zero();  // the photo's move: pixels x, y, scale, turn
};

/// A template the photo fit works with: the rig (neutral, expressions, materials, UVs), its
/// identity modes (deltas from the neutral, one unit = one standard deviation) and its 68
/// landmark vertices.
struct PhotoTemplate {
  rig::Rig rig;
  std::vector<rig::Positions> modes;
  std::array<int, kLandmarkCount> landmarks{};
  std::vector<char> skin;  // per vertex: on the face or back-of-head surface (textured)
  std::vector<int> rigid;  // per vertex: rigid group (0: follows the RBF; 1.. eyes, mouth)
  /// Where the detector puts each landmark relative to its vertex, in the template's frame (zero:
  /// the template's landmark vertices follow dlib's convention on such photos; see
  /// measure_landmark_bias). Jaw-line points use theirs only when mode_bias is measured; otherwise
  /// they are matched to the fit's silhouette.
  std::array<Eigen::Vector3d, kLandmarkCount> bias = zero_landmark_vectors();
  /// Per identity mode, the bias's change per unit of the mode (empty: the bias is the same for
  /// every identity); see measure_detector_response.
  std::vector<std::array<Eigen::Vector3d, kLandmarkCount>> mode_bias;
  /// The same for side photos (the detector's convention differs on a turned face).
  std::array<Eigen::Vector3d, kLandmarkCount> side_bias = zero_landmark_vectors();
  std::vector<std::array<Eigen::Vector3d, kLandmarkCount>> side_mode_bias;
  /// Expression shapes a photo may show (deltas from the neutral; with_photo_expressions): fitted
  /// beside the modes, never part of the fitted neutral.
  std::vector<rig::Positions> expressions;
  std::vector<std::string> expression_names;  // the rig's own names for them
  IdentityEvidence appearance;  // the photo's pixels on the identity (analysis by synthesis)
};

/// The template to build from: `given` (a --template argument) if not empty, else
/// options.template_path if not empty, else the shipped template (template.hpp).
std::filesystem::path photo_template_path(const PhotoOptions& options, const std::string& given);

/// Reads a template: the ICT FaceKit folder (generic_neutral_mesh.obj, expressions,
/// identity000.obj..), a rig file (.glb/.obj) whose shapes named identity* are the modes, or a
/// compact GLB with its modes in mesh.extras.facecast.identity (the shipped template).
/// Throws Error naming the path when it has no modes or unknown landmarks.
PhotoTemplate load_photo_template(const std::filesystem::path& path);

/// `tmpl` with the expression shapes named in options.expressions that its rig has (ARKit names,
/// or the ICT FaceKit's name_L / name_R for nameLeft / nameRight); the rest are left out.
PhotoTemplate with_photo_expressions(PhotoTemplate tmpl, const PhotoOptions& options);

/// The 68 points dlib finds in a photo (the largest face).
struct PhotoLandmarks {
  std::array<Eigen::Vector2d, kLandmarkCount> points{};
  int faces = 0;                 // faces dlib found (the largest is used)
  double box = 0;                // width of the face box, pixels
  std::array<double, 4> rect{};  // the face box: left, top, right, bottom (pixels)
  std::string note;              // e.g. "3 faces found, the largest used"
  int width = 0, height = 0;     // the photo's size (0: unknown; no perspective camera then)
  double focal = 0;  // the lens's focal length, pixels, from the photo's EXIF (0: unknown)
  double roll = 0;   // degrees the face was turned upright by for the predictor (0: as it stood)
};

/// Reads dlib's face detector and its 68-point predictor (options.predictor) once per process, as
/// the first detect_photo_landmarks would: about a second, which a caller can spend meanwhile on
/// the template. Throws Error naming the predictor's path when it is missing or unreadable.
void load_photo_detector(const PhotoOptions& options);

/// Throws a one-line Error naming `what` when no face is found or it is smaller than min_face.
/// `expected_roll` (degrees): a face is looked for first in the photo turned by this much (a
/// render of a head posed as a photo's, read as that photo was: PhotoLandmarks::roll).
PhotoLandmarks detect_photo_landmarks(const render::Image& photo, const std::string& what,
                                      const PhotoOptions& options, double expected_roll = 0);

/// A photo's camera. Scale-orthographic (kappa = 0): pixel = (s (R p).x + tx, ty - s (R p).y);
/// perspective (kappa > 0, 1 / the camera's distance from the model's origin along its axis):
/// pixel = c + ((t - c) + s ((R p).x, -(R p).y)) / (1 - kappa (R p).z), c the principal point
/// (the photo's centre), so t is still where the origin projects, s the scale there, and the
/// focal length s / kappa pixels. Depth (R p).z grows towards the camera.
struct PhotoCamera {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double s = 1;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  double kappa = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // the principal point (perspective), pixels
  Eigen::Vector2d project(const Eigen::Vector3d& p) const;
  double depth(const Eigen::Vector3d& p) const { return (R * p).z(); }
  /// The camera's axis, towards the camera, in model coordinates.
  Eigen::Vector3d towards() const { return R.row(2).transpose(); }
  /// The direction from p towards the camera (the axis when orthographic).
  Eigen::Vector3d towards(const Eigen::Vector3d& p) const;
  /// The camera's centre in model coordinates (perspective only).
  Eigen::Vector3d eye() const;
  /// d pixel / d p at p, with the pixel's y pointing up (2 x 3).
  Eigen::Matrix<double, 2, 3> jacobian(const Eigen::Vector3d& p) const;
  bool perspective() const { return kappa > 0; }
  /// The focal length in pixels (0: orthographic).
  double focal() const { return kappa > 0 ? s / kappa : 0.0; }
};

/// A renderer camera that shows what `camera` projects onto a width x height photo (an
/// orthographic one: a narrow field of view far away): for rendering the result as the photo saw
/// it.
render::Camera render_camera(const PhotoCamera& camera, const rig::Positions& positions, int width,
                             int height);

struct PhotoFit {
  rig::Positions positions;                // the fitted neutral, template topology
  rig::Positions model_positions;          // the low-dimensional fit only (before the RBF)
  Eigen::VectorXd coefficients;            // identity-mode weights
  Eigen::VectorXd coefficient_sd;          // their posterior standard deviations (the last round's)
  Eigen::MatrixXd coefficient_covariance;  // ... and covariance
  /// Weights of the template's expressions (PhotoTemplate::expressions) the photos show; empty
  /// when the evidence kept the neutral. posed_positions: the head as photographed.
  Eigen::VectorXd expression;
  double expression_evidence = 0;  // chi^2 without - chi^2 with - the penalty (> 0: kept)
  double noise = 0;  // the front landmarks' noise estimated (inter-ocular distances; PhotoOptions)
  /// Each landmark group's noise relative to `noise`: jaw line, brows, nose, eyes, mouth.
  std::array<double, 5> group_noise{1, 1, 1, 1, 1};
  PhotoCamera front;
  std::optional<PhotoCamera> side;
  std::array<int, kLandmarkCount> front_vertex{};  // landmark vertices (jaw: silhouette ones)
  std::array<int, kLandmarkCount> side_vertex{};   // -1 where not used in the side photo
  double front_rms = 0, side_rms = 0;              // landmark residual of the model fit, pixels
  double side_noise = 0;  // the side landmarks' noise relative to the front's that the fit used
  double moved_rms = 0;   // RMS RBF displacement at the landmarks, model units
  /// The landmarks' misfit of the model fit, squared inter-ocular distances, and how many
  /// residuals (two per point) it sums: the camera model's evidence.
  double front_rss = 0, side_rss = 0;
  int residuals = 0;
  /// The cameras' model (PhotoOptions::camera): "orthographic" or "perspective"; and, when chosen
  /// by the evidence, chi^2 (orthographic) - chi^2 (perspective) - the penalty (> 0: perspective).
  std::string camera_model = "orthographic";
  double camera_evidence = 0;
  /// The identity prior's precision the evidence chose (calibrate_posterior; 1: the modes' own).
  double prior_precision = 1;
  /// The front photo's EXIF focal length was the perspective camera's prior.
  bool exif_focal = false;
  /// Per landmark, the calibration's move of its front vertex (model units).
  std::array<Eigen::Vector3d, kLandmarkCount> landmark_moves = zero_landmark_vectors();
};

/// The fitted head as the photos show it: the neutral posed with the fit's expression.
rig::Positions posed_positions(const PhotoTemplate& tmpl, const PhotoFit& fit);

/// The fit's posterior made `scale` times as wide in its evidence (counted 1 / scale^2 times): the
/// coefficients c with posterior covariance C (prior N(0, I)) become (C^-1 + (scale^2 - 1) I)^-1
/// C^-1 c, their covariance scale^2 times that inverse. With max_precision > 1 the prior is then
/// N(0, I / alpha), alpha in [1, max_precision] the one under which the evidence is most probable
/// (type-II maximum likelihood; the fit's prior_precision). Both heads move along the modes by the
/// change. The cameras and the expressions stay as fitted.
void calibrate_posterior(const PhotoTemplate& tmpl, PhotoFit& fit, double scale,
                         double max_precision = 1.0);

/// The side photo's profile points (nose ridge and tip, lip centres, chin) and the near side's
/// eye corners, brow ends, nostril and mouth corner; of these the chin is a silhouette point.
std::vector<int> side_points(const PhotoLandmarks& side);

/// `front_photo`, `side_photo` (optional): the photos the landmarks came from, whose outlines the
/// fit then matches too. With options.camera "auto" both camera models are fitted and the
/// perspective one is kept when chi^2 = RSS_front / sigma^2 + RSS_side / (sigma n_side)^2 + |c|^2
/// (sigma, n_side: the orthographic fit's noises) is lower by more than ln(residuals), the
/// Bayesian information criterion's price of its parameter; landmarks of unknown photo size
/// (PhotoLandmarks::width 0) keep the orthographic camera. A front photo whose EXIF gives its lens
/// (PhotoLandmarks::focal) gets the perspective camera with that focal length as its prior
/// (PhotoFit::exif_focal), with the landmarks' noise floor at options.near_landmark_noise (and
/// the side photo's noise at options.side_noise) when the camera comes out nearer than
/// options.exif_distance. `start` (optional): an earlier fit whose cameras (and side turn) the
/// fit starts from instead of fitting each photo's alone.
PhotoFit fit_photo_shape(const PhotoTemplate& tmpl, const PhotoLandmarks& front,
                         const PhotoLandmarks* side, const PhotoOptions& options,
                         const render::Image* front_photo = nullptr,
                         const render::Image* side_photo = nullptr,
                         const PhotoFit* start = nullptr);

/// The detector's convention on a kind of photo (renders, say): the template itself photographed
/// that way and fitted without identity modes; per landmark the calibration's move, which
/// PhotoTemplate::bias then adds to the landmark's vertex.
std::array<Eigen::Vector3d, kLandmarkCount> measure_landmark_bias(const PhotoTemplate& tmpl,
                                                                  const PhotoLandmarks& front,
                                                                  const PhotoLandmarks* side,
                                                                  const PhotoOptions& options);

/// Photographs a head (template topology) the way the photos are taken: front and side images
/// (an empty side image: no side photo, its response is not measured).
using PhotoShootFn =
    std::function<std::pair<render::Image, render::Image>(const rig::Positions& positions)>;

/// The detector's convention and how it changes with the identity, on a kind of photo: the
/// template and the template moved by +-`amplitude` of each identity mode are photographed and
/// measured (measure_landmark_bias, front and side photo each alone); the bias is the offsets'
/// mean over all those heads and, per mode, its change per unit of the mode the central
/// difference (the least-squares fit of offset = bias + sum_m mode_bias_m c_m to them). Stored in
/// PhotoTemplate::bias, ::mode_bias and the side_* ones. The detector regresses towards its mean
/// face, so it sees a fraction of a shape change; the fit then models what it sees. `detect`
/// (optional) finds the points on a shot (`side`: the side one); by default detect_photo_landmarks.
using PhotoDetectFn = std::function<PhotoLandmarks(const render::Image& shot, bool side)>;
void measure_detector_response(PhotoTemplate& tmpl, const PhotoShootFn& shoot,
                               const PhotoOptions& options, double amplitude = 2.0,
                               const PhotoDetectFn& detect = {});

/// The skin texture (2 N x N, u in [0, 2] as the template's face and back-of-head UV tiles)
/// baked from the photos. `coverage` (optional): fraction of skin texels seen by a photo;
/// `refused` (optional): fraction seen only where a photo shows background (mask_background).
render::Image bake_photo_texture(const PhotoTemplate& tmpl, const PhotoFit& fit,
                                 const render::Image& front, const render::Image* side,
                                 const PhotoOptions& options, double* coverage = nullptr,
                                 double* refused = nullptr);

struct PhotoAvatar {
  rig::Rig rig;  // textured, with the template's expressions transferred
  PhotoFit fit;
  PhotoLandmarks front, side;
  bool has_side = false;
  double texture_coverage = 0;
  double texture_refused = 0;  // skin texels a photo saw only as background (bake_photo_texture)
  /// The photos were worked on scaled by this (max_photo_side): `fit`'s cameras are in the scaled
  /// photos' pixels, `front` and `side` in the photos' own.
  double photo_scale = 1;
  nlohmann::json report;
};

/// The whole pipeline. Throws Error for unusable photos.
PhotoAvatar avatar_from_photos(const PhotoTemplate& tmpl, const render::Image& front,
                               const render::Image* side, const PhotoOptions& options,
                               const ProgressFn& progress = {});

/// The photo with its landmarks drawn (green; red: not used).
render::Image photo_landmark_picture(const render::Image& photo, const PhotoLandmarks& marks,
                                     const std::vector<int>& used = {});

/// Images side by side, top-aligned (black below the shorter ones).
render::Image side_by_side(const std::vector<render::Image>& images);

}  // namespace facecast::rigbuild
