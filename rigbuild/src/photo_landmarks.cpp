// Landmarks in photos: dlib's HOG face detector on the photo scaled down to a working size, the
// 68-point shape predictor on the full-resolution photo in the box it found. See
// docs/algorithms.md#photo-avatar.
#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "landmark_views.hpp"

namespace facecast::rigbuild {
namespace {

// The photo scaled by `scale` (<= 1) with a box filter: each output pixel averages the source
// pixels it covers.
dlib::array2d<dlib::rgb_pixel> to_dlib(const render::Image& image, double scale) {
  const int w = std::max(1, static_cast<int>(std::lround(image.width * scale)));
  const int h = std::max(1, static_cast<int>(std::lround(image.height * scale)));
  dlib::array2d<dlib::rgb_pixel> img(h, w);
  const double step = 1.0 / scale;
  for (int y = 0; y < h; ++y) {
    const int y0 = static_cast<int>(y * step),
              y1 = std::max(y0 + 1, static_cast<int>((y + 1) * step));
    for (int x = 0; x < w; ++x) {
      const int x0 = static_cast<int>(x * step),
                x1 = std::max(x0 + 1, static_cast<int>((x + 1) * step));
      int sum[3] = {0, 0, 0}, n = 0;
      for (int yy = y0; yy < std::min(y1, image.height); ++yy)
        for (int xx = x0; xx < std::min(x1, image.width); ++xx, ++n)
          for (int c = 0; c < 3; ++c) sum[c] += image.at(xx, yy, c);
      n = std::max(n, 1);
      img[y][x] = dlib::rgb_pixel(static_cast<unsigned char>(sum[0] / n),
                                  static_cast<unsigned char>(sum[1] / n),
                                  static_cast<unsigned char>(sum[2] / n));
    }
  }
  return img;
}

// The 68 points in the face box `rect` (left, top, right, bottom), averaged over the box grid of
// options.box_jitter and box_steps.
std::array<Eigen::Vector2d, kLandmarkCount> predict_landmarks(const render::Image& photo,
                                                              const std::array<double, 4>& rect,
                                                              const PhotoOptions& options) {
  const dlib::shape_predictor& sp = shape_predictor(options.predictor);
  const dlib::rectangle box(std::lround(rect[0]), std::lround(rect[1]), std::lround(rect[2]),
                            std::lround(rect[3]));
  const dlib::array2d<dlib::rgb_pixel> full = to_dlib(photo, 1.0);
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
  std::array<Eigen::Vector2d, kLandmarkCount> points;
  points.fill(Eigen::Vector2d::Zero());
  for (const auto& m : moves) {
    const dlib::drectangle c =
        dlib::centered_drect(dlib::dpoint(dlib::center(dlib::drectangle(box)).x() + m[0] * w,
                                          dlib::center(dlib::drectangle(box)).y() + m[1] * h),
                             w * m[2], h * m[2]);
    const dlib::full_object_detection shape =
        sp(full, dlib::rectangle(std::lround(c.left()), std::lround(c.top()),
                                 std::lround(c.right()), std::lround(c.bottom())));
    for (int k = 0; k < kLandmarkCount; ++k)
      points[static_cast<std::size_t>(k)] +=
          Eigen::Vector2d(static_cast<double>(shape.part(k).x()),
                          static_cast<double>(shape.part(k).y())) /
          static_cast<double>(moves.size());
  }
  return points;
}

// The face box dlib's HOG detector finds in `img` (the photo at its working size).
struct Found {
  dlib::rectangle box;  // in `img`'s pixels
  int faces = 0;        // 0: none
  bool weak = false;    // found only below the detector's threshold
  double score = 0;     // the SVM score of a weak one
};

// In passes, each only when the ones before found nothing: at the detector's threshold, the
// largest face (the working size's, then twice it: the detector's window is 80 pixels, and a face
// in a large photo of a person to the waist is smaller once scaled down); then the best-scoring
// face above `weak_score` (a face turned well aside or lit from one side scores below the
// threshold; 0: no such pass).
Found find_face(const dlib::array2d<dlib::rgb_pixel>& img, double weak_score) {
  // Made once per thread (building it reads its HOG filters: a tenth of a second).
  thread_local dlib::frontal_face_detector detector = dlib::get_frontal_face_detector();
  dlib::array2d<dlib::rgb_pixel> up;
  const auto doubled = [&]() -> const dlib::array2d<dlib::rgb_pixel>& {
    if (up.size() == 0) dlib::pyramid_up(img, up, dlib::pyramid_down<2>());
    return up;
  };
  const auto halved = [](const dlib::rectangle& r, double f) {
    return f == 1.0 ? r
                    : dlib::rectangle(std::lround(r.left() * f), std::lround(r.top() * f),
                                      std::lround(r.right() * f), std::lround(r.bottom() * f));
  };
  Found out;
  for (int pass = 0; pass < 2; ++pass) {
    const double factor = pass == 0 ? 1.0 : 0.5;
    const std::vector<dlib::rectangle> faces = detector(pass == 0 ? img : doubled());
    if (faces.empty()) continue;
    const dlib::rectangle best =
        *std::max_element(faces.begin(), faces.end(),
                          [](const auto& a, const auto& b) { return a.area() < b.area(); });
    out.box = halved(best, factor);
    out.faces = static_cast<int>(faces.size());
    return out;
  }
  if (weak_score >= 0) return out;
  for (int pass = 0; pass < 2; ++pass) {
    const double factor = pass == 0 ? 1.0 : 0.5;
    std::vector<std::pair<double, dlib::rectangle>> faces;
    detector(pass == 0 ? img : doubled(), faces, weak_score);
    if (faces.empty()) continue;
    const auto best = *std::max_element(
        faces.begin(), faces.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    if (out.faces == 0 || best.first > out.score) {
      out.box = halved(best.second, factor);
      out.faces = static_cast<int>(faces.size());
      out.weak = true;
      out.score = best.first;
    }
  }
  return out;
}

}  // namespace

PhotoLandmarks detect_photo_landmarks(const render::Image& photo, const std::string& what,
                                      const PhotoOptions& options) {
  if (photo.width < options.min_face || photo.height < options.min_face)
    throw Error(what + ": photo too small (" + std::to_string(photo.width) + "x" +
                std::to_string(photo.height) + " pixels; a face needs at least " +
                std::to_string(options.min_face) + ")");
  const double scale =
      std::min(1.0, options.max_side / static_cast<double>(std::max(photo.width, photo.height)));
  const dlib::array2d<dlib::rgb_pixel> small = to_dlib(photo, scale);
  const Found found = find_face(small, options.weak_face_score);
  if (found.faces == 0) throw Error(what + ": no face found");
  const dlib::rectangle best = found.box;
  PhotoLandmarks out;
  out.width = photo.width;
  out.height = photo.height;
  out.faces = found.faces;
  out.box = best.width() / scale;
  if (out.box < options.min_face)
    throw Error(what + ": face too small (" + std::to_string(static_cast<int>(out.box)) +
                " pixels wide; at least " + std::to_string(options.min_face) + " needed)");
  if (found.weak)
    out.note = what + ": a face found only below the detector's threshold (score " +
               std::to_string(found.score).substr(0, 5) + "); check its landmarks";
  else if (out.faces > 1)
    out.note = what + ": " + std::to_string(out.faces) + " faces found, the largest used";
  out.rect = {std::round(best.left() / scale), std::round(best.top() / scale),
              std::round(best.right() / scale), std::round(best.bottom() / scale)};
  out.points = predict_landmarks(photo, out.rect, options);
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
