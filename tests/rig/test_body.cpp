// The body on a skeleton (rig/body.hpp): the joints a BodyPose turns, found by the VRM humanoid or
// from the head down, and what breath, shrug, lean and the head's turn do to the figure.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/rig/body.hpp"
#include "facecast/rig/rest_pose.hpp"
#include "humanoid.hpp"

using namespace facecast::rig;

namespace {

using facecast::test::kDeg;

// The humanoid standing at rest, and where its joints go in `pose`.
struct Posed {
  Rig rig;
  BodyJoints joints;
  explicit Posed(Rig r) : rig(std::move(r)) {
    apply_rest_pose(rig);
    joints = find_body_joints(rig.skeleton);
  }
  std::vector<Eigen::Affine3f> motion(const BodyPose& pose) const {
    return compose_turns(rig.skeleton, body_turns(joints, rig.skeleton, pose));
  }
  Eigen::Vector3f at(const BodyPose& pose, int joint) const {
    return motion(pose)[static_cast<std::size_t>(joint)] *
           rig.skeleton.rest_origin[static_cast<std::size_t>(joint)];
  }
};

float angle_deg(const Eigen::Matrix3f& r) {
  return Eigen::AngleAxisf(r).angle() / kDeg;
}

}  // namespace

TEST_CASE("the body's joints are found from the head down, or by the VRM humanoid", "[rig][body]") {
  const Rig mixamo = facecast::test::humanoid(0);
  BodyJoints b = find_body_joints(mixamo.skeleton);
  CHECK(b.head == 8);
  CHECK(b.neck == 7);
  CHECK(b.chest == 10);
  CHECK(b.spine == std::vector<int>{9});  // the hips (legs branch there) are not spine
  CHECK(b.shoulder[0] == 11);
  CHECK(b.shoulder[1] == 12);
  CHECK(b.upper_arm[0] == 1);
  CHECK(b.upper_arm[1] == 4);

  SECTION("by the VRM humanoid, whatever the names") {
    Rig vrm = facecast::test::humanoid(0, "Bone.003", "Bone.007");
    Skeleton& s = vrm.skeleton;
    for (auto& n : s.joint_names) n = "Bone." + std::to_string(&n - &s.joint_names[0]);
    s.head = s.neck = -1;
    s.humanoid = {{"hips", 0},           {"spine", 9},        {"chest", 10},
                  {"neck", 7},           {"head", 8},         {"leftShoulder", 11},
                  {"rightShoulder", 12}, {"leftUpperArm", 1}, {"rightUpperArm", 4}};
    const BodyJoints v = find_body_joints(s);
    CHECK(v.head == 8);
    CHECK(v.chest == 10);
    CHECK(v.spine == std::vector<int>{9});
    CHECK(v.shoulder[1] == 12);
  }
  SECTION("a skeleton without a head, or whose chest would be its root, turns no body") {
    Skeleton headless = mixamo.skeleton;
    headless.head = -1;
    headless.joint_names[8] = "Bone";
    CHECK(find_body_joints(headless).head == -1);
    CHECK(find_body_joints(headless).all().empty());
    Skeleton flat = mixamo.skeleton;  // the neck and the arms straight on the hips
    flat.parent = {-1, 0, 1, 2, 0, 4, 5, 0, 7, 0, 9, 10, 10, 0, 13, 0, 15};
    const BodyJoints f = find_body_joints(flat);
    CHECK(f.head == 8);
    CHECK(f.chest == -1);
    CHECK(f.all() == std::vector<int>{7, 8});
  }
}

TEST_CASE("breath, shrug, lean and the head's turn move the figure as a body would",
          "[rig][body]") {
  const Posed p(facecast::test::humanoid(0));
  const BodyPose rest;
  const int head = 8, left_hand = 3, right_hand = 6, left_arm = 1;
  // At rest nothing moves.
  for (const auto& m : p.motion(rest)) CHECK(m.matrix().isIdentity(1e-6f));

  SECTION("a breath raises the shoulders and the arms with them; the head keeps its direction") {
    BodyPose in;
    in.breath = 1;
    const auto m = p.motion(in);
    const Eigen::Vector3f hand0 = p.at(rest, left_hand), hand1 = p.at(in, left_hand);
    CHECK(hand1.y() > hand0.y() + 1e-3f);
    CHECK(std::abs(hand1.x() - hand0.x()) < 0.25f * (hand1.y() - hand0.y()) + 1e-3f);
    CHECK(angle_deg(m[head].linear()) < 0.01f);
    // The chest itself pitched back by breath_chest_deg.
    CHECK(angle_deg(m[10].linear()) == Approx(body_options().breath_chest_deg).margin(0.01));
  }
  SECTION("a shrug lifts the hands; the arms keep hanging") {
    BodyPose shrug;
    shrug.shrug = 1;
    const auto m = p.motion(shrug);
    for (const int hand : {left_hand, right_hand}) {
      const Eigen::Vector3f h0 = p.at(rest, hand), h1 = p.at(shrug, hand);
      CHECK(h1.y() - h0.y() > 0.005f);
      CHECK(std::abs(h1.x() - h0.x()) < 0.3f * (h1.y() - h0.y()));
    }
    // The upper arm's net rotation is none: the shoulder's raise is turned back.
    CHECK(angle_deg(m[left_arm].linear()) < 0.01f);
    CHECK(angle_deg(m[11].linear()) == Approx(body_options().shrug_deg).margin(0.01));
  }
  SECTION("a lean to the figure's left moves the head that way and mostly keeps it upright") {
    BodyPose lean;
    lean.lean = 0.05f;
    const auto m = p.motion(lean);
    const Eigen::Vector3f h1 = p.at(lean, head), h0 = p.at(rest, head);
    CHECK(h1.x() - h0.x() > 0.01f);  // +X: the figure's left (it faces +Z)
    CHECK(angle_deg(m[head].linear()) ==
          Approx((1 - body_options().lean_counter) * 0.05f / kDeg).margin(0.05));
  }
  SECTION("the head's turn is shared by the neck and the head") {
    BodyPose turn;
    turn.yaw = 0.3f;
    const auto m = p.motion(turn);
    CHECK(angle_deg(m[7].linear()) == Approx(body_options().neck_share * 0.3f / kDeg).margin(0.01));
    CHECK(angle_deg(m[head].linear()) == Approx(0.3f / kDeg).margin(0.01));
    CHECK(m[10].matrix().isIdentity(1e-6f));
  }
}
