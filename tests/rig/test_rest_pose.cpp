// The rest pose on a humanoid made in code (humanoid.hpp) saved in T-pose or A-pose with
// Mixamo's and others' joint names: the arms come down, the face stays.
#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>

#include "facecast/rig/rest_pose.hpp"
#include "humanoid.hpp"
#include "test_data.hpp"

using namespace facecast::rig;

namespace {

using facecast::test::humanoid;
using facecast::test::kDeg;

Eigen::Vector3f extent(const Rig& r) {
  return r.positions.colwise().maxCoeff() - r.positions.colwise().minCoeff();
}

}  // namespace

TEST_CASE("an avatar saved in T- or A-pose stands with its arms down", "[rig][pose]") {
  const Rig t_pose = humanoid(0);
  Rig rest = t_pose;
  const PoseReport report = apply_rest_pose(rest);
  REQUIRE(report.turned.size() == 2);
  CHECK(report.turned[0].first == "mixamorig:LeftArm");
  CHECK(report.turned[0].second == Approx(80).margin(0.5));
  // The figure: wider than tall with its arms out, well under its height with them down.
  CHECK(extent(t_pose).x() > extent(t_pose).y());
  CHECK(extent(rest).x() < 0.6f * extent(rest).y());
  // The hands hang 10 degrees outward of straight down, below the hips' joint.
  const Eigen::Vector3f hand = rest.skeleton.rest_origin[3],
                        shoulder = rest.skeleton.rest_origin[1];
  CHECK(hand.y() < 1.0f);
  CHECK(std::atan2(hand.x() - shoulder.x(), shoulder.y() - hand.y()) / kDeg ==
        Approx(10).margin(0.5));
  CHECK(rest.skeleton.rest_origin[6].x() == Approx(-hand.x()));
  // The left arm's normals turned with it (80 degrees clockwise about +Z, seen from the front);
  // the torso, the head and its shape are untouched.
  const Eigen::Matrix3f turn = Eigen::AngleAxisf(-80 * kDeg, Eigen::Vector3f::UnitZ()).matrix();
  for (int v = 16; v < 24; ++v)
    CHECK(rest.normals.row(v).dot((turn * t_pose.normals.row(v).transpose()).transpose()) >
          0.9999f);
  CHECK(rest.positions.topRows(16).isApprox(t_pose.positions.topRows(16)));
  CHECK(rest.shapes[0].deltas.isApprox(t_pose.shapes[0].deltas));
  CHECK(rest.skeleton.rest_origin[8] == t_pose.skeleton.rest_origin[8]);

  SECTION("an A-pose ends where the T-pose does") {
    Rig a = humanoid(45);
    const PoseReport ra = apply_rest_pose(a);
    REQUIRE(ra.turned.size() == 2);
    CHECK(ra.turned[1].second == Approx(35).margin(0.5));
    CHECK((a.skeleton.rest_origin[3] - hand).norm() < 1e-4f);
  }
  SECTION("arms already down stay, and a second pass changes nothing") {
    Rig again = rest;
    CHECK(apply_rest_pose(again).turned.empty());
    CHECK(again.positions == rest.positions);
  }
  SECTION("VRM's humanoid bones name arms that no table knows") {
    Rig vrm = humanoid(0, "Bone.003", "Bone.007");
    Rig unnamed = vrm;
    CHECK(apply_rest_pose(unnamed).turned.empty());
    vrm.skeleton.humanoid = {{"leftUpperArm", 1}, {"rightUpperArm", 4}};
    CHECK(apply_rest_pose(vrm).turned.size() == 2);
    CHECK(vrm.positions.isApprox(rest.positions, 1e-5f));
  }
  SECTION("other name sets: VRoid, Unreal, MakeHuman, Rigify") {
    for (const auto& [l, r] :
         std::vector<std::pair<const char*, const char*>>{{"J_Bip_L_UpperArm", "J_Bip_R_UpperArm"},
                                                          {"upperarm_l", "upperarm_r"},
                                                          {"upperarm01.L", "upperarm01.R"},
                                                          {"DEF-upper_arm.L", "DEF-upper_arm.R"}}) {
      Rig other = humanoid(0, l, r);
      INFO(l);
      CHECK(apply_rest_pose(other).turned.size() == 2);
    }
  }
  CHECK(parse_pose("rest", "--pose").kind == Pose::Kind::kRest);
  CHECK(parse_pose("bind", "--pose").kind == Pose::Kind::kBind);
  CHECK_THROWS_WITH(parse_pose("sit", "--pose"),
                    Catch::Contains("--pose") && Catch::Contains("sit"));
}

TEST_CASE("the rest pose relaxes the hands: fingers curl toward the palm, the thumb stays",
          "[rig][pose]") {
  // The T-posed humanoid's left hand (joint 3, palm down) with four fingers of four joints along
  // +X, spread in z, and a thumb pointing forward (+Z).
  Rig r = humanoid(0);
  Skeleton& s = r.skeleton;
  const Eigen::Vector3f hand = s.rest_origin[3];
  const auto add_chain = [&](const std::string& name, Eigen::Vector3f at,
                             const Eigen::Vector3f& step, int joints) {
    int parent = 3;
    for (int k = 0; k < joints; ++k, at += step) {
      s.joint_names.push_back(name + std::to_string(k + 1));
      s.parent.push_back(parent);
      s.rest_origin.push_back(at);
      parent = static_cast<int>(s.parent.size()) - 1;
    }
    return static_cast<int>(s.parent.size()) - joints;
  };
  const int index =
      add_chain("LeftHandIndex", hand + Eigen::Vector3f(0.05f, 0, 0.03f), {0.03f, 0, 0}, 4);
  for (const float z : {0.01f, -0.01f, -0.03f})
    add_chain("LeftHandFinger", hand + Eigen::Vector3f(0.05f, 0, z), {0.03f, 0, 0}, 4);
  const int thumb =
      add_chain("LeftHandThumb", hand + Eigen::Vector3f(0.02f, 0, 0.05f), {0.01f, 0, 0.03f}, 3);
  r.validate("hand");
  const auto at = [&](int j) { return r.skeleton.rest_origin[static_cast<std::size_t>(j)]; };
  const auto angle = [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0f, 1.0f)) / kDeg;
  };
  const float thumb_before = angle(at(thumb + 2) - at(thumb), at(3) - at(2));

  const PoseReport report = apply_rest_pose(r);
  CHECK(report.turned.size() == 4 * 3 + 2);     // three joints of each finger, and both arms
  const Eigen::Vector3f along = at(3) - at(2);  // the hand's direction, now down
  // Each joint curls by configs/rig/humanoid.json's 15, 25 and 15 degrees.
  CHECK(angle(at(index + 1) - at(index), along) == Approx(15).margin(0.5));
  CHECK(angle(at(index + 2) - at(index + 1), along) == Approx(40).margin(0.5));
  CHECK(angle(at(index + 3) - at(index + 2), along) == Approx(55).margin(0.5));
  // Toward the palm: down in the T-pose, turned inward (-X) with the arm.
  const Eigen::Vector3f palm = along.cross(Eigen::Vector3f::UnitZ()).normalized();
  CHECK(palm.x() < -0.9f);
  CHECK((at(index + 3) - at(index)).dot(palm) > 0.02f);
  CHECK(angle(at(thumb + 2) - at(thumb), along) == Approx(thumb_before).margin(0.5));
}

TEST_CASE("a pose file turns the bones it names", "[rig][pose]") {
  const auto dir = facecast::test::scratch_dir();
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  const Rig t_pose = humanoid(0);
  // The rest pose written as a file: the left arm by its VRM name (through the name table), the
  // right by its joint's own name; a quaternion and Euler angles (80 degrees about z each way).
  const float s = std::sin(40 * kDeg), c = std::cos(40 * kDeg);
  const Pose pose =
      parse_pose(write("rest.json", "{\"leftUpperArm\": {\"rotation\": [0, 0, " +
                                        std::to_string(-s) + ", " + std::to_string(c) +
                                        "]}, \"mixamorig:RightArm\": {\"euler_deg\": [0, 0, 80], "
                                        "\"position\": [0, 1, 0]}}"),
                 "--pose");
  REQUIRE(pose.kind == Pose::Kind::kFile);
  REQUIRE(pose.bones.size() == 2);
  Rig posed = t_pose, rest = t_pose;
  const PoseReport report = apply_pose(posed, pose);
  REQUIRE(report.turned.size() == 2);
  CHECK(report.turned[1].second == Approx(80).margin(0.01));
  (void)apply_rest_pose(rest);
  CHECK(posed.positions.isApprox(rest.positions, 1e-4f));
  CHECK(posed.skeleton.rest_origin[3].isApprox(rest.skeleton.rest_origin[3], 1e-4f));
  CHECK(posed.positions.topRows(16) == t_pose.positions.topRows(16));  // torso and head stay

  SECTION("a VRM 0.x figure (turned to face +Z when read) turns as any other") {
    Rig vrm0 = t_pose;
    vrm0.skeleton.vrm0 = true;
    vrm0.skeleton.humanoid = {{"leftUpperArm", 1}, {"rightUpperArm", 4}};
    const Pose raise = parse_pose(
        write("raise.json", "{\"leftUpperArm\": {\"euler_deg\": [0, 0, 30]}}"), "--pose");
    Rig a = t_pose, b = vrm0;
    (void)apply_pose(a, raise);
    (void)apply_pose(b, raise);
    // 30 degrees about +Z raises the figure's left arm (+X) above the shoulder.
    const auto rise = [](const Rig& r) {
      return r.skeleton.rest_origin[3].y() - r.skeleton.rest_origin[1].y();
    };
    CHECK(rise(a) > 0.1f);
    CHECK(rise(b) == Approx(rise(a)).margin(1e-5));
  }
  SECTION("bad files get one line naming the file and the field") {
    CHECK_THROWS_WITH(
        apply_pose(posed, parse_pose(write("tail.json", "{\"tail\": {\"euler_deg\": [0, 0, 1]}}"),
                                     "--pose")),
        Catch::Contains("tail.json") && Catch::Contains("tail") && Catch::Contains("no such bone"));
    CHECK_THROWS_WITH(
        parse_pose(write("short.json", "{\"head\": {\"rotation\": [0, 0, 1]}}"), "--pose"),
        Catch::Contains("short.json") && Catch::Contains("head.rotation"));
    CHECK_THROWS_WITH(
        parse_pose(write("zero.json", "{\"head\": {\"rotation\": [0, 0, 0, 0]}}"), "--pose"),
        Catch::Contains("zero length"));
    CHECK_THROWS_WITH(
        parse_pose(write("both.json", "{\"head\": {}}"), "--pose"),
        Catch::Contains("both.json") && Catch::Contains("head") && Catch::Contains("euler_deg"));
    CHECK_THROWS_WITH(parse_pose(write("scale.json",
                                       "{\"head\": {\"euler_deg\": [0, 0, 0], "
                                       "\"scale\": [2, 2, 2]}}"),
                                 "--pose"),
                      Catch::Contains("scale"));
    CHECK_THROWS_WITH(
        parse_pose(write("deep.json", std::string(100, '[') + std::string(100, ']')), "--pose"),
        Catch::Contains("deep.json") && Catch::Contains("deeper"));
    CHECK_THROWS_WITH(parse_pose((dir / "missing.json").string(), "--pose"),
                      Catch::Contains("missing.json"));
  }
}
