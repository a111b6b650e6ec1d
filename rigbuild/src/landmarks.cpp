// Automatic facial landmarks: dlib on rendered views, lifted and fused. See
// docs/algorithms.md#landmarks.
#include "facecast/rigbuild/landmarks.hpp"

#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <istream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <streambuf>

#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"
#include "geometry.hpp"
#include "landmark_views.hpp"
#include "lid_margins.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Mirror pairs of the 68-point layout: (subject's right, subject's left).
constexpr std::array<std::array<int, 2>, 29> kMirror = {{
    {0, 16},  {1, 15},  {2, 14},  {3, 13},  {4, 12},  {5, 11},  {6, 10},  {7, 9},
    {17, 26}, {18, 25}, {19, 24}, {20, 23}, {21, 22}, {31, 35}, {32, 34}, {36, 45},
    {37, 44}, {38, 43}, {39, 42}, {40, 47}, {41, 46}, {48, 54}, {49, 53}, {50, 52},
    {59, 55}, {58, 56}, {60, 64}, {61, 63}, {67, 65},
}};

// Adds the time since the last call (or construction) to the slot named.
class Lap {
 public:
  void operator()(double& slot) {
    const auto now = std::chrono::steady_clock::now();
    slot += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

bool is_jaw(int k) {
  return k <= 16;
}

}  // namespace

namespace detail {
// dlib's detector serialized uncompressed at build time (tools/face_detector_gen.cpp).
extern const unsigned char kFaceDetector[];
extern const std::size_t kFaceDetectorSize;
}  // namespace detail

// Read from the build's uncompressed copy in a few milliseconds (dlib's own compressed copy,
// get_frontal_face_detector, takes 0.3 s): once per process, copied per use or per thread (its
// operator() is not const).
const dlib::frontal_face_detector& face_detector() {
  static const dlib::frontal_face_detector prototype = [] {
    struct Bytes : std::streambuf {
      Bytes(const unsigned char* p, std::size_t n) {
        char* c = const_cast<char*>(reinterpret_cast<const char*>(p));  // read only
        setg(c, c, c + n);
      }
    } bytes(detail::kFaceDetector, detail::kFaceDetectorSize);
    std::istream in(&bytes);
    dlib::frontal_face_detector d;
    dlib::deserialize(d, in);
    return d;
  }();
  return prototype;
}

// The shape predictor, read once per path (about 100 MB); shared by every thread (its operator()
// is const).
const dlib::shape_predictor& shape_predictor(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<dlib::shape_predictor>> cache;
  std::lock_guard lock(mutex);
  auto& slot = cache[path];
  if (!slot) {
    if (!std::filesystem::exists(path))
      throw Error(path + ": dlib's 68-point shape predictor is missing (Debian: libdlib-data)");
    auto sp = std::make_unique<dlib::shape_predictor>();
    try {
      dlib::deserialize(path) >> *sp;
    } catch (const std::exception& e) {
      throw Error(path + ": not a dlib shape predictor (" + std::string(e.what()).substr(0, 80) +
                  ")");
    }
    slot = std::move(sp);
  }
  return *slot;
}

namespace {

dlib::array2d<dlib::rgb_pixel> to_dlib(const render::Image& image) {
  dlib::array2d<dlib::rgb_pixel> img(image.height, image.width);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      img[y][x] = dlib::rgb_pixel(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
  return img;
}

// dlib's largest face in `image` (the HOG scan over the pyramid: tens of milliseconds on a
// 400 px view, so it runs on the wide view only).
std::optional<dlib::rectangle> find_face(const dlib::array2d<dlib::rgb_pixel>& img) {
  dlib::frontal_face_detector detector = face_detector();
  const std::vector<dlib::rectangle> faces = detector(img);
  if (faces.empty()) return std::nullopt;
  return *std::max_element(faces.begin(), faces.end(),
                           [](const auto& a, const auto& b) { return a.area() < b.area(); });
}

// The 68 points of the face in `box` (a few milliseconds).
void predict(const dlib::array2d<dlib::rgb_pixel>& img, const dlib::shape_predictor& sp,
             const dlib::rectangle& box, std::array<Eigen::Vector2d, kLandmarkCount>& points) {
  const dlib::full_object_detection shape = sp(img, box);
  for (int k = 0; k < kLandmarkCount; ++k)
    points[static_cast<std::size_t>(k)] = {static_cast<double>(shape.part(k).x()),
                                           static_cast<double>(shape.part(k).y())};
}

// Drops, one at a time (the worst first), the points farther than `limit` from the reference
// after the similarity fit; fills `residual` from the last fit.
int drop_by_similarity(const Points& reference, double limit, Points& points,
                       std::vector<double>& residual) {
  int dropped = 0;
  for (;;) {
    std::vector<int> both;
    for (int k = 0; k < kLandmarkCount; ++k)
      if (has_point(points, k) && has_point(reference, k)) both.push_back(k);
    if (both.size() < 4) return dropped;
    Points from(static_cast<Eigen::Index>(both.size()), 3), to(from.rows(), 3);
    for (std::size_t i = 0; i < both.size(); ++i) {
      from.row(static_cast<Eigen::Index>(i)) = reference.row(both[i]);
      to.row(static_cast<Eigen::Index>(i)) = points.row(both[i]);
    }
    const Similarity s = procrustes(from, to, true);
    int worst = -1;
    residual.assign(kLandmarkCount, 0.0);
    for (int k : both) {
      residual[static_cast<std::size_t>(k)] =
          (s.apply(Eigen::RowVector3d(reference.row(k))) - points.row(k)).norm();
      if (worst < 0 ||
          residual[static_cast<std::size_t>(k)] > residual[static_cast<std::size_t>(worst)])
        worst = k;
    }
    if (worst < 0 || residual[static_cast<std::size_t>(worst)] <= limit) return dropped;
    points.row(worst).setConstant(kNaN);
    ++dropped;
  }
}

// Mirror plane of the fused points (normal: the mean right-to-left direction of the mirror
// pairs; offset: the median of their midpoints); drops the point of each pair whose mirror
// image misses its partner by more than `limit` -- the one with the larger similarity residual,
// or both without a reference.
int drop_by_symmetry(double limit, const std::vector<double>& residual, Points& points) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  std::vector<std::array<int, 2>> pairs;
  for (const auto& [r, l] : kMirror) {
    if (!has_point(points, r) || !has_point(points, l)) continue;
    n += (points.row(l) - points.row(r)).transpose().normalized();
    pairs.push_back({r, l});
  }
  if (pairs.size() < 4 || n.norm() < 1e-12) return 0;
  n.normalize();
  std::vector<double> mids;
  for (const auto& [r, l] : pairs)
    mids.push_back(0.5 * n.dot((points.row(r) + points.row(l)).transpose()));
  const double d = median(mids);
  std::vector<int> drop;
  for (const auto& [r, l] : pairs) {
    const Eigen::Vector3d pr = points.row(r).transpose();
    const Eigen::Vector3d mirrored = pr - 2 * (n.dot(pr) - d) * n;
    if ((mirrored - points.row(l).transpose()).norm() <= limit) continue;
    const double er = residual.empty() ? 0 : residual[static_cast<std::size_t>(r)];
    const double el = residual.empty() ? 0 : residual[static_cast<std::size_t>(l)];
    if (residual.empty() || er >= el) drop.push_back(r);
    if (residual.empty() || el >= er) drop.push_back(l);
  }
  for (int k : drop) points.row(k).setConstant(kNaN);
  return static_cast<int>(drop.size());
}

// The template's eye opening: the mean distance of its upper and lower lid points (37-41, 38-40,
// 43-47, 44-46); 0 when it has none of them.
double eye_opening(const Points& reference) {
  double sum = 0;
  int n = 0;
  for (auto [upper, lower] : {std::pair{37, 41}, {38, 40}, {43, 47}, {44, 46}}) {
    if (!has_point(reference, upper) || !has_point(reference, lower)) continue;
    sum += (reference.row(upper) - reference.row(lower)).norm();
    ++n;
  }
  return n ? sum / n : 0.0;
}

// Each point moved by the template's bias carried into the target's frame: the rotation and
// scale of the similarity fitted from the reference onto the points. An eye point whose bias is
// more than `eye_limit` times the template's eye opening is left as found: no convention moves a
// lid point by most of the opening; the detector failed on the template there (the raw ICT
// FaceKit's eye-occlusion layers, opaque in these renders, cover its eyes), and carried over,
// that bias lifted the MakeHuman head's lid points onto the upper lid (docs/algorithms.md
// #landmarks, step 5).
void apply_bias(const Points& reference, const Points& bias, double eye_limit, Points& points) {
  const double opening = eye_opening(reference);
  std::vector<int> both;
  for (int k = 0; k < kLandmarkCount; ++k)
    if (has_point(points, k) && has_point(reference, k)) both.push_back(k);
  if (both.size() < 4) return;
  Points from(static_cast<Eigen::Index>(both.size()), 3), to(from.rows(), 3);
  for (std::size_t i = 0; i < both.size(); ++i) {
    from.row(static_cast<Eigen::Index>(i)) = reference.row(both[i]);
    to.row(static_cast<Eigen::Index>(i)) = points.row(both[i]);
  }
  const Similarity s = procrustes(from, to, true);
  for (int k = 0; k < kLandmarkCount; ++k)
    if (has_point(points, k) && has_point(bias, k) &&
        !(k >= 36 && k <= 47 && opening > 0 && bias.row(k).norm() > eye_limit * opening))
      points.row(k) += (s.scale * s.R * bias.row(k).transpose()).transpose();
}

// Per landmark, the median of its lifted points over the views that may show it.
Points fuse(const std::vector<LandmarkView>& views,
            const std::vector<std::array<Eigen::RowVector3d, kLandmarkCount>>& lifted,
            double contour_yaw) {
  Points out(kLandmarkCount, 3);
  for (int k = 0; k < kLandmarkCount; ++k) {
    std::array<std::vector<double>, 3> c;
    for (std::size_t v = 0; v < views.size(); ++v) {
      if (!views[v].found || !views[v].lifted[static_cast<std::size_t>(k)]) continue;
      if (is_jaw(k) && std::abs(views[v].yaw) > contour_yaw) continue;
      for (int i = 0; i < 3; ++i)
        c[static_cast<std::size_t>(i)].push_back(lifted[v][static_cast<std::size_t>(k)][i]);
    }
    for (int i = 0; i < 3; ++i)
      out(k, i) = c[0].empty() ? kNaN : median(c[static_cast<std::size_t>(i)]);
  }
  return out;
}

// A camera far in front of the head (+Z, +Y up: the views' convention), nearly orthographic.
render::Camera front_of(const rig::Rig& head) {
  render::Camera c;
  c.target = head.positions.colwise().mean().transpose();
  const float size =
      (head.positions.colwise().maxCoeff() - head.positions.colwise().minCoeff()).norm();
  c.eye = c.target + Eigen::Vector3f(0, 0, 100 * size);
  return c;
}

}  // namespace

HeadLandmarks detect_landmarks(const rig::Rig& head, const LandmarkOptions& options,
                               const Points* reference, const Points* bias) {
  return detect_landmarks(head, rig::connected_components(head.vertex_count(), head.triangles),
                          options, reference, bias);
}

HeadLandmarks detect_landmarks(const rig::Rig& head, const rig::Components& comps,
                               const LandmarkOptions& options, const Points* reference,
                               const Points* bias) {
  check_components(comps, head.vertex_count(), "landmarks: components");
  if (options.image_size < 64 || options.image_size > 4096)
    throw Error("landmarks: image_size " + std::to_string(options.image_size) +
                " out of range (64..4096)");
  // dlib's models are read (once per process) while the views are set up.
  auto models = async_within_budget([&] {
    face_detector();
    return &shape_predictor(options.predictor);
  });
  // The neutral alone (the renderer takes at most 256 shapes; the views need none).
  rig::Rig neutral = head;
  neutral.shapes.clear();
  // Matte: specular highlights move with the view and read as edges to the detector.
  for (auto& m : neutral.materials) {
    m.roughness = 1.0f;
    m.metallic = 0.0f;
  }
  render::RenderOptions ro;
  ro.width = ro.height = options.image_size;
  ro.margin = options.frame_margin;
  ro.contexts = 1;
  // The detector's views: quality over speed, and the exact sRGB curve (the stored biases are
  // from these renders, and dlib's landmarks move with their last bits).
  ro.trilinear = true;
  ro.fast_srgb = false;
  ro.lod_pixels = 0;  // the mesh itself
  ro.background = Eigen::Vector3f(0.05f, 0.05f, 0.05f);
  Lap lap;
  HeadLandmarks out;
  auto& time = out.timings;
  render::Renderer renderer(neutral, ro);
  lap(time.render);

  const Points rest = rig::to_points(head.positions);
  std::vector<char> skin(static_cast<std::size_t>(head.triangle_count()));
  for (int t = 0; t < head.triangle_count(); ++t)
    skin[static_cast<std::size_t>(t)] =
        comps.label[static_cast<std::size_t>(head.triangles(t, 0))] == comps.largest;
  const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
  // The face framed: found in a wide frontal view, then filling face_fill of the image. The
  // detector's box, zoomed with the view, starts the shape predictor in every view (the views
  // orbit the face's centre, so the face stays there).
  const render::Camera wide = wide_camera(head, options.frame_margin, options.image_size);
  render::Camera front = wide;
  dlib::rectangle box;
  const dlib::shape_predictor* sp = nullptr;
  {
    renderer.set_camera(wide);
    lap(time.lift);
    render::Image image = renderer.render({});
    lap(time.render);
    const auto img = to_dlib(image);
    sp = models.get();
    const auto face = find_face(img);
    lap(time.detect);
    if (!face) {
      out.views.push_back({0.0, std::move(image), false, {}, {}});
      out.points = Points::Constant(kLandmarkCount, 3, kNaN);
      out.vertex.fill(-1);
      return out;
    }
    std::array<Eigen::Vector2d, kLandmarkCount> px;
    predict(img, *sp, *face, px);
    lap(time.predict);
    Eigen::Vector2d lo = px[0], hi = px[0];
    for (const auto& p : px) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const SkinBuffer buffer(rest, head.triangles, skin, wide, options.image_size, 0.02 * diagonal);
    const Eigen::Vector2d mid = 0.5 * (lo + hi);
    const auto centre = buffer.lift(mid, 0.25 * (hi - lo).minCoeff());
    double zoom = 1;
    Eigen::Vector2d from = Eigen::Vector2d::Constant(0.5 * options.image_size);
    if (centre) {
      zoom = options.face_fill * options.image_size / (hi - lo).maxCoeff();
      front = face_camera(wide, centre->transpose(), zoom);
      from = mid;
    }
    const auto zoomed = [&](double x, double y) {
      return Eigen::Vector2d(0.5 * options.image_size + zoom * (x - from.x()),
                             0.5 * options.image_size + zoom * (y - from.y()));
    };
    const Eigen::Vector2d a = zoomed(face->left(), face->top()),
                          b = zoomed(face->right(), face->bottom());
    box = dlib::rectangle(std::lround(a.x()), std::lround(a.y()), std::lround(b.x()),
                          std::lround(b.y()));
  }
  std::vector<std::array<Eigen::RowVector3d, kLandmarkCount>> lifted;
  for (double yaw : options.yaws) {
    LandmarkView view;
    view.yaw = yaw;
    const render::Camera camera = orbit(front, yaw);
    renderer.set_camera(camera);
    lap(time.lift);
    view.image = renderer.render({});
    lap(time.render);
    predict(to_dlib(view.image), *sp, box, view.pixels);
    lap(time.predict);
    view.found = true;
    ++out.views_found;
    auto& points = lifted.emplace_back();
    const SkinBuffer buffer(rest, head.triangles, skin, camera, options.image_size,
                            0.02 * diagonal);
    for (int k = 0; k < kLandmarkCount; ++k) {
      const auto p = buffer.lift(view.pixels[static_cast<std::size_t>(k)], options.search_pixels);
      view.lifted[static_cast<std::size_t>(k)] = p.has_value();
      if (p) points[static_cast<std::size_t>(k)] = *p;
    }
    out.views.push_back(std::move(view));
  }
  lap(time.lift);
  out.points = fuse(out.views, lifted, options.contour_yaw);
  out.vertex.fill(-1);

  const double iod = has_point(out.points, 36) && has_point(out.points, 45)
                         ? (out.points.row(36) - out.points.row(45)).norm()
                         : 0.25 * diagonal;
  std::vector<double> residual;
  if (reference && bias) apply_bias(*reference, *bias, options.eye_bias_limit, out.points);
  if (reference)
    out.dropped += drop_by_similarity(*reference, options.outlier * iod, out.points, residual);
  out.dropped += drop_by_symmetry(options.symmetry * iod, residual, out.points);
  if (reference && bias && options.lid_margins) LidMargins(head, comps, front).snap(out.points);

  // Each fused point's nearest skin vertex.
  for (int k = 0; k < kLandmarkCount; ++k) {
    if (!has_point(out.points, k)) continue;
    double best = std::numeric_limits<double>::infinity();
    for (int v = 0; v < head.vertex_count(); ++v) {
      if (comps.label[static_cast<std::size_t>(v)] != comps.largest) continue;
      const double d = (rest.row(v) - out.points.row(k)).squaredNorm();
      if (d < best) {
        best = d;
        out.vertex[static_cast<std::size_t>(k)] = v;
      }
    }
  }
  lap(time.fuse);
  return out;
}

std::vector<MarkerPair> landmark_markers(const std::array<int, kLandmarkCount>& template_vertices,
                                         const HeadLandmarks& target) {
  std::vector<MarkerPair> out;
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int a = template_vertices[static_cast<std::size_t>(k)];
    const int b = target.vertex[static_cast<std::size_t>(k)];
    if (a < 0 || b < 0) continue;
    out.push_back({landmark_name(k), a, b});
  }
  if (out.size() < 8)
    throw Error("landmarks: only " + std::to_string(out.size()) +
                " of 68 landmarks agree with the template's; give --markers");
  return out;
}

std::vector<MarkerPair> with_lid_middles(const rig::Rig& tmpl, const rig::Rig& target,
                                         const Points& registered,
                                         const std::vector<MarkerPair>& markers) {
  return with_lid_middles(tmpl, target,
                          rig::connected_components(target.vertex_count(), target.triangles),
                          registered, markers);
}

std::vector<MarkerPair> with_lid_middles(const rig::Rig& tmpl, const rig::Rig& target,
                                         const rig::Components& target_components,
                                         const Points& registered,
                                         const std::vector<MarkerPair>& markers) {
  check_components(target_components, target.vertex_count(), "lid middles: target components");
  const auto middles = known_lid_middles(tmpl);
  if (!middles) return {};
  Points at = Points::Constant(kLandmarkCount, 3, kNaN);  // the landmarks' target vertices
  for (const MarkerPair& m : markers) {
    int k = -1;
    if (std::sscanf(m.name.c_str(), "dlib_%d", &k) != 1 || k < 0 || k >= kLandmarkCount)
      return {};  // not (only) the automatic landmarks' pairs
    at.row(k) = target.positions.row(m.target_vertex).cast<double>();
  }
  const LidMargins lids(target, target_components, front_of(target));
  const char* names[4] = {"lid_r_upper_mid", "lid_r_lower_mid", "lid_l_upper_mid",
                          "lid_l_lower_mid"};
  std::vector<MarkerPair> added;
  for (std::size_t i = 0; i < 4; ++i) {
    const auto f = lids.frame(at, LidMargins::kEyes[i / 2]);
    if (f.width <= 0) continue;
    const int v = lids.margin(f, i % 2 ? -1 : 1, registered.row((*middles)[i]).transpose());
    if (v >= 0) added.push_back({names[i], (*middles)[i], v});
  }
  if (added.empty()) return {};
  // A landmark on a middle's vertex was put there by dlib's narrower eye: the middle wins.
  std::vector<MarkerPair> out;
  for (const MarkerPair& m : markers)
    if (std::none_of(added.begin(), added.end(),
                     [&](const MarkerPair& a) { return a.target_vertex == m.target_vertex; }))
      out.push_back(m);
  out.insert(out.end(), added.begin(), added.end());
  return out;
}

Points landmark_bias(const rig::Rig& tmpl, const Points& reference, const LandmarkOptions& options,
                     LandmarkTimings* timings) {
  const HeadLandmarks found = detect_landmarks(tmpl, options, &reference);
  if (timings) *timings = found.timings;
  Points bias = reference - found.points;
  for (int k = 0; k < kLandmarkCount; ++k)
    if (!has_point(bias, k)) bias.row(k).setZero();
  return bias;
}

AutoMarkers auto_markers(const rig::Rig& tmpl, const rig::Rig& target,
                         const LandmarkOptions& options) {
  return auto_markers(tmpl, target,
                      rig::connected_components(target.vertex_count(), target.triangles), options);
}

AutoMarkers auto_markers(const rig::Rig& tmpl, const rig::Rig& target,
                         const rig::Components& target_components, const LandmarkOptions& options) {
  const OpenMpWithinBudget omp_threads;  // Eigen's regions, within the budget
  AutoMarkers out;
  if (const auto known = known_landmarks(tmpl)) {
    out.template_vertices = *known;
  } else {
    const HeadLandmarks t = detect_landmarks(tmpl, options);
    out.template_timings = t.timings;
    if (t.views_found == 0)
      throw Error(
          "template: no face found in its " + std::to_string(t.views.size()) +
          " rendered views, and it has no stored landmarks (dlib_00..dlib_67); give --markers");
    out.template_vertices = t.vertex;
  }
  Points reference(kLandmarkCount, 3);
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int v = out.template_vertices[static_cast<std::size_t>(k)];
    if (v >= 0 && v < tmpl.vertex_count())
      reference.row(k) = tmpl.positions.row(v).cast<double>();
    else
      reference.row(k).setConstant(kNaN);
  }
  const std::optional<Points> known_bias = known_landmark_bias(tmpl);
  LandmarkTimings bias_timings;
  const Points bias =
      known_bias ? *known_bias : landmark_bias(tmpl, reference, options, &bias_timings);
  for (auto [slot, add] : {std::pair{&out.template_timings.render, bias_timings.render},
                           {&out.template_timings.detect, bias_timings.detect},
                           {&out.template_timings.predict, bias_timings.predict},
                           {&out.template_timings.lift, bias_timings.lift},
                           {&out.template_timings.fuse, bias_timings.fuse}})
    *slot += add;
  out.target = detect_landmarks(target, target_components, options, &reference, &bias);
  if (out.target.views_found == 0)
    throw Error("target: no face found in its " + std::to_string(out.target.views.size()) +
                " rendered views (a head facing +Z with +Y up is needed; or give --markers)");
  out.markers = landmark_markers(out.template_vertices, out.target);
  return out;
}

}  // namespace facecast::rigbuild
