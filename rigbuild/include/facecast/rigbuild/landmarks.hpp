#pragma once
// Automatic facial landmarks on a 3D head (docs/algorithms.md#landmarks): the head's neutral is
// rendered headless from the front and a few turned views, dlib's HOG face detector and 68-point
// shape predictor find the landmarks in each picture, each is lifted onto the skin through a CPU
// z-buffer of the same camera (triangle ids, then the ray through the landmark's pixel cut with
// that triangle), and the views are fused robustly: the median over the views that see a point
// (jaw-line points, which are silhouette points, only from the near-frontal views), then points
// dropped that break the face's mirror symmetry or miss the template's landmarks after the
// similarity fit. The template's 68 landmark vertices paired with the target's nearest skin
// vertices become the registration's markers (correspondence.hpp).
//
// Heads face +Z with +Y up (as the renderer's frame_avatar assumes).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "facecast/render/image.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/geometry.hpp"

namespace facecast::rigbuild {

/// The 68-point layout of dlib (the Multi-PIE / iBUG 300-W markup): 0-16 jaw, 17-26 brows,
/// 27-35 nose, 36-47 eyes, 48-67 lips. "_r" is the subject's right (-x).
inline constexpr int kLandmarkCount = 68;

/// The name a rig stores landmark k under, and marker files use: "dlib_00".."dlib_67".
std::string landmark_name(int k);

/// Defaults mirrored in configs/rigbuild/landmarks.json (load_landmark_options).
struct LandmarkOptions {
  std::string predictor = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";
  int image_size = 400;       // square views, pixels
  float frame_margin = 1.3f;  // the head's box scaled by this in the first, wide view
  double face_fill = 0.5;     // the views are zoomed until the landmarks span this much of them
  std::vector<double> yaws{0, -15, 15, -30, 30};  // view directions, degrees about +Y
  double contour_yaw = 16;      // jaw-line points only from views turned at most this far
  double search_pixels = 6;     // a landmark off the skin takes the nearest skin pixel this close
  double outlier = 0.15;        // drop a point farther than this * the inter-ocular distance from
                                // the template's, after the similarity fit
  double symmetry = 0.15;       // ... or whose mirror image misses its partner by this much
  double eye_bias_limit = 0.5;  // an eye point's template bias longer than this * the template's
                                // eye opening is not applied (a failed detection, no convention)
  bool lid_margins = true;      // a target's lid points go onto its lid margins, and the lids'
                                // middles are paired too (with_lid_middles)
};

/// LandmarkOptions from configs/rigbuild/landmarks.json; throws Error naming the field.
LandmarkOptions load_landmark_options();

/// One rendered view and what dlib found in it.
struct LandmarkView {
  double yaw = 0;  // degrees
  render::Image image;
  bool found = false;
  std::array<Eigen::Vector2d, kLandmarkCount> pixels{};  // dlib's points, image pixels
  std::array<bool, kLandmarkCount> lifted{};             // each landmark reached the skin
};

/// Where detect_landmarks spends its time (seconds): the bench and `rig build` print them.
struct LandmarkTimings {
  double render = 0;   // the views, on the GPU (EGL), read back
  double detect = 0;   // dlib's HOG face detector on the wide view, and the wait for dlib's
                       // models (read once per process, while the views are set up)
  double predict = 0;  // dlib's shape predictor on every view
  double lift = 0;     // the CPU z-buffers and the lifting onto the skin
  double fuse = 0;     // the median over the views, the outlier tests, the nearest vertices
};

struct HeadLandmarks {
  std::vector<LandmarkView> views;
  LandmarkTimings timings;
  Points points;  // 68 by 3, the fused surface points; NaN rows where dropped
  std::array<int, kLandmarkCount> vertex{};  // the nearest skin vertex, or -1 where dropped
  int views_found = 0;
  int dropped = 0;  // landmarks the outlier and symmetry tests removed
};

/// `reference`: the template's landmark positions (68 by 3, NaN rows where unknown) that the
/// target's are checked against; nullptr: no similarity test. `bias` (with a reference): the
/// template's landmark_bias, added to the fused points in the target's frame; then (with
/// options.lid_margins) the lid points move onto the target's lid margins seen from the front.
HeadLandmarks detect_landmarks(const rig::Rig& head, const LandmarkOptions& options,
                               const Points* reference = nullptr, const Points* bias = nullptr);
/// The same with the head's connected components (rig::connected_components) given: its skin is
/// the largest.
HeadLandmarks detect_landmarks(const rig::Rig& head, const rig::Components& components,
                               const LandmarkOptions& options, const Points* reference = nullptr,
                               const Points* bias = nullptr);

/// Where dlib puts a landmark on a render and where the template's own landmark vertex is differ
/// by a convention (the brows of a bald grey head, the lid margins): per landmark, the
/// template's `reference` point minus the point detected on the template (zero where dropped),
/// in the template's frame.
Points landmark_bias(const rig::Rig& tmpl, const Points& reference, const LandmarkOptions& options,
                     LandmarkTimings* timings = nullptr);

/// The rig's 68 landmark vertices: landmarks named "dlib_00".."dlib_67" stored with it, else the
/// entry of configs/rigbuild/template_landmarks.json with its vertex and triangle counts;
/// nullopt when neither knows the rig.
std::optional<std::array<int, kLandmarkCount>> known_landmarks(const rig::Rig& rig);

/// The template's landmark_bias stored in its entry of configs/rigbuild/template_landmarks.json
/// ("bias", 68 rows, template units; computed with the default LandmarkOptions), so a build need
/// not render and detect the template; nullopt when the entry has none.
std::optional<Points> known_landmark_bias(const rig::Rig& rig);

/// The template's 4 lid-middle vertices (right upper, right lower, left upper, left lower): the
/// "lid_middles" of its entry in configs/rigbuild/template_landmarks.json; nullopt without one.
std::optional<std::array<int, 4>> known_lid_middles(const rig::Rig& rig);

/// The automatic landmarks' marker pairs (every name "dlib_NN": found, or found and moved by
/// hand in the web page) with pairs for the middles of the lids added (docs/algorithms.md
/// #landmarks, step 7): each of the template's known_lid_middles, where `registered` (the template
/// registered onto the target with `markers`) puts it along the target's eye, paired with the
/// target's lid margin there; a landmark pair on the same target vertex is dropped. Empty when
/// there is nothing to add: other markers, no lid middles known for the template, an eye's
/// corners missing.
std::vector<MarkerPair> with_lid_middles(const rig::Rig& tmpl, const rig::Rig& target,
                                         const Points& registered,
                                         const std::vector<MarkerPair>& markers);
/// The same with the target's connected components (rig::connected_components) given.
std::vector<MarkerPair> with_lid_middles(const rig::Rig& tmpl, const rig::Rig& target,
                                         const rig::Components& target_components,
                                         const Points& registered,
                                         const std::vector<MarkerPair>& markers);

/// The template's landmarks as marker pairs with the target's detected ones ("dlib_NN"), the
/// landmarks dropped on either side left out. Throws Error when fewer than 8 remain.
std::vector<MarkerPair> landmark_markers(const std::array<int, kLandmarkCount>& template_vertices,
                                         const HeadLandmarks& target);

/// Markers for a template and a target of another topology: the template's known landmarks (or
/// detected on it), the target's detected. Throws a one-line Error when no face is found.
struct AutoMarkers {
  std::vector<MarkerPair> markers;
  HeadLandmarks target;
  std::array<int, kLandmarkCount> template_vertices{};
  double seconds = 0;                // the views, detection and fusion
  LandmarkTimings template_timings;  // the template's side (its bias, its landmarks if unknown)
};
AutoMarkers auto_markers(const rig::Rig& tmpl, const rig::Rig& target,
                         const LandmarkOptions& options);
/// The same with the target's connected components (rig::connected_components) given.
AutoMarkers auto_markers(const rig::Rig& tmpl, const rig::Rig& target,
                         const rig::Components& target_components, const LandmarkOptions& options);

/// The marker JSON format of ../shared/data/markers (index_base 0; read_markers reads it).
/// Atomic.
void write_markers_json(const std::filesystem::path& path, const std::vector<MarkerPair>& markers);

/// The views side by side, each with its detected points (green: used, red: not lifted).
render::Image landmark_picture(const HeadLandmarks& landmarks);

}  // namespace facecast::rigbuild
