// Landmarks in photos: dlib's HOG face detector on the photo scaled down to a working size, the
// 68-point shape predictor on the full-resolution photo in the box it found. See
// docs/algorithms.md#photo-avatar.
#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "facecast/core/error.hpp"
#include "facecast/core/threads.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "landmark_views.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {
namespace {

// The photo scaled by `scale` (<= 1) with a box filter (render::scale_down), as dlib's image.
dlib::array2d<dlib::rgb_pixel> to_dlib(const render::Image& photo, double scale) {
  const render::Image scaled = scale < 1 ? render::scale_down(photo, scale) : render::Image{};
  const render::Image& image = scale < 1 ? scaled : photo;
  dlib::array2d<dlib::rgb_pixel> img(image.height, image.width);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      img[y][x] = dlib::rgb_pixel(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
  return img;
}

// A view of a photo turned by `angle` (radians; positive turns the view's x axis towards the
// photo's y, clockwise as the picture shows it) about `centre`, `side` pixels square, `zoom`
// view pixels to a photo pixel (<= 1): the view's pixel q is the photo's centre + R(angle) (q -
// the view's centre) / zoom, bilinear. A face tilted by `angle` in the photo stands upright in it.
struct TurnedView {
  Eigen::Vector2d centre;  // in the photo
  double angle = 0;
  int side = 0;
  double zoom = 1;
  dlib::array2d<dlib::rgb_pixel> img;

  Eigen::Vector2d to_photo(const Eigen::Vector2d& q) const {
    return centre + Eigen::Rotation2Dd(angle) * (q - Eigen::Vector2d::Constant(side / 2.0)) / zoom;
  }
};

template <typename At>
TurnedView turned_view(int width, int height, const At& at, const Eigen::Vector2d& centre,
                       double angle, int side, double zoom = 1) {
  TurnedView v{centre, angle, side, zoom, {}};
  v.img.set_size(side, side);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      // Outside the photo: its edge's pixels (no dark wedges for the detector to see).
      const Eigen::Vector2d p = v.to_photo(Eigen::Vector2d(x, y));
      const double fx = std::clamp(p.x(), 0.0, width - 1.0),
                   fy = std::clamp(p.y(), 0.0, height - 1.0);
      const int x0 = std::min(static_cast<int>(fx), std::max(0, width - 2));
      const int y0 = std::min(static_cast<int>(fy), std::max(0, height - 2));
      const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
      const double ax = fx - x0, ay = fy - y0;
      unsigned char rgb[3];
      for (int c = 0; c < 3; ++c) {
        const double top = (1 - ax) * at(x0, y0, c) + ax * at(x1, y0, c);
        const double bottom = (1 - ax) * at(x0, y1, c) + ax * at(x1, y1, c);
        rgb[c] = static_cast<unsigned char>(std::lround((1 - ay) * top + ay * bottom));
      }
      v.img[y][x] = dlib::rgb_pixel(rgb[0], rgb[1], rgb[2]);
    }
  return v;
}

// The 68 points in the face box `rect` (left, top, right, bottom) of `image`, averaged over the
// box grid of options.box_jitter and box_steps.
std::array<Eigen::Vector2d, kLandmarkCount> predict_landmarks(
    const dlib::array2d<dlib::rgb_pixel>& full, const std::array<double, 4>& rect,
    const PhotoOptions& options) {
  const dlib::shape_predictor& sp = shape_predictor(options.predictor);
  const dlib::rectangle box(std::lround(rect[0]), std::lround(rect[1]), std::lround(rect[2]),
                            std::lround(rect[3]));
  // The predictor's cascade starts from the box: its answer varies with the box by a pixel or
  // two. Averaging it over a grid of boxes, shifted in x and y and scaled by up to box_jitter of
  // their size in box_steps steps each way ((2 n + 1)^3 boxes), removes most of that noise.
  const double w = static_cast<double>(box.width()), h = static_cast<double>(box.height());
  const int n = options.box_jitter > 0 ? options.box_steps : 0;
  const double step = n > 0 ? options.box_jitter / n : 0.0;
  std::vector<std::array<double, 3>> moves;
  for (int x = -n; x <= n; ++x)
    for (int y = -n; y <= n; ++y)
      for (int s = -n; s <= n; ++s) moves.push_back({x * step, y * step, 1 + s * step});
  // The boxes are read on the loop's workers (the predictor is const and shared) and summed in
  // their order, so the average does not depend on the number of threads.
  std::vector<dlib::full_object_detection> shapes(moves.size());
  parallel_for(moves.size(), [&](std::size_t i) {
    const auto& m = moves[i];
    const dlib::drectangle c =
        dlib::centered_drect(dlib::dpoint(dlib::center(dlib::drectangle(box)).x() + m[0] * w,
                                          dlib::center(dlib::drectangle(box)).y() + m[1] * h),
                             w * m[2], h * m[2]);
    shapes[i] = sp(full, dlib::rectangle(std::lround(c.left()), std::lround(c.top()),
                                         std::lround(c.right()), std::lround(c.bottom())));
  });
  std::array<Eigen::Vector2d, kLandmarkCount> points;
  points.fill(Eigen::Vector2d::Zero());
  for (const auto& shape : shapes)
    for (int k = 0; k < kLandmarkCount; ++k)
      points[static_cast<std::size_t>(k)] +=
          Eigen::Vector2d(static_cast<double>(shape.part(k).x()),
                          static_cast<double>(shape.part(k).y())) /
          static_cast<double>(moves.size());
  return points;
}

// The face box dlib's HOG detector finds in `img` (the photo at its working size).
struct Found {
  dlib::rectangle box;  // in `img`'s pixels, or in the turned view's when roll != 0
  int faces = 0;        // 0: none
  bool weak = false;    // found only below the detector's threshold
  double score = 0;     // the SVM score of a weak one
  double roll = 0;      // the view's turn (radians) where the face was found upright
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // the box's centre in `img`
};

// In passes, each only when the ones before found nothing: at the detector's threshold (the
// working size's, then twice it: the detector's window is 80 pixels, and a face
// in a large photo of a person to the waist is smaller once scaled down); at the threshold in
// views of the photo turned by roll_step, 2 roll_step, ... up to max_roll degrees either way (the
// detector's filters look for upright faces; a head tilted by more than about 20 degrees is found
// only so); then the best-scoring upright face above `weak_face_score` (a face turned well aside
// or lit from one side scores below the threshold; 0: no such pass).
Found find_face(const dlib::array2d<dlib::rgb_pixel>& img, const PhotoOptions& options,
                double expected_roll) {
  // Copied once per thread from the one built per process.
  thread_local dlib::frontal_face_detector detector = face_detector();
  dlib::array2d<dlib::rgb_pixel> up;
  const auto doubled = [&]() -> const dlib::array2d<dlib::rgb_pixel>& {
    if (up.size() == 0) dlib::pyramid_up(img, up, dlib::pyramid_down<2>());
    return up;
  };
  const auto scaled = [](const dlib::rectangle& r, double f) {
    return f == 1.0 ? r
                    : dlib::rectangle(std::lround(r.left() * f), std::lround(r.top() * f),
                                      std::lround(r.right() * f), std::lround(r.bottom() * f));
  };
  const auto centre_of = [](const dlib::rectangle& r) {
    return Eigen::Vector2d((r.left() + r.right()) / 2.0, (r.top() + r.bottom()) / 2.0);
  };
  // The largest face among those scoring at least half the best one's: the subject nearest the
  // camera, not a badge or a poster (a false face scores near 0; astronaut.png's mission patch
  // 0.04-0.09 in her photo turned 12-25 degrees, larger than her face, which scores 0.6-1.1).
  Found out;
  // The face chosen in `view` (scaled by `factor` back to `img`'s size), with the best score there;
  // faces = 0 when there is none.
  const auto choose = [&](const dlib::array2d<dlib::rgb_pixel>& view, double factor) {
    std::vector<std::pair<double, dlib::rectangle>> faces;
    detector(view, faces, 0.0);
    Found f;
    if (faces.empty()) return std::make_pair(f, 0.0);
    double best = 0;
    for (const auto& face : faces) best = std::max(best, face.first);
    const dlib::rectangle* chosen = nullptr;
    for (const auto& face : faces)
      if (face.first >= best / 2 && (!chosen || face.second.area() > chosen->area()))
        chosen = &face.second;
    f.box = scaled(*chosen, factor);
    f.centre = centre_of(f.box);
    f.faces = static_cast<int>(faces.size());
    return std::make_pair(f, best);
  };
  const int w = static_cast<int>(img.nc()), h = static_cast<int>(img.nr());
  const int side = static_cast<int>(std::ceil(std::hypot(w, h)));  // the whole photo, turned
  const auto at = [&](int x, int y, int c) {
    const dlib::rgb_pixel& px = img[y][x];
    return c == 0 ? px.red : c == 1 ? px.green : px.blue;
  };
  double best_score = 0;
  // The face in the view turned by `degrees`, kept when it scores best so far.
  const auto look_turned = [&](double degrees) {
    const double angle = degrees * std::numbers::pi / 180;
    const TurnedView view = turned_view(w, h, at, Eigen::Vector2d(w / 2.0, h / 2.0), angle, side);
    auto [f, score] = choose(view.img, 1.0);
    if (f.faces == 0 || score <= best_score) return;
    best_score = score;
    out = f;
    out.centre = view.to_photo(f.centre);
    out.roll = angle;
  };
  if (expected_roll != 0) {
    look_turned(expected_roll);
    if (out.faces) return out;
  }
  for (int pass = 0; pass < 2; ++pass)
    if (const Found f = choose(pass == 0 ? img : doubled(), pass == 0 ? 1.0 : 0.5).first; f.faces)
      return f;
  // Every turned view, the one whose face scores best (a false face in one view does not hide a
  // real one in another).
  for (double roll = options.roll_step; roll <= options.max_roll + 1e-9; roll += options.roll_step)
    for (const double sign : {1.0, -1.0}) look_turned(sign * roll);
  if (out.faces) return out;
  if (options.weak_face_score >= 0) return out;
  for (int pass = 0; pass < 2; ++pass) {
    const double factor = pass == 0 ? 1.0 : 0.5;
    std::vector<std::pair<double, dlib::rectangle>> faces;
    detector(pass == 0 ? img : doubled(), faces, options.weak_face_score);
    if (faces.empty()) continue;
    const auto best = *std::max_element(
        faces.begin(), faces.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    if (out.faces == 0 || best.first > out.score) {
      out.box = scaled(best.second, factor);
      out.centre = centre_of(out.box);
      out.faces = static_cast<int>(faces.size());
      out.weak = true;
      out.score = best.first;
    }
  }
  return out;
}

// The eyes' line's angle in the picture (radians, positive clockwise as shown).
double eye_line_angle(const std::array<Eigen::Vector2d, kLandmarkCount>& points) {
  Eigen::Vector2d right = Eigen::Vector2d::Zero(), left = Eigen::Vector2d::Zero();
  for (int k = 36; k < 42; ++k) right += points[static_cast<std::size_t>(k)] / 6;
  for (int k = 42; k < 48; ++k) left += points[static_cast<std::size_t>(k)] / 6;
  return std::atan2(left.y() - right.y(), left.x() - right.x());
}

}  // namespace

void load_photo_detector(const PhotoOptions& options) {
  auto detector = async_within_budget([] { face_detector(); });  // the two are read side by side
  shape_predictor(options.predictor);
  detector.get();
}

PhotoLandmarks detect_photo_landmarks(const render::Image& photo, const std::string& what,
                                      const PhotoOptions& options, double expected_roll) {
  if (photo.width < options.min_face || photo.height < options.min_face)
    throw Error(what + ": photo too small (" + std::to_string(photo.width) + "x" +
                std::to_string(photo.height) + " pixels; a face needs at least " +
                std::to_string(options.min_face) + ")");
  const double scale =
      std::min(1.0, options.max_side / static_cast<double>(std::max(photo.width, photo.height)));
  const dlib::array2d<dlib::rgb_pixel> small = to_dlib(photo, scale);
  const Found found = find_face(small, options, expected_roll);
  if (found.faces == 0) throw Error(what + ": no face found");
  PhotoLandmarks out;
  out.width = photo.width;
  out.height = photo.height;
  // A 35-mm equivalent focal length is the one that gives the photo's diagonal the angle a 36 x 24
  // mm frame's would have.
  if (photo.focal_35mm > 0)
    out.focal = photo.focal_35mm * std::hypot(photo.width, photo.height) / std::hypot(36.0, 24.0);
  out.faces = found.faces;
  out.box = found.box.width() / scale;
  if (out.box < options.min_face)
    throw Error(what + ": face too small (" + std::to_string(static_cast<int>(out.box)) +
                " pixels wide; at least " + std::to_string(options.min_face) + " needed)");
  if (found.weak)
    out.note = what + ": a face found only below the detector's threshold (score " +
               std::to_string(found.score).substr(0, 5) + "); check its landmarks";
  else if (out.faces > 1)
    out.note = what + ": " + std::to_string(out.faces) +
               " faces found, the largest used (of those scoring at least half the best)";
  // The box in the photo: its centre mapped back, its size scaled (upright in the turned view).
  const Eigen::Vector2d centre = found.centre / scale;
  const double half_w = (found.box.right() - found.box.left()) / scale / 2,
               half_h = (found.box.bottom() - found.box.top()) / scale / 2;
  out.rect = {std::round(centre.x() - half_w), std::round(centre.y() - half_h),
              std::round(centre.x() + half_w), std::round(centre.y() + half_h)};
  // The predictor in a view where the face stands upright: the detector's turn, then the eyes'
  // line of its answer when that is tilted by more than level_eyes degrees (the predictor, like
  // the detector, learnt mostly upright faces).
  const auto at = [&](int x, int y, int c) { return photo.at(x, y, c); };
  const auto predict_turned = [&](double angle) {
    // The face box and half as much around it, at most kViewFace pixels wide (a face filling a
    // large photo is read smaller, not from a view of gigabytes).
    constexpr double kViewFace = 1024;
    const double zoom = std::min(1.0, kViewFace / (2 * std::max(half_w, half_h)));
    const int side = static_cast<int>(std::ceil(1.5 * 2 * std::max(half_w, half_h) * zoom));
    const TurnedView view = turned_view(photo.width, photo.height, at, centre, angle, side, zoom);
    const double c = side / 2.0, hw = half_w * zoom, hh = half_h * zoom;
    auto points = predict_landmarks(view.img, {c - hw, c - hh, c + hw, c + hh}, options);
    for (auto& p : points) p = view.to_photo(p);
    return points;
  };
  double roll = found.roll;
  out.points =
      roll != 0 ? predict_turned(roll) : predict_landmarks(to_dlib(photo, 1.0), out.rect, options);
  // A face read tilted is read tilted less than it is (astronaut.png turned 40 degrees: her eyes'
  // line at 18): up to three looks, each in the view the last one's eyes make level.
  for (int look = 0; look < 3 && options.level_eyes > 0; ++look) {
    const double tilt = eye_line_angle(out.points);
    if (std::abs(tilt - roll) <= options.level_eyes * std::numbers::pi / 180) break;
    roll = tilt;
    out.points = predict_turned(roll);
  }
  out.roll = roll * 180 / std::numbers::pi;
  return out;
}

std::vector<int> side_points(const PhotoLandmarks& side) {
  // The near side is the one whose cheek contour lies farther from the nose tip in the picture.
  const auto& p = side.points;
  const bool near_right = std::abs(p[30].x() - p[2].x()) > std::abs(p[14].x() - p[30].x());
  // The profile: nose ridge and tip, lip centres, chin; and the near eye's corners, brow ends,
  // nostril and mouth corner.
  std::vector<int> out{8, 27, 28, 29, 30, 33, 51, 57, 62, 66};
  const std::vector<int> near = near_right ? std::vector<int>{17, 21, 31, 36, 39, 48}
                                           : std::vector<int>{22, 26, 35, 42, 45, 54};
  out.insert(out.end(), near.begin(), near.end());
  return out;
}

render::Image photo_landmark_picture(const render::Image& photo, const PhotoLandmarks& marks,
                                     const std::vector<int>& used) {
  render::Image out = photo;
  out.channels = 3;
  const int r = std::max(2, photo.width / 200);
  for (int k = 0; k < kLandmarkCount; ++k) {
    const bool on = used.empty() || std::find(used.begin(), used.end(), k) != used.end();
    const auto& p = marks.points[static_cast<std::size_t>(k)];
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        const int x = static_cast<int>(std::lround(p.x())) + dx;
        const int y = static_cast<int>(std::lround(p.y())) + dy;
        if (x < 0 || y < 0 || x >= out.width || y >= out.height) continue;
        std::uint8_t* px = &out.pixels[(static_cast<std::size_t>(y) * out.width + x) * 3];
        px[0] = on ? 40 : 240;
        px[1] = on ? 230 : 40;
        px[2] = 40;
      }
  }
  return out;
}

render::Image side_by_side(const std::vector<render::Image>& images) {
  render::Image out;
  for (const auto& i : images) {
    out.width += i.width;
    out.height = std::max(out.height, i.height);
  }
  out.pixels.assign(static_cast<std::size_t>(out.width) * out.height * 3, 0);
  int x0 = 0;
  for (const auto& i : images) {
    for (int y = 0; y < i.height; ++y)
      for (int x = 0; x < i.width; ++x)
        for (int c = 0; c < 3; ++c)
          out.pixels[(static_cast<std::size_t>(y) * out.width + x0 + x) * 3 +
                     static_cast<std::size_t>(c)] = i.at(x, y, std::min(c, i.channels - 1));
    x0 += i.width;
  }
  return out;
}

}  // namespace facecast::rigbuild
