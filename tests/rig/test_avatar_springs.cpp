// Spring bones as VRM files hold them: VRMC_springBone (VRM 1.0) and VRM 0.x's secondaryAnimation
// read into the skeleton at rest in the rig's axes, and the hair they move in rendered frames.
#include <tiny_gltf.h>

#include <algorithm>
#include <catch2/catch.hpp>

#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/rig_io.hpp"
#include "spring_avatar.hpp"

using namespace facecast;
using tinygltf::Value;

namespace {

Value number(double x) {
  return Value(x);
}
using test::object;
Value ints(std::initializer_list<int> xs) {
  return test::array_of(xs);
}

int joint(const rig::Rig& r, const std::string& name) {
  const auto& n = r.skeleton.joint_names;
  return static_cast<int>(std::find(n.begin(), n.end(), name) - n.begin());
}

Eigen::Vector3f origin(const rig::Rig& r, const std::string& name) {
  return r.skeleton.rest_origin[static_cast<std::size_t>(joint(r, name))];
}

rig::Rig vrm1_ponytail() {
  return rig::parse_glb(test::ponytail_vrm(), "ponytail1.vrm");
}

}  // namespace

TEST_CASE("VRMC_springBone springs and colliders are read at rest", "[rig][gltf][spring]") {
  const rig::Rig r = vrm1_ponytail();
  const auto& sb = r.skeleton.springs;
  REQUIRE(sb.springs.size() == 1);
  const auto& joints = sb.springs[0].joints;
  REQUIRE(joints.size() == 2);  // the last joint is the second one's tail
  CHECK(joints[0].joint == joint(r, "Hair1"));
  CHECK(joints[1].joint == joint(r, "Hair2"));
  CHECK((joints[0].tail - origin(r, "Hair2")).norm() < 1e-5f);
  CHECK((joints[1].tail - origin(r, "Hair3")).norm() < 1e-5f);
  CHECK(joints[0].drag == Approx(0.4f));
  CHECK(joints[0].hit_radius == Approx(0.02f));
  CHECK(joints[0].gravity_power == 0.0f);
  REQUIRE(sb.colliders.size() == 1);
  CHECK(sb.colliders[0].joint == joint(r, "mixamorig:Head"));
  CHECK((sb.colliders[0].offset - Eigen::Vector3f(0, 1.65f, 0)).norm() < 1e-5f);
  CHECK(sb.colliders[0].radius == Approx(0.1f));
  CHECK(sb.springs[0].colliders == std::vector<int>{0});
}

TEST_CASE("VRM 0.x secondaryAnimation is read turned to face +Z", "[rig][gltf][spring][vrm]") {
  const std::string bytes =
      test::ponytail_glb(false, [](tinygltf::Model& m, const test::NodeOf& node) {
        const Value group = object(
            {{"stiffiness", number(1.5)},
             {"dragForce", number(0.3)},
             {"gravityPower", number(0.2)},
             {"gravityDir", object({{"x", number(0.6)}, {"y", number(-0.8)}, {"z", number(0)}})},
             {"hitRadius", number(0.01)},
             {"bones", ints({node("Hair1")})},
             {"colliderGroups", ints({0})}});
        const Value colliders = object(
            {{"node", Value(node("mixamorig:Head"))},
             {"colliders",
              Value(Value::Array{object(
                  {{"offset", object({{"x", number(0)}, {"y", number(0.05)}, {"z", number(0.02)}})},
                   {"radius", number(0.1)}})})}});
        m.extensions["VRM"] = object(
            {{"secondaryAnimation", object({{"boneGroups", Value(Value::Array{group})},
                                            {"colliderGroups", Value(Value::Array{colliders})}})}});
        m.extensionsUsed.push_back("VRM");
      });
  const rig::Rig r = rig::parse_glb(bytes, "ponytail0.vrm");
  CHECK(r.skeleton.vrm0);
  const auto& sb = r.skeleton.springs;
  REQUIRE(sb.springs.size() == 1);
  const auto& joints = sb.springs[0].joints;
  // Every bone under the root, the leaf's tail 7 cm on along its bone.
  REQUIRE(joints.size() == 3);
  CHECK(joints[2].joint == joint(r, "Hair3"));
  CHECK((joints[1].tail - origin(r, "Hair3")).norm() < 1e-5f);
  const Eigen::Vector3f along = (origin(r, "Hair3") - origin(r, "Hair2")).normalized();
  CHECK((joints[2].tail - (origin(r, "Hair3") + 0.07f * along)).norm() < 1e-5f);
  CHECK(joints[0].stiffness == Approx(1.5f));
  // The file's gravity and collider offset (Unity's axes: z negated) in the turned figure's axes.
  CHECK((joints[0].gravity_dir - Eigen::Vector3f(-0.6f, -0.8f, 0)).norm() < 1e-5f);
  REQUIRE(sb.colliders.size() == 1);
  CHECK((sb.colliders[0].offset - Eigen::Vector3f(0, 1.65f, 0.02f)).norm() < 1e-5f);
}

TEST_CASE("spring-bone hair swings in rendered frames and settles", "[rig][render][spring]") {
  const rig::Rig r = vrm1_ponytail();
  render::RenderOptions o;
  o.width = o.height = 128;
  o.contexts = 1;
  render::Renderer renderer(r, o);
  // Seen from the figure's right, where the ponytail hangs behind the head.
  render::Camera side;
  side.eye = {3, 1.45f, 0};
  side.target = {0, 1.45f, 0};
  renderer.set_camera(side);
  const std::vector<float> neutral(r.shapes.size(), 0.0f);
  rig::SpringSim springs = renderer.spring_sim();
  REQUIRE_FALSE(springs.empty());
  // The head nods down 0.5 rad over 0.2 s from 0.5 s on and holds: rendered at 30 frames per
  // second with the springs and without (the hair carried rigidly by the head).
  double most = 0, last = 1;
  for (int f = 0; f <= 120; ++f) {
    const double t = f / 30.0;
    rig::BodyPose pose;
    pose.pitch = static_cast<float>(0.5 * std::clamp((t - 0.5) / 0.2, 0.0, 1.0));
    const rig::JointTurns& turns = springs.advance(pose, t);
    if (f % 6 != 0 && f != 120) continue;
    const double differ = render::compare_images(renderer.render(neutral, pose, turns),
                                                 renderer.render(neutral, pose))
                              .fraction_over;
    if (t < 0.5) CHECK(differ == 0.0);
    if (t <= 1.5) most = std::max(most, differ);
    last = differ;
  }
  INFO("most pixels apart while the head moved " << most << ", at 4 s " << last);
  CHECK(most > 0.004);
  CHECK(last < 0.0005);
}

TEST_CASE("spring bones past the limits are refused in one line; bad entries are skipped",
          "[rig][gltf][spring][hostile]") {
  // 1000 bone groups each listing the ponytail's root: 3000 joints to simulate per frame.
  const std::string many = test::ponytail_glb(false, [](tinygltf::Model& m,
                                                        const test::NodeOf& node) {
    Value::Array groups;
    for (int i = 0; i < 1000; ++i) groups.push_back(object({{"bones", ints({node("Hair1")})}}));
    m.extensions["VRM"] = object({{"secondaryAnimation", object({{"boneGroups", Value(groups)}})}});
  });
  CHECK_THROWS_WITH(rig::parse_glb(many, "many.vrm"),
                    Catch::Contains("VRM secondaryAnimation") && Catch::Contains("2048"));
  // Nodes out of range, colliders that name nothing, wrong types: left out, the rest read.
  const std::string bad = test::ponytail_glb(false, [](tinygltf::Model& m,
                                                       const test::NodeOf& node) {
    Value::Array joints{object({{"node", Value(node("Hair1"))}}), object({{"node", Value(99999)}}),
                        object({{"node", Value(std::string("Hair2"))}}),
                        object({{"node", Value(node("Hair2"))}, {"stiffness", Value(-5.0)}}),
                        object({{"node", Value(node("Hair3"))}})};
    m.extensions["VRMC_springBone"] =
        object({{"colliders", Value(Value::Array{object({{"node", Value(-1)}}), Value(3.0)})},
                {"colliderGroups", Value(Value::Array{object({{"colliders", ints({0, 1, 7})}})})},
                {"springs", Value(Value::Array{object(
                                {{"joints", Value(joints)}, {"colliderGroups", ints({0, 5})}})})}});
  });
  const rig::Rig r = rig::parse_glb(bad, "bad.vrm");
  REQUIRE(r.skeleton.springs.springs.size() == 1);
  const auto& joints = r.skeleton.springs.springs[0].joints;
  REQUIRE(joints.size() == 1);  // Hair2 -> Hair3; the pairs with a bad node are left out
  CHECK(joints[0].joint == joint(r, "Hair2"));
  CHECK(joints[0].stiffness == 0.0f);  // clamped
  CHECK(r.skeleton.springs.colliders.empty());
  CHECK(r.skeleton.springs.springs[0].colliders.empty());
}
