// MPEG-4 FAPs: the FBA ASCII file, the units and directions measured on a rig, a performance's
// round trip, and hand-written files from the standard's description driving a rig.
#include <catch2/catch.hpp>
#include <cmath>

#include "build_paths.hpp"
#include "facecast/anim/fap.hpp"
#include "facecast/anim/live_link.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/viseme/viseme.hpp"

using namespace facecast;
using namespace facecast::anim;

namespace {

// The ICT FaceKit as the rig builder ships it (all 68 landmarks stored), with its 52 ARKit shapes
// only: the face an ARKit-driven player has.
const rig::Rig& ict_face() {
  static const rig::Rig rig = [] {
    rig::Rig r = rig::load_rig(facecast::test::source_dir() / "rigbuild/data/ict_facekit.glb");
    const auto arkit = arkit_shape_names();
    std::erase_if(r.shapes, [&](const rig::Blendshape& b) {
      return std::find(arkit.begin(), arkit.end(), b.name) == arkit.end();
    });
    REQUIRE(r.shapes.size() >= 51);  // the FaceKit has no tongueOut
    return r;
  }();
  return rig;
}

const FapRig& avatar_fap() {
  static const FapRig rig = [] {
    const auto landmarks = rigbuild::known_landmarks(ict_face());
    REQUIRE(landmarks);
    return FapRig(ict_face(), *landmarks);
  }();
  return rig;
}

int shape(const std::string& name) {
  const int s = ict_face().find_shape(name);
  REQUIRE(s >= 0);
  return s;
}

double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const auto n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
  double ab = 0, aa = 0, bb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ab += (a[i] - ma) * (b[i] - mb);
    aa += (a[i] - ma) * (a[i] - ma);
    bb += (b[i] - mb) * (b[i] - mb);
  }
  return ab / std::sqrt(aa * bb);
}

std::string mask_line(std::initializer_list<int> faps) {
  std::string out;
  for (int n = 1; n <= kFapCount; ++n) {
    out += std::find(faps.begin(), faps.end(), n) != faps.end() ? '1' : '0';
    out += n < kFapCount ? ' ' : '\n';
  }
  return out;
}

FapMotion drive_avatar(const std::string& file) {
  const std::string path = (facecast::test::source_dir() / "tests/anim/data").string() + "/" + file;
  return FapMotion(parse_fap(read_file(path), path), avatar_fap(),
                   Mapping::for_rig(ict_face().shape_names()));
}

std::vector<float> weights_at(const FapMotion& m, int frame, rig::BodyPose* head = nullptr) {
  std::vector<float> w(m.shape_names().size());
  m.sample(frame / m.fps(), w, head);
  return w;
}

}  // namespace

TEST_CASE("an FBA ASCII FAP file: header, masks, FAP 1 and 2, held values, skipped frames",
          "[anim][fap]") {
  const std::string text = "# a comment\n2.1 test 25 4\n" + mask_line({1, 3}) +
                           "0 1 10 40 0 120\n" + mask_line({2, 19}) + "1 1 30 6 5 0 0 -7.5\n" +
                           mask_line({3}) + "3 -60\n";
  const FapSequence s = parse_fap(text, "t.fap");
  CHECK(s.version == "2.1");
  CHECK(s.name == "test");
  CHECK(s.fps == 25);
  REQUIRE(s.frames.size() == 4);
  CHECK(s.frames[0].viseme.select1 == 1);
  CHECK(s.frames[0].viseme.select2 == 10);
  CHECK(s.frames[0].viseme.blend == 40);
  CHECK(s.frames[0].value[2] == 120);
  // Frame 1 sets FAP 2 and 19; FAP 1 and 3 keep their values.
  CHECK(s.frames[1].expression.select1 == 1);
  CHECK(s.frames[1].expression.intensity1 == 30);
  CHECK(s.frames[1].expression.select2 == 6);
  CHECK(s.frames[1].expression.intensity2 == 5);
  CHECK(s.frames[1].value[18] == -7.5);
  CHECK(s.frames[1].value[2] == 120);
  CHECK(s.frames[1].viseme.select2 == 10);
  // Frame 2 is not listed: it repeats frame 1 and sets nothing.
  CHECK(s.frames[2].mask.none());
  CHECK(s.frames[2].value[18] == -7.5);
  CHECK(s.frames[3].value[2] == -60);
  CHECK(s.frames[3].value[18] == -7.5);
  // Written and read again, the same (values rounded to integers, as the standard codes them).
  const FapSequence again = parse_fap(to_fap_text(s), "again.fap");
  REQUIRE(again.frames.size() == 4);
  CHECK(again.frames[1].value[18] == -8);  // -7.5 rounds away from zero
  CHECK(again.frames[3].value[2] == -60);
  CHECK(again.frames[1].expression.intensity1 == 30);
}

TEST_CASE("a malformed FAP file is refused with its line and the field", "[anim][fap]") {
  const auto refused = [](const std::string& text, const std::string& expected) {
    CHECK_THROWS_WITH(parse_fap(text, "bad.fap"), Catch::Contains(expected));
  };
  refused("", "bad.fap:1: the file ends where the header's version should be");
  refused("2.1 x 0 3\n", "bad.fap:1: frame rate: expected 1 to 1000");
  refused("2.1 x 1 100000\n", "bad.fap:1: 100000 frames at 1 fps: longer than 3600 s");
  refused("2.1 x 25 -1\n", "the header's frame count: expected a whole number");
  refused("2.1 x 25 2\n1 0 2\n", "bad.fap:2: the mask: expected a whole number in 0..1");
  refused("2.1 x 25 2\n" + mask_line({3}), "the file ends where the frame number should be");
  refused("2.1 x 25 2\n" + mask_line({3}) + "0 abc\n", "bad.fap:3: FAP 3: 'abc' is not a number");
  refused("2.1 x 25 2\n" + mask_line({3}) + "0 inf\n", "FAP 3: 'inf' is not a number");
  refused("2.1 x 25 2\n" + mask_line({3}) + "0 1e9\n", "bad.fap:3: FAP 3: beyond");
  refused("2.1 x 25 2\n" + mask_line({1}) + "0 15 0 63 0\n", "viseme_select1: expected");
  refused("2.1 x 25 2\n" + mask_line({2}) + "0 1 64 0 0 0 0\n", "expression_intensity1");
  refused("2.1 x 25 2\n" + mask_line({3}) + "5 1\n", "frame 5: the header says 2 frames");
  refused("2.1 x 25 3\n" + mask_line({3}) + "1 1\n" + mask_line({3}) + "0 2\n",
          "frame 0 comes after frame 1");
  FapLimits small;
  small.max_bytes = 10;
  CHECK_THROWS_WITH(parse_fap("2.1 x 25 0\n      ", "big.fap", small),
                    Catch::Contains("big.fap: 17 bytes, more than 10"));
}

TEST_CASE("FAP units and directions measured on a rig's feature points", "[anim][fap]") {
  const FapRig& r = avatar_fap();
  const Fapu& u = r.fapu();
  // Proportions of a face: the mouth narrower than the eyes are apart, the eye-nose and
  // mouth-nose separations a fraction of it, the eye opening smaller still.
  CHECK(u.es0 > 0);
  CHECK(u.mw0 > 0.5 * u.es0);
  CHECK(u.mw0 < 1.5 * u.es0);
  CHECK(u.ens0 > 0.2 * u.es0);
  CHECK(u.ens0 < 1.5 * u.es0);
  CHECK(u.mns0 > 0.1 * u.es0);
  CHECK(u.mns0 < u.ens0);
  CHECK(u.irisd0 < 0.5 * u.es0);
  // Directions as ISO/IEC 14496-2 gives them.
  CHECK(r.basis(3, shape("jawOpen")) > 200);                 // open_jaw: the chin goes down
  CHECK(r.basis(52, shape("jawOpen")) < -100);               // raise_b_midlip_o: the lower lip too
  CHECK(r.basis(19, shape("eyeBlinkLeft")) > 300);           // close_t_l_eyelid: down
  CHECK(std::abs(r.basis(20, shape("eyeBlinkLeft"))) < 30);  // not the right eye
  CHECK(r.basis(20, shape("eyeBlinkRight")) > 300);
  CHECK(r.basis(31, shape("browInnerUp")) > 20);  // raise_l_i_eyebrow: up
  CHECK(r.basis(32, shape("browInnerUp")) > 20);
  CHECK(r.basis(53, shape("mouthStretchLeft")) > 0);  // stretch_l_cornerlip_o: to the left
  CHECK(r.basis(59, shape("mouthSmileLeft")) > 20);   // raise_l_cornerlip_o: up
  CHECK(r.measured(3));
  CHECK(r.measured(48));
  CHECK_FALSE(r.measured(23));  // eyeballs: no landmark
  CHECK_FALSE(r.measured(65));  // ears
}

TEST_CASE("a performance written as FAPs and read back moves the mouth and eyes alike",
          "[anim][fap]") {
  const FapRig& r = avatar_fap();
  const Mapping mapping = Mapping::for_rig(ict_face().shape_names());
  viseme::Options o = viseme::load_options();
  const auto u = viseme::analyze(
      "(joy, 40, 0.5) Papa made a big apple pie, maybe more. Mother baked bread for the whole "
      "village, and everybody came by to eat it warm.",
      o);
  AnimOptions ao;
  ao.idle = true;  // blinks and head motion go through the file too
  const Performance p(u, mapping, ao);
  const FapSequence written = to_fap(p, r, 30);
  const std::string text = to_fap_text(written);
  const FapSequence read = parse_fap(text, "round.fap");
  REQUIRE(read.frames.size() == written.frames.size());
  CHECK(read.frames[10].mask[0]);         // FAP 1
  CHECK(read.frames[10].mask[2]);         // open_jaw
  CHECK_FALSE(read.frames[10].mask[22]);  // yaw_l_eyeball: not measured

  const FapMotion back(read, r, mapping);
  const std::size_t n = ict_face().shapes.size();
  std::vector<float> a(n), b(n);
  std::vector<double> jaw_a, jaw_b, blink_a, blink_b;
  double head_error = 0;
  int with_viseme = 0, a_frames = 0;
  for (std::size_t f = 0; f < read.frames.size(); ++f) {
    const double t = static_cast<double>(f) / 30;
    rig::BodyPose ha, hb;
    p.sample(t, a, &ha);
    back.sample(t, b, &hb);
    jaw_a.push_back(a[static_cast<std::size_t>(shape("jawOpen"))]);
    jaw_b.push_back(b[static_cast<std::size_t>(shape("jawOpen"))]);
    blink_a.push_back(a[static_cast<std::size_t>(shape("eyeBlinkLeft"))]);
    blink_b.push_back(b[static_cast<std::size_t>(shape("eyeBlinkLeft"))]);
    head_error = std::max(head_error, static_cast<double>(std::abs(ha.yaw - hb.yaw)));
    with_viseme += read.frames[f].viseme.select1 != 0;
    a_frames += read.frames[f].viseme.select1 == 10;
  }
  INFO("jaw " << correlation(jaw_a, jaw_b) << ", blink " << correlation(blink_a, blink_b));
  REQUIRE(*std::max_element(blink_a.begin(), blink_a.end()) > 0.9f);  // it blinks
  CHECK(correlation(jaw_a, jaw_b) >= 0.9);
  CHECK(correlation(blink_a, blink_b) >= 0.9);
  CHECK(head_error < 1e-4);  // 1 AU = 1e-5 rad, rounded
  CHECK(with_viseme > static_cast<int>(read.frames.size()) / 2);
  CHECK(a_frames > 0);  // "papa", "made": A:
  // FAP 2 carries the joy tag.
  CHECK(read.frames[read.frames.size() / 2].expression.select1 == 1);
  CHECK(read.frames[read.frames.size() / 2].expression.intensity1 > 20);
}

TEST_CASE("hand-written FAP files drive a rig", "[anim][fap]") {
  const int jaw = shape("jawOpen");
  SECTION("FAP 1 alone: the jaw opens on A and the lips meet on p") {
    const FapMotion m = drive_avatar("visemes.fap");
    CHECK(m.frame_count() == 12);
    const float p = weights_at(m, 0)[static_cast<std::size_t>(jaw)];
    const float a = weights_at(m, 3)[static_cast<std::size_t>(jaw)];
    CHECK(a > p + 0.2f);
    CHECK(weights_at(m, 11)[static_cast<std::size_t>(jaw)] < 0.05f);  // none: rest
  }
  SECTION("low-level FAPs: the jaw follows open_jaw, the lids close, the head turns") {
    const FapMotion m = drive_avatar("jaw_and_blink.fap");
    std::vector<float> jaw_by_frame;
    for (int f = 0; f < 6; ++f)
      jaw_by_frame.push_back(weights_at(m, f)[static_cast<std::size_t>(jaw)]);
    CHECK(jaw_by_frame[0] < 0.05f);
    CHECK(jaw_by_frame[1] > jaw_by_frame[0]);
    CHECK(jaw_by_frame[2] > jaw_by_frame[1]);
    CHECK(jaw_by_frame[3] == Approx(jaw_by_frame[2]));  // not listed: repeats frame 2
    CHECK(jaw_by_frame[4] > jaw_by_frame[3]);
    CHECK(jaw_by_frame[5] < jaw_by_frame[4]);
    CHECK(weights_at(m, 7)[static_cast<std::size_t>(shape("eyeBlinkLeft"))] > 0.6f);
    CHECK(weights_at(m, 7)[static_cast<std::size_t>(shape("eyeBlinkRight"))] > 0.6f);
    CHECK(weights_at(m, 9)[static_cast<std::size_t>(shape("eyeBlinkLeft"))] < 0.1f);
    rig::BodyPose head;
    weights_at(m, 11, &head);
    CHECK(head.pitch == Approx(0.05));
    CHECK(head.yaw == Approx(-0.08));
  }
  SECTION("FAP 2 joy rises; decimal brow values lift the brows") {
    const FapMotion m = drive_avatar("joy.fap");
    const auto first = weights_at(m, 0), last = weights_at(m, 7);
    CHECK(last[static_cast<std::size_t>(shape("mouthSmileLeft"))] >
          first[static_cast<std::size_t>(shape("mouthSmileLeft"))] + 0.2f);
    CHECK(last[static_cast<std::size_t>(shape("browInnerUp"))] > 0.3f);
  }
}

TEST_CASE("a rig whose detector dropped some landmarks still speaks the FAPs it can",
          "[anim][fap]") {
  // The built-in avatar's stored landmarks lack 37, 43 and 44 (upper lids).
  const rig::Rig& a = avatar::default_avatar();
  const auto landmarks = rigbuild::known_landmarks(a);
  REQUIRE(landmarks);
  REQUIRE((*landmarks)[43] < 0);
  const FapRig r(a, *landmarks);
  CHECK(r.fapu().es0 > 0);
  CHECK(r.fapu().irisd0 > 0);
  CHECK_FALSE(r.measured(19));  // close_t_l_eyelid: both its points are missing
  CHECK(r.measured(53));        // stretch_l_cornerlip_o
  CHECK(r.basis(3, a.find_shape("jawOpen")) > 200);
  // Without the mouth's middle there are no units at all.
  auto broken = *landmarks;
  broken[62] = broken[66] = -1;
  CHECK_THROWS_WITH(FapRig(a, broken), Catch::Contains("landmark 62"));
}
