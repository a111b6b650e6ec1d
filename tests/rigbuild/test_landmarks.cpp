// Automatic facial landmarks (rigbuild/landmarks.hpp) on real heads from ../shared/data: the ICT
// identities against their known landmark vertices, and MakeHuman and MediaPipe heads.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <tuple>

#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/template.hpp"
#include "landmark_views.hpp"
#include "test_data.hpp"

#include <dlib/image_processing/frontal_face_detector.h>

using namespace facecast;
using namespace facecast::rigbuild;

namespace {

// The landmark vertices' positions; NaN rows where a landmark is unknown (-1), as landmark_bias
// and detect_landmarks take them.
Points landmark_points(const rig::Rig& rig, const std::array<int, kLandmarkCount>& ids) {
  Points p(kLandmarkCount, 3);
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int v = ids[static_cast<std::size_t>(k)];
    if (v >= 0)
      p.row(k) = rig.positions.row(v).cast<double>();
    else
      p.row(k).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return p;
}

// The bias stored in configs/rigbuild/template_landmarks.json (known_landmark_bias) is the one
// landmark_bias computes, within 2% of the inter-ocular distance; prints the entry's "bias" to
// regenerate it.
void check_stored_bias(const rig::Rig& tmpl, const Points& computed, const Points& reference) {
  std::ostringstream json;
  json << std::setprecision(5);
  for (int k = 0; k < kLandmarkCount; ++k)
    json << (k ? ", [" : "[[") << computed(k, 0) << ", " << computed(k, 1) << ", " << computed(k, 2)
         << "]";
  json << "]";
  INFO("computed bias: " << json.str());
  const auto stored = known_landmark_bias(tmpl);
  REQUIRE(stored);
  const double iod = (reference.row(36) - reference.row(45)).norm();
  // dlib sees llvmpipe's renders, whose last bits follow the CPU's vector code: on another CPU a
  // point near the detector's threshold may not be found at all (landmark_bias gives it a zero
  // row). The points found here must match the stored bias; a few may be missing.
  double worst = 0;
  int missing = 0;
  std::ostringstream per_point;
  for (int k = 0; k < kLandmarkCount; ++k) {
    if (stored->row(k).isZero(0)) continue;  // not found where the bias was stored
    if (computed.row(k).isZero(0)) {
      ++missing;
      continue;
    }
    worst = std::max(worst, (stored->row(k) - computed.row(k)).norm());
    per_point << " " << k << ":" << (stored->row(k) - computed.row(k)).norm() / iod;
  }
  INFO("per point:" << per_point.str());
  INFO(missing << " points not found in this machine's renders; worst difference " << worst << " ("
               << worst / iod << " of the inter-ocular distance)");
  CHECK(missing <= 4);
  CHECK(worst <= 0.02 * iod);
}

}  // namespace

TEST_CASE("landmarks on ICT identities land within 2% of the face's diagonal of the true ones",
          "[rigbuild][landmarks][ict]") {
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const rig::Rig neutral = rig::read_obj(dir / "generic_neutral_mesh.obj");
  const auto truth_ids = known_landmarks(neutral);
  REQUIRE(truth_ids);  // configs/rigbuild/template_landmarks.json knows the ICT FaceKit
  const LandmarkOptions options = load_landmark_options();
  const Points reference = landmark_points(neutral, *truth_ids);
  const Points bias = landmark_bias(neutral, reference, options);
  check_stored_bias(neutral, bias, reference);
  double worst_mean = 0;
  for (const char* name : {"identity003.obj", "identity007.obj"}) {
    rig::Rig head = neutral;
    head.positions = rig::read_obj_positions(dir / name);
    head.normals = rig::vertex_normals(head.positions, head.triangles);
    const HeadLandmarks found = detect_landmarks(head, options, &reference, &bias);
    CHECK(found.views_found >= 3);
    const Points truth = landmark_points(head, *truth_ids);
    // The face: the bounding box of the skin in front of the ears (the true landmarks' box).
    const double diagonal = (truth.colwise().maxCoeff() - truth.colwise().minCoeff()).norm();
    double sum = 0;
    int n = 0;
    for (int k = 0; k < kLandmarkCount; ++k) {
      if (!std::isfinite(found.points(k, 0))) continue;
      sum += (found.points.row(k) - truth.row(k)).norm();
      ++n;
    }
    const double mean = sum / std::max(n, 1) / diagonal;
    std::ostringstream groups;
    for (auto [a, b] : {std::pair{0, 17}, std::pair{17, 27}, std::pair{27, 36}, std::pair{36, 48},
                        std::pair{48, 68}}) {
      double s = 0;
      int m = 0;
      for (int k = a; k < b; ++k)
        if (std::isfinite(found.points(k, 0)))
          s += (found.points.row(k) - truth.row(k)).norm(), ++m;
      groups << " " << a << "-" << b - 1 << ": " << 100 * s / std::max(m, 1) / diagonal << " %";
    }
    WARN(name << ": " << n << " of 68 landmarks (" << found.dropped << " dropped, "
              << found.views_found << " views with a face), mean error " << 100 * mean
              << " % of the face diagonal " << diagonal << ";" << groups.str());
    CHECK(n >= 60);
    CHECK(mean <= 0.02);
    worst_mean = std::max(worst_mean, mean);
    render::write_image(test::artifacts_dir("landmarks") / (std::string(name) + ".png"),
                        landmark_picture(found));
  }
  WARN("worst mean landmark error: " << 100 * worst_mean << " %");
}

TEST_CASE("the face detector compiled in is dlib's, byte for byte", "[rigbuild][landmarks]") {
  // The build writes dlib's detector uncompressed (rigbuild/tools/face_detector_gen.cpp); the
  // library reads that copy, not dlib's compressed one.
  std::ostringstream built, dlibs;
  dlib::serialize(face_detector(), built);
  dlib::serialize(dlib::get_frontal_face_detector(), dlibs);
  CHECK(built.str().size() > 100000);
  CHECK(built.str() == dlibs.str());
}

TEST_CASE("configs/rigbuild/landmarks.json mirrors LandmarkOptions' defaults",
          "[rigbuild][landmarks][config]") {
  const LandmarkOptions d, c = load_landmark_options();
  CHECK(c.predictor == d.predictor);
  CHECK(c.image_size == d.image_size);
  CHECK(c.frame_margin == d.frame_margin);
  CHECK(c.face_fill == d.face_fill);
  CHECK(c.yaws == d.yaws);
  CHECK(c.contour_yaw == d.contour_yaw);
  CHECK(c.search_pixels == d.search_pixels);
  CHECK(c.outlier == d.outlier);
  CHECK(c.symmetry == d.symmetry);
  CHECK(c.eye_bias_limit == d.eye_bias_limit);
  CHECK(c.lid_margins == d.lid_margins);
}

TEST_CASE("a mesh that is not a head: no face found, said in one line", "[rigbuild][landmarks]") {
  // A closed box: nothing for the face detector.
  rig::Rig box;
  box.positions.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    box.positions.row(i) << (i & 1 ? 1.f : -1.f), (i & 2 ? 1.f : -1.f), (i & 4 ? 1.f : -1.f);
  box.triangles.resize(12, 3);
  box.triangles << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2,
      2, 4, 6, 1, 3, 5, 3, 7, 5;
  box.triangle_material.assign(12, 0);
  box.materials.resize(1);
  box.normals = rig::vertex_normals(box.positions, box.triangles);
  rig::Rig tmpl = box;
  tmpl.landmarks.clear();
  for (int k = 0; k < kLandmarkCount; ++k) tmpl.landmarks.push_back({landmark_name(k), 0});
  const LandmarkOptions options = load_landmark_options();
  REQUIRE(known_landmarks(tmpl));
  try {
    auto_markers(tmpl, box, options);
    FAIL("a box has no face");
  } catch (const Error& e) {
    const std::string what = e.what();
    CHECK(what.find("no face found") != std::string::npos);
    CHECK(what.find('\n') == std::string::npos);
  }
}

namespace {

// sum <d_auto, d_hand> / sum |d_hand|^2 over the vertices: 1 when the automatic build moves
// every vertex as the hand-marker build does.
double agreement(const rig::Rig& automatic, const rig::Rig& hand, const std::string& shape) {
  const int a = automatic.find_shape(shape), h = hand.find_shape(shape);
  REQUIRE(a >= 0);
  REQUIRE(h >= 0);
  const rig::Positions da =
      automatic.shapes[static_cast<std::size_t>(a)].dense(automatic.vertex_count());
  const rig::Positions dh = hand.shapes[static_cast<std::size_t>(h)].dense(hand.vertex_count());
  return (da.cast<double>().array() * dh.cast<double>().array()).sum() /
         dh.cast<double>().squaredNorm();
}

// The gap left between MakeHuman's mid upper and mid lower lid vertices (the hand marker file's
// eye_*_lid_mid) in `shape`, as a fraction of the neutral gap.
double mid_lid_gap(const rig::Rig& rig, const std::string& shape, int upper, int lower) {
  const int s = rig.find_shape(shape);
  REQUIRE(s >= 0);
  const rig::Positions p =
      rig.positions + rig.shapes[static_cast<std::size_t>(s)].dense(rig.vertex_count());
  return (p.row(upper) - p.row(lower)).norm() /
         (rig.positions.row(upper) - rig.positions.row(lower)).norm();
}

}  // namespace

TEST_CASE(
    "MakeHuman head without markers builds like with the hand markers, and so does the "
    "MediaPipe face",
    "[rigbuild][landmarks][makehuman][slow]") {
  const auto dir = test::ict_dir();
  const auto mh = test::shared_data() / "makehuman/head.obj";
  const auto mp = test::shared_data() / "mediapipe/canonical_face_model.obj";
  if (!test::require_data(dir / "generic_neutral_mesh.obj") || !test::require_data(mh) ||
      !test::require_data(mp))
    return;
  const rig::Rig tmpl = rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  const rig::Rig target = rig::read_obj(mh);
  const BuildOptions defaults = load_build_options();
  const BuildResult automatic = build_rig(tmpl, target, defaults);
  REQUIRE(automatic.landmarks);
  CHECK(automatic.landmarks->markers.size() >= 50);
  // What --markers-out writes reads back as --markers; --landmarks-png draws every view.
  const auto markers_out = test::scratch_dir() / "mh_markers.json";
  write_markers_json(markers_out, automatic.landmarks->markers);
  const auto again = read_markers(markers_out, tmpl.vertex_count(), target.vertex_count());
  REQUIRE(again.size() == automatic.landmarks->markers.size());
  for (std::size_t i = 0; i < again.size(); ++i) {
    CHECK(again[i].name == automatic.landmarks->markers[i].name);
    CHECK(again[i].template_vertex == automatic.landmarks->markers[i].template_vertex);
    CHECK(again[i].target_vertex == automatic.landmarks->markers[i].target_vertex);
  }
  const render::Image picture = landmark_picture(automatic.landmarks->target);
  CHECK(picture.width == 5 * load_landmark_options().image_size);
  render::write_image(test::artifacts_dir("landmarks") / "makehuman.png", picture);
  BuildOptions opt = defaults;
  opt.markers = read_markers(test::shared_data() / "markers/makehuman_head_to_ict.json",
                             tmpl.vertex_count(), target.vertex_count());
  const BuildResult hand = build_rig(tmpl, target, opt);
  CHECK(!hand.landmarks);
  std::ostringstream figures;
  for (const char* shape :
       {"jawOpen", "eyeBlink_L", "eyeBlink_R", "mouthSmile_L", "mouthFunnel", "browInnerUp_L"}) {
    const double r = agreement(automatic.rig, hand.rig, shape);
    figures << " " << shape << " " << r;
    INFO(shape << ": " << r);
    CHECK(r >= 0.8);
  }
  // The blink closes the lids as far without markers as with them (docs/algorithms.md#landmarks,
  // step 7: the lid middles; the template leaves 0.164 of the gap).
  for (const auto& [shape, upper, lower] :
       {std::tuple{"eyeBlink_L", 3190, 3203}, std::tuple{"eyeBlink_R", 1068, 1081}}) {
    const double a = mid_lid_gap(automatic.rig, shape, upper, lower),
                 h = mid_lid_gap(hand.rig, shape, upper, lower);
    figures << "; " << shape << " leaves " << a << " of the mid-lid gap (hand markers " << h << ")";
    INFO(shape << " mid-lid gap: " << a);
    CHECK(a < 0.2);
  }
  for (const auto& m : automatic.landmarks->markers)
    if (m.name.starts_with("lid_") || (m.name >= "dlib_36" && m.name <= "dlib_47"))
      figures << "; " << m.name << " " << m.target_vertex;
  // The lid middles come with the landmarks' pairs only (the web page sends those back, perhaps
  // moved); a marker file of other names is used as it is.
  std::vector<MarkerPair> landmark_pairs, lid_pairs;
  for (const auto& m : automatic.landmarks->markers)
    (m.name.starts_with("dlib_") ? landmark_pairs : lid_pairs).push_back(m);
  CHECK(lid_pairs.size() == 4);
  const auto again_with_lids =
      with_lid_middles(tmpl, target, automatic.correspondence.registered, landmark_pairs);
  for (const auto& l : lid_pairs)
    CHECK(std::count_if(again_with_lids.begin(), again_with_lids.end(), [&](const MarkerPair& m) {
            return m.name == l.name && m.target_vertex == l.target_vertex;
          }) == 1);
  CHECK(with_lid_middles(tmpl, target, automatic.correspondence.registered, opt.markers).empty());
  WARN("MakeHuman, automatic vs hand markers, sum<d_auto,d_hand>/sum|d_hand|^2:"
       << figures.str() << "; " << automatic.landmarks->markers.size()
       << " landmark markers; build " << automatic.timings.total << " s (landmarks "
       << automatic.timings.landmarks << " s, correspondence " << automatic.timings.correspondence
       << " s)");

  const rig::Rig mask = rig::read_obj(mp);
  const BuildResult m = build_rig(tmpl, mask, defaults);
  REQUIRE(m.landmarks);
  CHECK(m.rig.shapes.size() == 57);
  CHECK(m.rig.shapes[static_cast<std::size_t>(m.rig.find_shape("jawOpen"))].max_displacement() >
        0.0f);
  WARN("MediaPipe: " << m.landmarks->markers.size() << " landmark markers, build "
                     << m.timings.total << " s");
}

TEST_CASE("the default avatar's stored landmarks are where the detector finds them",
          "[rigbuild][landmarks]") {
  const rig::Rig& avatar = avatar::default_avatar();
  const HeadLandmarks found = detect_landmarks(avatar, load_landmark_options());
  std::ostringstream list;  // configs/rigbuild/template_landmarks.json's entry, to regenerate it
  for (int k = 0; k < kLandmarkCount; ++k)
    list << (k ? ", " : "[") << found.vertex[static_cast<std::size_t>(k)];
  list << "] (" << avatar.vertex_count() << " vertices, " << avatar.triangle_count()
       << " triangles)";
  const auto stored = known_landmarks(avatar);
  INFO("detected: " << list.str());
  REQUIRE(stored);
  const double iod =
      (avatar.positions.row((*stored)[36]) - avatar.positions.row((*stored)[45])).norm();
  int agree = 0;
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int s = (*stored)[static_cast<std::size_t>(k)],
              d = found.vertex[static_cast<std::size_t>(k)];
    agree += s >= 0 && d >= 0 &&
             (avatar.positions.row(s) - avatar.positions.row(d)).norm() <= 0.05 * iod;
  }
  // The detector sees llvmpipe's renders, whose last bits differ between machines (the JIT
  // follows the CPU): the landmarks were stored where 55 agreed; on another machine 54 do, the
  // others moving by a vertex ring or two. The lid-corner vertices the rig tests measure with are
  // the stored ones. The avatar's bias moves further (a tenth of the inter-ocular distance
  // between an Intel and an AMD machine, three eye points lost on the latter), so none is stored:
  // a build computes it where it is used.
  CHECK(agree >= 50);
  CHECK_FALSE(known_landmark_bias(avatar));
  const Points reference = landmark_points(avatar, *stored);
  const Points bias = landmark_bias(avatar, reference, load_landmark_options());
  int in_bias = 0;
  for (int k = 0; k < kLandmarkCount; ++k) in_bias += !bias.row(k).isZero(0);
  CHECK(in_bias >= 60);
  CHECK(bias.rowwise().norm().maxCoeff() <= 0.25 * iod);
}

TEST_CASE("the shipped template's stored landmark bias is the one computed",
          "[rigbuild][landmarks][template]") {
  if (!test::require_data(test::ict_dir() / "generic_neutral_mesh.obj")) return;  // packed from it
  const rig::Rig tmpl = load_shipped_template();
  const auto ids = known_landmarks(tmpl);
  REQUIRE(ids);  // stored in the file
  const Points reference = landmark_points(tmpl, *ids);
  check_stored_bias(tmpl, landmark_bias(tmpl, reference, load_landmark_options()), reference);
}
