// The rest pose on a humanoid made in code (humanoid.hpp) saved in T-pose or A-pose with
// Mixamo's and others' joint names: the arms come down, the face stays.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/rig/rest_pose.hpp"
#include "humanoid.hpp"

using namespace facecast::rig;

namespace {

constexpr float kDeg = 3.14159265f / 180.0f;
using facecast::test::humanoid;

Eigen::Vector3f extent(const Rig& r) {
  return r.positions.colwise().maxCoeff() - r.positions.colwise().minCoeff();
}

}  // namespace

TEST_CASE("an avatar saved in T- or A-pose stands with its arms down", "[rig][pose]") {
  const Rig t_pose = humanoid(0);
  Rig rest = t_pose;
  const RestPoseReport report = apply_rest_pose(rest);
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
    const RestPoseReport ra = apply_rest_pose(a);
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
    vrm.skeleton.left_upper_arm = 1;
    vrm.skeleton.right_upper_arm = 4;
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
  CHECK(parse_pose("rest", "--pose") == Pose::kRest);
  CHECK_THROWS_WITH(parse_pose("sit", "--pose"),
                    Catch::Contains("--pose") && Catch::Contains("sit"));
}
