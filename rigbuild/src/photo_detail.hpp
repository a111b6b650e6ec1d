#pragma once
// Private pieces of the photo avatar (docs/algorithms.md#photo-avatar): the camera fit, the RBF
// calibration and the depth buffer, shared by photo_*.cpp and the tests of rigbuild's stages.
#include <array>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include "facecast/rigbuild/photo_avatar.hpp"

namespace facecast::rigbuild {

/// Scale-orthographic camera closest to `pixels` (photo coordinates) = projection of `points`:
/// the affine camera by least squares, its 2x3 part replaced by the nearest scaled pair of
/// orthonormal rows (SVD), then scale and translation refitted.
PhotoCamera fit_ortho_camera(const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector2d>& pixels);

/// One exact-displacement constraint of the calibration: vertex `vertex` moves by `move`.
struct RbfCentre {
  int vertex = 0;
  Eigen::Vector3d move = Eigen::Vector3d::Zero();
};

/// Moves `positions` by the Wendland-RBF field that interpolates the centres' moves (centres
/// closer than `merge` are merged, their moves averaged); vertices of a rigid group (> 0) move by
/// the field's mean over the group. `radius`: the kernel's support. `smoothing` (lambda >= 0):
/// the kernel matrix K + lambda I, so the field approximates the moves (an isolated centre moves
/// by 1 / (1 + lambda) of its move) instead of interpolating them exactly (lambda = 0).
void rbf_deform(rig::Positions& positions, const std::vector<RbfCentre>& centres,
                const std::vector<int>& rigid, double radius, double merge, double smoothing = 0);

/// A mesh's depth seen through a photo's camera, per photo pixel (larger = nearer): the texture's
/// visibility test and the fit's outer outline.
struct DepthBuffer {
  static constexpr float kEmpty = -std::numeric_limits<float>::max();  // no triangle there
  int w = 0, h = 0;
  std::vector<float> depth;  // w * h, rows from the top
  DepthBuffer(const rig::Positions& positions, const Triangles& triangles,
              const PhotoCamera& camera, int width, int height);
  /// Depth z at the pixel nearest `at` is not behind the mesh by more than `tolerance`.
  bool visible(const Eigen::Vector2d& at, double z, double tolerance) const;
  /// A triangle covers the pixel nearest `at`.
  bool covered(const Eigen::Vector2d& at) const;

 private:
  std::ptrdiff_t pixel(const Eigen::Vector2d& at) const;  // index of the nearest pixel, -1: outside
};

/// Pixels of a w x h image (rows from the top) not `done` take the colour of the nearest one that
/// is (breadth-first, 4-connected), and become done.
void fill_unseen(std::vector<Eigen::Vector3f>& colour, std::vector<char>& done, int w, int h);

/// Calls f(texel index, surface point, unit normal) for every texel of a w x h texture (u scaled
/// by 1 / `tiles`) that a skin triangle of `positions` covers.
void for_each_skin_texel(
    const PhotoTemplate& tmpl, const rig::Positions& positions, int w, int h, int tiles,
    const std::function<void(std::size_t, const Eigen::Vector3d&, const Eigen::Vector3d&)>& f);

/// The photo's light on the face relative to the renderer's: per channel, the ratio of the photo
/// to a render of the painted template as a function of the surface normal n (the head's frame),
/// in real spherical harmonics up to order 2 (Ramamoorthi and Hanrahan's irradiance basis).
struct FaceLight {
  Eigen::Matrix<double, 3, 9> coefficients = Eigen::Matrix<double, 3, 9>::Zero();
  int samples = 0;                   // skin points it was fitted on
  Eigen::Vector3d towards{0, 0, 1};  // the render's camera axis (the normals it saw face it)
  /// The ratio per channel at normal n, kept within [0.25, 4].
  Eigen::Vector3d operator()(const Eigen::Vector3d& n) const;
};

/// Fits FaceLight: at the template's skin vertices on the face (facing both cameras, away from
/// the brows, eyes, nostrils and lips), the photo where `fit` (through `photo_camera`) puts the
/// vertex against `render` (the painted template through `render_camera`), robustly (Tukey); a
/// channel the photo clips (kSaturated) is left out of that channel's fit where it is.
FaceLight fit_face_light(const PhotoTemplate& tmpl, const render::Image& photo, const PhotoFit& fit,
                         const PhotoCamera& photo_camera, const render::Image& render,
                         const PhotoCamera& render_camera);

/// A stylised face on the template's skin (2 N x N, as bake_photo_texture's), its features where
/// the template's landmark vertices put them (brows along 17-21 and 22-26, lips along the outer
/// lip contour and across the mouth), in the colours the photo shows at dlib's points (`marks`):
/// analysis by synthesis's renders (a texture baked from the photo through the first fit would
/// carry that fit's landmark errors into the renders, and the detector would find its own points
/// again).
/// `light`, when given, multiplies each texel's colour by light(n), n its normal (FaceLight).
render::Image paint_face_texture(const PhotoTemplate& tmpl, const render::Image& photo,
                                 const PhotoLandmarks& marks, int n,
                                 const FaceLight* light = nullptr);

/// `positions` on the template's topology as a rig without shapes, its skin materials sampling
/// `texture` (2 N x N: u scaled onto the skin's UV tiles).
rig::Rig textured_head(const PhotoTemplate& tmpl, const rig::Positions& positions,
                       const render::Image& texture);

/// The eyes of `rig` (textured_head's): the template's irises sit behind its cornea (the front
/// bulge of the sclera's material), so a render shows white eyes. Per eye (a rigid group), the
/// outer shell's triangles within 29 degrees of the eyeball's axis take an iris material, within
/// 9 a pupil's (the eyeball a sphere fitted to the shell, its axis through the shell's foremost
/// vertex); the iris's colour is the front photo's where it sees the eye, else a mid brown.
/// Returns, per eye, what it painted (the report's "eyes").
nlohmann::json paint_eyes(rig::Rig& rig, const PhotoTemplate& tmpl, const PhotoFit& fit,
                          const render::Image& front);

/// A render read at an AppearanceGrid's points: 3 values per point (0..1), and the share of each
/// point's blur that shows the head.
struct AppearanceShot {
  Eigen::VectorXd colour, head;
};

/// Where a photo is compared with renders pixel by pixel (appearance_evidence): a grid over
/// dlib's face box and around it, every 2 sigma pixels, read blurred by a Gaussian of sigma; points
/// within 0.15 IOD of dlib's brows, eyes, nostrils and lips are left out.
struct AppearanceGrid {
  AppearanceGrid(const PhotoLandmarks& marks, double sigma_fraction);
  double sigma = 1;                     // pixels: sigma_fraction of the face box's width
  double box = 1;                       // the face box's width, pixels
  Eigen::Vector2d centre;               // the face box's centre
  std::vector<Eigen::Vector2d> points;  // photo pixels
  /// The renders' background colour (their pixels of it are not the head) and what the photo
  /// shows behind the head in its place (empty: the renders' own pixels).
  std::optional<std::array<int, 3>> behind;
  render::Image backdrop;
  /// The renders' background: `shot`'s corner pixel's colour; the backdrop: the photo away from
  /// the head `shot` shows, filled in towards it and under it from there.
  void set_backdrop(const render::Image& photo, const render::Image& shot);
  /// A render (the photo's size) at the points, its background replaced by the backdrop.
  AppearanceShot read(const render::Image& render) const;
};

/// The photo matched to renders of a head in its colours and light through its camera: `shots`
/// (AppearanceGrid::read) of the head, then moved by +amplitude and -amplitude along each identity
/// mode in turn. Their differences give how the picture changes per mode; the photo less the
/// head's render, a per channel gain and offset and a small similarity move of the photo solved
/// with it (Tukey-weighted), measures the identity. Points no render shows the head at are left
/// out. `weight` scales the evidence (the blurred samples are not independent). The evidence is on
/// the identity's change from the first shot's (its pull: for the change; add information times
/// the shot's coefficients for c).
IdentityEvidence appearance_evidence(const AppearanceGrid& grid, const render::Image& photo,
                                     const std::vector<AppearanceShot>& shots, double amplitude,
                                     double weight);

/// The two photos against each other (multi-view photo-consistency): a point of the head that
/// both photos see shows the same skin in each, so where the fitted head puts it in the front
/// photo and in the side photo their colours agree. Where the identity moves the skin towards or
/// away from the cameras it moves the two readings apart: evidence on the identity that passes
/// through neither a detector's convention nor a painted head. The photos are read in linear
/// light, as the two colour components across the light's own (white) colour (a highlight adds
/// the light's colour and moves neither), blurred by a Gaussian of sigma_fraction face-box widths,
/// the side photo's carried over the same patch of skin. Solved with the identity, Tukey-weighted,
/// and profiled out: a gain and offset per component varying over the face, the lens (kappa, the
/// cameras re-projected), the head's small move (within a couple of degrees and pixels of the
/// fitted pose) and the side camera's (rotation, shift, scale). `weight` scales the evidence
/// (neighbouring samples are not independent). The points are skin vertices of `at` (the head at
/// the fit's identity, as photographed) facing both cameras with the blur's reach unhidden in
/// either, one per 2 sigma of the front photo over dlib's face box. The evidence is on the
/// identity's change from `at`'s (add information times its coefficients for c); its warp is the
/// side photo's move (pixels x, y, scale, turn).
IdentityEvidence stereo_evidence(const PhotoTemplate& tmpl, const rig::Positions& at,
                                 const PhotoLandmarks& marks, const render::Image& front,
                                 const PhotoCamera& front_camera, const render::Image& side,
                                 const PhotoCamera& side_camera, double sigma_fraction,
                                 double weight);

}  // namespace facecast::rigbuild
