// Spring bones (rig/spring_sim.hpp) on the code-made humanoid's ponytail: the hair trails a turn
// of the head and settles where the head carries it, the same for the same poses, at any frame
// rate; the head's collider keeps the hair out.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "facecast/rig/body.hpp"
#include "facecast/rig/spring_sim.hpp"
#include "humanoid.hpp"

using namespace facecast::rig;

namespace {

// The head: still for 0.5 s, turned 0.6 rad (yaw) over the next 0.2 s, then held.
BodyPose head_turn(double t) {
  BodyPose p;
  p.yaw = static_cast<float>(0.6 * std::clamp((t - 0.5) / 0.2, 0.0, 1.0));
  return p;
}

struct Ponytail {
  Rig rig = facecast::test::humanoid(0);
  BodyJoints joints;
  int tip = 0;  // Hair3: the second spring joint's tail
  Ponytail() {
    facecast::test::add_ponytail(rig);
    joints = find_body_joints(rig.skeleton);
    tip = static_cast<int>(rig.skeleton.joint_names.size()) - 1;
  }
  // Where joint `j` (default: the tip) is with the body in `pose` and the springs turned as
  // `springs` says.
  Eigen::Vector3f tip_at(const BodyPose& pose, const JointTurns& springs, int j = -1) const {
    JointTurns turns = body_turns(joints, rig.skeleton, pose);
    turns.insert(turns.end(), springs.begin(), springs.end());
    const auto motion = compose_turns(rig.skeleton, turns);
    const auto t = static_cast<std::size_t>(j < 0 ? tip : j);
    return motion[static_cast<std::size_t>(rig.skeleton.parent[t])] * rig.skeleton.rest_origin[t];
  }
  // The tip's distance from where the head alone would carry it, per frame at `fps` to `end`.
  std::vector<float> lag(double fps, double end, SpringSim sim) const {
    std::vector<float> out;
    for (int f = 0; f / fps <= end + 1e-9; ++f) {
      const BodyPose pose = head_turn(f / fps);
      out.push_back((tip_at(pose, sim.advance(pose, f / fps)) - tip_at(pose, {})).norm());
    }
    return out;
  }
};

}  // namespace

TEST_CASE("spring-bone hair trails a turn of the head and settles when it stops", "[rig][spring]") {
  const Ponytail p;
  const SpringSim sim(p.rig.skeleton);
  REQUIRE_FALSE(sim.empty());
  const std::vector<float> lag = p.lag(30, 4, sim);
  // At rest before the turn (no gravity: the rest shape is the balance).
  for (int f = 0; f < 15; ++f) CHECK(lag[static_cast<std::size_t>(f)] < 1e-5f);
  // While the head turns and just after: the tip is left behind by centimetres.
  float most = 0;
  for (int f = 15; f < 36; ++f) most = std::max(most, lag[static_cast<std::size_t>(f)]);
  CHECK(most > 0.03f);
  // Settled within a millimetre three seconds after the head stopped, and still.
  CHECK(lag.back() < 1e-3f);
  CHECK(std::abs(lag.back() - lag[lag.size() - 2]) < 1e-4f);

  // The same poses give the same motion; half the frame rate moves the hair within 5 mm of it
  // (the steps are fixed; the pose between frames is interpolated).
  CHECK(p.lag(30, 4, sim) == lag);
  const std::vector<float> half = p.lag(15, 4, sim);
  for (std::size_t f = 0; f < half.size(); ++f) CHECK(std::abs(half[f] - lag[2 * f]) < 5e-3f);
}

TEST_CASE("a collider keeps the spring bones' tails out", "[rig][spring]") {
  // The ponytail held out level behind the head falls under gravity; a sphere below its path (on
  // the head, as a shoulder's would be) catches it.
  const auto nearest = [](bool collide) {
    Ponytail p;
    Skeleton& s = p.rig.skeleton;
    auto& spring = s.springs.springs[0];
    for (int k = 0; k < 2; ++k) {
      const auto j = static_cast<std::size_t>(p.tip - 1 + k);
      s.rest_origin[j] = {0, 1.7f, -0.12f - 0.2f * static_cast<float>(k + 1)};
      spring.joints[static_cast<std::size_t>(k)].tail = s.rest_origin[j];
    }
    for (auto& j : spring.joints) {
      j.gravity_power = 3;
      j.stiffness = 0;
    }
    const Eigen::Vector3f centre(0, 1.55f, -0.3f);
    s.springs.colliders[0].offset = s.springs.colliders[0].tail = centre;
    if (!collide) spring.colliders.clear();
    SpringSim sim(s);
    float closest = 1e9f;
    for (int f = 0; f < 60; ++f) {
      const JointTurns& springs = sim.advance({}, f / 30.0);
      closest = std::min(closest, (p.tip_at({}, springs, p.tip - 1) - centre).norm());
    }
    return closest;
  };
  CHECK(nearest(false) < 0.05f);
  CHECK(nearest(true) > 0.1f - 1e-3f);
}
